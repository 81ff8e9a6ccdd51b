"""The gait tracking measure (`sac.gait_search.track_gaits`, `quadcos.evaluation.gait_tracking`)
against the training's own step-0 evaluation: each run's searched gait (its action centre and
measured feed-forward in campaign.json) walked as `track` walks a finalist (`--robots` robots
each, 20 s, random commands under `--preset=command`'s randomisation, MJX-JAX on this machine),
beside the run's step-0 evaluation (the same gait under the untrained actor, on the GPU it
trained on):

    MENAGERIE_ROOT=DIR python experiments/commands/track_gaits.py --robot=unitree_go1 \\
        --runs go1cmd_tauyaw3gait_s0 ... --out=experiments/commands/track_gaits.json

With `--rescore A` it walks nothing: for runs that logged their finalists (`tracked_gaits`) it
prints the one `sac.gait_search.track_attitude=A` keeps and the one the run kept (`ran_with`):

    python experiments/commands/track_gaits.py --rescore 0.1 --runs go1cmd_tracked_s0 ...

A row per run: the measure's fall rate, speed and yaw-rate tracking RMS and score (−max(speed
RMS / 0.10, yaw-rate RMS / 0.15)), and the step-0 evaluation's; then how well the measure orders
the gaits as the step-0 evaluations do (Spearman's rank correlation of the scores) and, for each
pair of gaits, how often it prefers the one the step-0 evaluations prefer. The runs must train
the preset's env (their flags change the trainer or restate the preset's values).
"""

import argparse
import itertools
import json
from pathlib import Path

import ml_collections
import numpy as np
from training_summary import load_runs

from quadcos.evaluation import gait_tracking
from quadcos.training import presets

HERE = Path(__file__).parent


def gait_config(robot: str, run: dict) -> ml_collections.ConfigDict:
    """The command preset's env for `robot` (MJX-JAX) with `run`'s gait and feed-forward."""
    config = presets.build_config(
        presets.PRESETS["command"], {"env.robot": f"menagerie:{robot}", "env.impl": "jax"}
    ).env
    config.action_centre = run["action_centre"]
    for key, value in run["feed_forward"].items():
        config.commands[key] = tuple(value) if isinstance(value, list) else value
    return config


def ranks(values: list[float]) -> np.ndarray:
    """Each value's rank (0 the least), tied values sharing their ranks' mean."""
    values = np.asarray(values)
    found = np.empty(len(values))
    found[np.argsort(values, kind="stable")] = np.arange(len(values))
    for value in np.unique(values):
        found[values == value] = found[values == value].mean()
    return found


def spearman(a: list[float], b: list[float]) -> float:
    """Spearman's rank correlation of two equally long lists (ties by their mean ranks)."""
    return float(np.corrcoef(ranks(a), ranks(b))[0, 1])


def rescore(runs: dict, names: list[str], target: float) -> list[dict]:
    """Per run, the finalist its gait tracking would keep with `sac.gait_search.track_attitude`
    at `target` (rad), from the finalists' lines the run logged (`tracked_gaits` in
    campaign.json), as `gait_tracking.rank` orders them."""
    chosen = []
    for name in names:
        lines = runs[name]["tracked_gaits"]

        def rank(i: int, lines: list[dict] = lines) -> tuple:
            line = lines[i]
            attitude = max(line["roll"], line["pitch_error"])
            speed, yaw_rate = line["speed_rms"], line["yaw_rate_rms"]
            fell = line["fall_percent"] > 0
            return gait_tracking.rank(fell, speed, yaw_rate, attitude, attitude_target=target)

        best = max(range(len(lines)), key=rank)
        kept = next(i for i, line in enumerate(lines) if line["kept"])
        chosen.append({"run": name, "finalist": best + 1, "ran_with": kept + 1,
                       "score": round(rank(best)[2], 3), **lines[best]})  # fmt: skip
    return chosen


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robot", default="unitree_go1", help="a Menagerie name")
    parser.add_argument("--runs", nargs="+", required=True, help="runs in campaign.json")
    parser.add_argument("--robots", type=int, default=16, help="robots per gait")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--batch", type=int, default=128, help="robots a rollout at most")
    parser.add_argument("--out")
    parser.add_argument("--rescore", type=float, metavar="A",
                        help="walk nothing: print the finalist each run's logged gait tracking"
                        " (`tracked_gaits`) keeps with `sac.gait_search.track_attitude` A rad")
    args = parser.parse_args()
    runs = load_runs(HERE / "campaign.json")
    if args.rescore is not None:
        untracked = [name for name in args.runs if not (runs.get(name) or {}).get("tracked_gaits")]
        if untracked:
            parser.error(f"no run with tracked_gaits: {', '.join(untracked)}")
        for row in rescore(runs, args.runs, args.rescore):
            print(json.dumps(row))
        return
    missing = [
        name for name in args.runs
        if not all((runs.get(name) or {}).get(key) for key in ("action_centre", "feed_forward"))
    ]  # fmt: skip
    if missing:
        parser.error(f"no run with a searched gait and feed-forward: {', '.join(missing)}")
    configs = [gait_config(args.robot, runs[name]) for name in args.runs]
    per = max(1, args.batch // args.robots)  # gaits a rollout (MJX-JAX on a CPU hangs at 160)
    lines = [
        line
        for first in range(0, len(configs), per)
        for line in gait_tracking.track(
            "flat", configs[first:first + per], robots=args.robots, seed=args.seed
        )
    ]
    rows = []
    for name, line in zip(args.runs, lines):
        step0 = runs[name]["evaluations"][0]
        rows.append({
            "run": name,
            "measure": {key: round(value, 4) for key, value in line.items()},
            "step0": {"speed_tracking_rms": step0["speed_rms"],
                      "yaw_rate_tracking_rms": step0["yaw_rate_rms"],
                      "score": round(gait_tracking.score(step0["speed_rms"],
                                                         step0["yaw_rate_rms"]), 4)},
        })  # fmt: skip
        print(json.dumps(rows[-1]))
    measured = [r["measure"]["score"] for r in rows]
    trained = [r["step0"]["score"] for r in rows]
    pairs = [(i, j) for i, j in itertools.combinations(range(len(rows)), 2)
             if trained[i] != trained[j]]  # fmt: skip
    agree = sum((measured[i] > measured[j]) == (trained[i] > trained[j]) for i, j in pairs)
    summary = {"spearman": round(spearman(measured, trained), 3), "pairs": len(pairs),
               "pairs_ordered_alike": agree}  # fmt: skip
    print(json.dumps(summary))
    if args.out:
        record = {"robot": args.robot, "robots_per_gait": args.robots,
                  "seconds": gait_tracking.SECONDS, "seed": args.seed, "rows": rows, **summary}
        Path(args.out).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
