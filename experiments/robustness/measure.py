"""A policy under the robustness table's perturbations, one at a time.

    python experiments/robustness/measure.py --policy=experiments/policies/flat --num_envs=256 \
        --out=experiments/robustness/flat_trained_without.json
    python experiments/robustness/measure.py --table experiments/robustness/*.json   # Markdown
    python experiments/robustness/measure.py --rows experiments/robustness/levers_gpu/*.json

Each condition is `quadcos.evaluate`'s deterministic evaluation (flat, 20-s episodes, the same
seeds) with `env.randomization` enabled and every range fixed to one value: the nominal robot
(`quadcos.env.randomization.NOMINAL`: friction 1.5 as in the paper's robot's MJCF and at the top
of the training range; Go1, Go2 and ANYmal C's feet have 0.8 in theirs; scales 1, no latency, no
pushes) except for the one
perturbation. `--env randomization.friction='(0.8, 0.8)'` moves the nominal friction.
"""

import argparse
import json
import time
from pathlib import Path

from quadcos.env.randomization import CONDITIONS

# Gait quality beside survival (quadcos.evaluation's keys; null where a policy has no commands).
GAIT_KEYS = (
    "speed_tracking_rms",
    "yaw_rate_tracking_rms",
    "mean_max_abs_pitch_error",
    "mean_max_abs_roll",
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--table", nargs="+", help="print the Markdown table of these outputs")
    parser.add_argument(
        "--rows", nargs="+", help="print these outputs as Markdown rows (one a policy)"
    )
    parser.add_argument("--policy")
    parser.add_argument("--num_envs", type=int, default=256)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--out")
    parser.add_argument(
        "--commands", help="velocity commands to follow (quadcos.evaluate's --commands)"
    )
    parser.add_argument(
        "--conditions", nargs="+", choices=list(CONDITIONS), default=list(CONDITIONS),
        help="measure only these (default: all)",
    )
    parser.add_argument(
        "--env", action="append", default=[], metavar="KEY=VALUE",
        help="an env config override under every condition (repeatable), e.g. action_centre=...",
    )
    args = parser.parse_args()
    if args.table:
        print(table([json.loads(Path(path).read_text()) for path in args.table]))
        return
    if args.rows:
        print(rows_table({path: json.loads(Path(path).read_text()) for path in args.rows}))
        return
    if not (args.policy and args.out):
        parser.error("--policy and --out are needed to measure")

    from quadcos import evaluation
    from quadcos._util import caches
    from quadcos.env.randomization import NOMINAL

    caches.enable()
    extra = env_overrides(args.env)
    rows = {}
    for name in args.conditions:
        overrides = CONDITIONS[name]
        started = time.monotonic()
        result = evaluation.evaluate(
            args.policy,
            "flat",
            num_envs=args.num_envs,
            seconds=args.seconds,
            env_overrides={**NOMINAL, **extra, **overrides},
            commands=args.commands,
        )
        summary = result.summary
        rows[name] = {
            "overrides": {key: value for key, value in overrides.items()},
            "episodes": args.num_envs,
            "success_rate": summary["success_rate"],
            "fall_rate": summary["fall_rate"],
            "mean_forward_speed": summary["mean_forward_speed"],
            **{key: summary.get(key) for key in GAIT_KEYS},
            "impl": summary["setup"]["impl"],  # the MJX physics that ran
            "wall_time_s": time.monotonic() - started,
        }
        print(f"{name}: success {summary['success_rate']:.3f}, speed"
              f" {summary['mean_forward_speed']:.3f} m/s", flush=True)
    output = {"policy": args.policy, "seconds": args.seconds, "conditions": rows}
    if args.commands:
        output["commands"] = args.commands
    if extra:
        output["env"] = extra
    Path(args.out).write_text(json.dumps(output, indent=1) + "\n")


def env_overrides(pairs: list[str]) -> dict:
    """{key: value} of --env KEY=VALUE pairs: the value as its config field's type (a string
    field keeps the text, e.g. an action centre "0.5,0.1,0.2,-6,-2.9"), else a Python literal."""
    from quadcos import env as env_lib
    from quadcos._util.overrides import flatten, parse_value

    defaults = flatten(env_lib.default_config().to_dict())
    overrides = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        if not sep or key not in defaults:
            raise SystemExit(f"measure.py: --env {pair!r}: give KEY=VALUE with an env config key")
        overrides[key] = text if isinstance(defaults[key], str) else parse_value(text)
    return overrides


def table(results: list[dict]) -> str:
    """success / speed (m/s) per condition (rows) and policy (columns)."""
    header = "| condition | " + " | ".join(f"`{_label(r['policy'])}`: success, speed" for r in results)
    header += " |"
    lines = [header, "|---" * (len(results) + 1) + "|"]
    for name in CONDITIONS:
        cells = [_cell(result, name) for result in results]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def rows_table(results: dict[str, dict]) -> str:
    """One row per output file (its name), one column per condition measured in any of them:
    success / speed (m/s); "—" where a file lacks the condition."""
    names = [name for name in CONDITIONS if any(name in r["conditions"] for r in results.values())]
    lines = ["| output | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for path, result in results.items():
        cells = [_cell(result, name) for name in names]
        lines.append(f"| {Path(path).stem} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _cell(result: dict, condition: str) -> str:
    """"success, speed" of one condition of a measure.py output; "—" where it was not measured."""
    row = result["conditions"].get(condition)
    return "—" if row is None else f"{row['success_rate']:.3f}, {row['mean_forward_speed']:.3f}"


def _label(policy: str) -> str:
    """A policy's run name: the directory above `policy/` (a run's), else the path."""
    path = Path(policy)
    return path.parent.name if path.name == "policy" else policy


if __name__ == "__main__":
    main()
