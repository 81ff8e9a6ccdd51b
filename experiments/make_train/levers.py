"""`make train` with and without a lever, seed by seed, one run after another on the CPU, and the
last evaluation of each run in one small JSON (no per-episode data).

    python experiments/make_train/levers.py --out=OUT --seeds 0 1 2 \\
        --arm base= --arm dist=--config.sac.critic_atoms=101 \\
        --record=experiments/make_train/critics.json

Each ARM is NAME=FLAGS (FLAGS space-separated, may be empty): the run `OUT/NAME_sSEED` trains
`python -m quadcos.train --preset=cpu --terrain=flat --seed=SEED FLAGS` (`make train`'s command).
A run already finished in OUT (its policy/ written) is read, not trained again. Each run's first
and last evaluation (16 robots, 25-s episodes, the policy's mean action) with the trainer's wall
seconds at it (`wall_time_s`) and its fastest evaluation.
"""

import argparse
import json
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from quadcos.training import metrics_log  # noqa: E402

MAKE_TRAIN = ("--preset=cpu", "--terrain=flat", "--no_progress")
KEPT = ("step", "wall_time_s", "eval/episode_reward", "eval/forward_speed", "eval/fall_rate")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=pathlib.Path, required=True)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--arm", action="append", required=True, help="NAME=FLAGS")
    parser.add_argument("--record", type=pathlib.Path, required=True)
    args = parser.parse_args(argv)
    arms = dict(_arm(text) for text in args.arm)
    runs = {}
    for seed in args.seeds:
        for name, flags in arms.items():
            run = f"{name}_s{seed}"
            _train(args.out / run, seed, flags)
            runs[run] = _last(args.out / run)
            print(run, json.dumps(runs[run]), flush=True)
    record = {
        "command": "python experiments/make_train/levers.py "
        + " ".join("--out=OUT" if a.startswith("--out=") else a for a in sys.argv[1:]),
        "train": "python -m quadcos.train " + " ".join(MAKE_TRAIN) + " --seed=SEED FLAGS",
        "arms": arms,
        "runs": runs,
    }
    args.record.write_text(json.dumps(record, indent=1) + "\n")
    return 0


def _arm(text: str) -> tuple[str, list[str]]:
    name, sep, flags = text.partition("=")
    if not sep or not name.isidentifier():
        raise SystemExit(f"levers.py: --arm {text!r} is not NAME=FLAGS")
    return name, flags.split()


def _train(run_dir: pathlib.Path, seed: int, flags: list[str]) -> None:
    """Trains the run unless it finished before (its policy/ written)."""
    if (run_dir / "policy").is_dir():
        return
    command = [sys.executable, "-m", "quadcos.train", *MAKE_TRAIN, f"--seed={seed}", *flags]
    run_dir.parent.mkdir(parents=True, exist_ok=True)
    with open(f"{run_dir}.log", "w") as log:
        subprocess.run(
            [*command, f"--output_dir={run_dir}"], cwd=ROOT, stdout=log, stderr=log, check=True
        )


def _last(run_dir: pathlib.Path) -> dict:
    rows = [
        row
        for row in metrics_log.read_rows(run_dir / "metrics.jsonl")
        if "eval/forward_speed" in row
    ]
    first, last = rows[0], rows[-1]
    return {
        "first": {key: first.get(key) for key in KEPT},
        "last": {key: last.get(key) for key in KEPT},
        "best_speed": max(row["eval/forward_speed"] for row in rows),
    }


if __name__ == "__main__":
    sys.exit(main())
