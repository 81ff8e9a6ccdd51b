r"""seeds.json from the `any_slope_seeds` runs: one row per seed of `--preset=any_slope`.

    python experiments/any_slope/seeds.py DIR --out experiments/any_slope/seeds.json [--runs REGEX]

DIR holds what `bash experiments/run_gpu.sh any_slope_seeds` (or `any_slope_lever`,
`any_slope_gpus`) wrote: runs/NAME/ (config.json, metrics.jsonl) and eval_NAME_{testset2026,
testset2027,testset4242,slope5,s4,flat}.json, for the run names REGEX matches (default
`any_slope_s\d+`); evaluations not there are null. `train_seconds` is the process's wall time
when `policy_best` was written (its `best_of_run.written_at_s`; runs from before the trainer
recorded it: the start of the evaluation whose policy it keeps, by the trainer's rule:
`best_policy_max_fall_rate`, then the evaluation reward); `first_chunk_s` the seconds from process
start to the first training chunk (the run's startup.json), `first_evaluation_s` to the step-0
evaluation (metrics.jsonl); `command` is the run's own command line.
Prints the rows as a Markdown table.
"""

import argparse
import json
import math
import pathlib
import re
import shlex
import sys

from quadcos.training import best_policy


def _read(path: pathlib.Path) -> dict | None:
    return json.loads(path.read_text()) if path.exists() else None


def _kept(metrics: list[dict], max_fall_rate: float) -> dict:
    """The evaluation row whose policy `policy_best` holds: the first of the highest rank
    (quadcos.training.best_policy.rank) among those with a finite reward."""
    rows = [row for row in metrics if math.isfinite(row.get("eval/episode_reward", math.nan))]
    ranks = [(*best_policy.rank(row, max_fall_rate), -index) for index, row in enumerate(rows)]
    return rows[-max(ranks)[2]]


def _written_at(run: pathlib.Path, kept: dict) -> float:
    """The run's wall time when `policy_best` was written (older runs: its evaluation's start)."""
    best = _read(run / "policy_best" / "policy.json")
    return ((best or {}).get("config", {}).get("best_of_run") or {}).get(
        "written_at_s", kept["wall_time_s"]
    )


def _command(argv: list[str]) -> str:
    """The training command of a run from its recorded argv: the last preset and the flags after
    it, without the output folder and the progress flag."""
    presets = [index for index, arg in enumerate(argv) if arg.startswith("--preset=")]
    flags = argv[presets[-1] :] if presets else argv
    kept = [arg for arg in flags if not arg.startswith(("--output_dir=", "--no_progress"))]
    return " ".join(["python -m quadcos.train", *map(shlex.quote, kept)])


def seed_row(folder: pathlib.Path, run: pathlib.Path) -> dict:
    name = run.name
    config = json.loads((run / "config.json").read_text())
    metrics = [
        json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines() if line
    ]
    sac = config["config"]
    kept = _kept(metrics, sac.get("best_policy_max_fall_rate", 1.0))
    levels = [row["train/course_level"] for row in metrics if "train/course_level" in row]
    evals = {
        key: _read(folder / f"eval_{name}_{key}.json")
        for key in ("testset2026", "testset2027", "testset4242", "slope5", "s4", "flat")
    }

    def success(key: str) -> float | None:
        return evals[key] and evals[key]["success_rate"]

    def testset(key: str, field: str):
        return evals[key] and evals[key][field]

    flat = evals["flat"]
    seed = int(sac["seed"])
    startup = _read(run / "startup.json")
    return {
        "run": name,
        "seed": seed,
        # Process start -> the first training chunk done (gait search and compiling included).
        "first_chunk_s": startup and round(startup["seconds"]["first_chunk"], 1),
        # Process start -> the step-0 evaluation logged (metrics.jsonl; runs without startup.json).
        "first_evaluation_s": round(metrics[0]["wall_time_s"], 1),
        "train_seconds": round(_written_at(run, kept), 1),
        "env_steps": int(kept["step"]),
        "last_env_steps": int(metrics[-1]["step"]),
        # The course curriculum's mean lane at the end (of 64, in order of slope) and the episodes
        # each env ran: a lane is climbed at most once per episode.
        "course_level": round(levels[-1], 1) if levels else None,
        "episodes_per_env": round(
            metrics[-1]["step"] / (sac["num_envs"] * sac["episode_length"]), 1
        ),
        "testset2026_mean": testset("testset2026", "mean_course_success_rate"),
        "testset2026_worst": testset("testset2026", "worst_course_success_rate"),
        "testset2026_worst_course": testset("testset2026", "worst_course"),
        "testset2027_mean": testset("testset2027", "mean_course_success_rate"),
        "testset2027_worst": testset("testset2027", "worst_course_success_rate"),
        "testset4242_mean": testset("testset4242", "mean_course_success_rate"),
        "testset4242_worst": testset("testset4242", "worst_course_success_rate"),
        "slope5": success("slope5"),
        "s4": success("s4"),
        "flat_success": success("flat"),
        "flat_speed_m_s": flat and flat["mean_forward_speed"],
        "flat_max_attitude_rad": flat
        and max(
            flat["mean_max_abs_pitch_error"], flat["mean_max_abs_roll"], flat["mean_max_abs_yaw"]
        ),
        "command": _command(config["run_info"]["argv"]),
    }


def _cell(value) -> str:
    if value is None:
        return "—"
    return f"{value:.3f}" if isinstance(value, float) else str(value)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folder", type=pathlib.Path)
    parser.add_argument("--out", type=pathlib.Path, required=True)
    parser.add_argument("--runs", default=r"any_slope_s\d+", help="regex of the run names")
    args = parser.parse_args(argv)
    runs = sorted(
        (run for run in (args.folder / "runs").glob("*") if re.fullmatch(args.runs, run.name)),
        key=lambda run: run.name,
    )
    if not runs:
        print(f"seeds.py: no runs/ matching {args.runs!r} in {args.folder}", file=sys.stderr)
        return 2
    rows = [seed_row(args.folder, run) for run in runs]
    args.out.write_text(json.dumps(rows, indent=2) + "\n")
    print_table(rows, [key for key in rows[0] if key != "command"])
    return 0


def print_table(rows: list[dict], keys: list[str]) -> None:
    """`rows` as a Markdown table of the columns `keys` (None: "—", floats to 3 decimals)."""
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for row in rows:
        print("| " + " | ".join(_cell(row[key]) for key in keys) + " |")


if __name__ == "__main__":
    sys.exit(main())
