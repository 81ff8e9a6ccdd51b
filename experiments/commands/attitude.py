"""Where the kept policies' attitude comes from: the random-command evaluation under the training
randomisation (the targets' pitch error and roll, mean of the episodes' peaks) against the four
robustness conditions of `measure.py`, per robot, over every run of campaign.json that has both:

    python experiments/commands/attitude.py [RECORD]   # default: campaign.json beside this file

Prints one row per robot: runs, and for the roll and the pitch error the evaluation's median
(range), the median of its ratio to the nominal condition's peak and of its difference from the
pushes condition's (50 N, 0.1 s), and how many runs exceed the 0.10-rad target under
randomisation and how many without it (nominal). Runs that did not record their robot: "?".
Then, per robot, what SAC changes: over the runs whose training evaluations recorded the roll,
the step-0 evaluation's roll (the searched gait under the untrained actor) and the largest
change any later evaluation of any run made to it (with that run), and the next largest.
"""

import sys
from pathlib import Path

from training_summary import load_runs

CONDITIONS = ("nominal", "pushes 50 N, 0.1 s")
ANGLES = (("roll", "mean_max_abs_roll"), ("pitch error", "mean_max_abs_pitch_error"))
TARGET = 0.10  # rad


def robot(run: dict) -> str:
    """The robot a run trained (its --robot flag), or "?" for a run that did not record it."""
    flags = [flag for flag in run.get("argv", ()) if flag.startswith("--robot=")]
    return flags[-1].split(":")[-1].split("=")[-1] if flags else "?"


def measured(runs: dict) -> dict[str, list[dict]]:
    """The runs with the kept policy's evaluation and both conditions measured, by robot."""
    by_robot: dict[str, list[dict]] = {}
    for run in runs.values():
        kept, conditions = run.get("kept") or {}, run.get("robustness") or {}
        keys = [key for _, key in ANGLES]
        if all(key in kept for key in keys) and all(
            key in conditions.get(name, {}) for name in CONDITIONS for key in keys
        ):
            by_robot.setdefault(robot(run), []).append(run)
    return by_robot


def median(values: list[float]) -> float:
    ordered = sorted(values)
    middle = len(ordered) // 2
    return ordered[middle] if len(ordered) % 2 else (ordered[middle - 1] + ordered[middle]) / 2


def describe(runs: list[dict], label: str, key: str) -> str:
    evaluated = [run["kept"][key] for run in runs]
    nominal = [run["robustness"]["nominal"][key] for run in runs]
    pushed = [run["robustness"]["pushes 50 N, 0.1 s"][key] for run in runs]
    return (
        f"{label} {median(evaluated):.3f} rad ({min(evaluated):.3f}–{max(evaluated):.3f}),"
        f" ×{median([e / n for e, n in zip(evaluated, nominal)]):.2f} the nominal's,"
        f" {median([e - p for e, p in zip(evaluated, pushed)]):+.3f} from the pushes',"
        f" over {TARGET} in {sum(e > TARGET for e in evaluated)}"
        f" (nominal {sum(n > TARGET for n in nominal)})"
    )


def sac_change(runs: dict) -> dict[str, list[tuple[float, float, str]]]:
    """(step 0's roll, the largest |change| from it over the later evaluations, the run's name)
    of each run whose training evaluations recorded the roll, by robot."""
    by_robot: dict[str, list[tuple[float, float, str]]] = {}
    for name, run in runs.items():
        rolls = [row["roll"] for row in run.get("evaluations", ()) if row.get("roll") is not None]
        first = (run.get("evaluations") or [{}])[0]
        if len(rolls) > 1 and first.get("env_steps") == 0 and first.get("roll") is not None:
            change = max(abs(roll - rolls[0]) for roll in rolls[1:])
            by_robot.setdefault(robot(run), []).append((rolls[0], change, name))
    return by_robot


def main(argv: list[str]) -> int:
    path = Path(argv[0]) if argv else Path(__file__).with_name("campaign.json")
    runs = load_runs(path)
    for name, measured_runs in sorted(measured(runs).items()):
        angles = "; ".join(describe(measured_runs, label, key) for label, key in ANGLES)
        print(f"{name}: {len(measured_runs)} runs; {angles}")
    for name, rows in sorted(sac_change(runs).items()):
        starts = ", ".join(f"{start:.3f}" for start, _, _ in rows)
        (_, most, run), *rest = sorted(rows, key=lambda row: -row[1])
        after = f", the next {rest[0][1]:.3f} rad" if rest else ""
        print(
            f"{name}, training evaluations: {len(rows)} runs; step-0 roll {starts} rad;"
            f" SAC changed it by at most {most:.3f} rad ({run}){after}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
