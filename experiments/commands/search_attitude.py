"""The gait search's view of a gait's attitude against its evaluation's: each run's searched gait
(its action centre in campaign.json) scored as `--preset=command`'s gait search scores a
candidate (its env, its seconds, `--robots` robots each, MJX-JAX on this machine), beside the
run's kept policy under random commands with the training randomisation (1024 episodes on the
GPU; SAC moves a run's roll by at most 0.016 rad from its gait's: attitude.py):

    MENAGERIE_ROOT=DIR python experiments/commands/search_attitude.py --robot=unitree_go1 \\
        --runs go1cmd_tauyaw3gait_s0 go1cmd_tauyaw3gait_s1 ... \\
        --out=experiments/commands/search_attitude.json

A row per run: the search's mean peak roll and pitch error, fall rate and speed, and the
evaluation's roll and pitch error; then for each `--bounds` value of `sac.gait_search.max_attitude`
how many of the gaits whose evaluations meet the 0.10-rad targets it keeps and how many of those
that miss them it rules out, among the gaits that did not fall here (a gait that falls is out of
the search's ranking whatever its attitude; on MJX-JAX a gait searched on MJX-Warp may fall).
"""

import argparse
import json
from pathlib import Path

import numpy as np
from training_summary import load_runs

from quadcos.evaluation import fixed_search, gait_search
from quadcos.training import presets

HERE = Path(__file__).parent
TARGET = 0.10  # rad, roll and pitch error (issue 58)


def search_env(robot: str) -> tuple[dict, float]:
    """The env overrides a command preset's gait search runs its candidates in, and its
    seconds."""
    config = presets.build_config(
        presets.PRESETS["command"], {"env.robot": f"menagerie:{robot}", "env.impl": "jax"}
    )
    return gait_search.candidate_overrides(config), config.sac.gait_search.seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--robot", default="unitree_go1", help="a Menagerie name")
    parser.add_argument("--runs", nargs="+", required=True, help="runs in campaign.json")
    parser.add_argument("--robots", type=int, default=8, help="robots per gait")
    parser.add_argument("--bounds", type=float, nargs="+", default=[0.08, 0.085, 0.09, 0.095, 0.1])
    parser.add_argument("--out")
    args = parser.parse_args()
    runs = load_runs(HERE / "campaign.json")
    missing = [name for name in args.runs if not (runs.get(name) or {}).get("action_centre")]
    if missing:
        parser.error(f"no run with a searched gait in campaign.json: {', '.join(missing)}")
    gaits = np.array([[float(v) for v in runs[n]["action_centre"].split(",")] for n in args.runs])
    overrides, seconds = search_env(args.robot)
    scored = fixed_search.score_gaits(
        "flat", gaits, robots=args.robots, seconds=seconds, env_overrides=overrides
    )
    rows = []
    for name, entry in zip(args.runs, scored):
        evaluation = runs[name]["kept"]
        rows.append({
            "run": name,
            "search": {key: round(entry[key], 4) for key in (
                "mean_max_abs_roll", "mean_max_abs_pitch_error", "fall_rate", "mean_forward_speed"
            )},
            "evaluation": {
                key: evaluation[key] for key in ("mean_max_abs_roll", "mean_max_abs_pitch_error")
            },
        })
        print(json.dumps(rows[-1]))
    standing = [r for r in rows if r["search"]["fall_rate"] == 0]
    meets = [max(r["evaluation"].values()) <= TARGET for r in standing]
    peaks = [max(r["search"]["mean_max_abs_roll"], r["search"]["mean_max_abs_pitch_error"])
             for r in standing]
    print(f"{len(rows) - len(standing)} of {len(rows)} gaits fell here: left out below")
    bounds_table = []
    for bound in args.bounds:
        kept = sum(p <= bound for p, m in zip(peaks, meets) if m)
        ruled_out = sum(p > bound for p, m in zip(peaks, meets) if not m)
        bounds_table.append({"max_attitude": bound, "keeps_meeting": kept,
                             "rules_out_missing": ruled_out})
        print(f"max_attitude {bound:g}: keeps {kept} of the {sum(meets)} gaits that meet the"
              f" targets, rules out {ruled_out} of the {len(meets) - sum(meets)} that miss them")
    if args.out:
        record = {"robot": args.robot, "robots_per_gait": args.robots, "seconds": seconds,
                  "rows": rows, "fell": len(rows) - len(standing), "bounds": bounds_table}
        Path(args.out).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
