"""Whether SAC beats its searched gait depends on how well that gait tracks. Over every run of
campaign.json whose step-0 gait was measured in `measure.py`'s four conditions beside its kept
policy (`run_gpu.sh evaluate`):

    python experiments/commands/gait_spread.py [RECORD]   # default: campaign.json beside this

Prints, per robot, the runs whose kept policy comes from training and beats its gait in every
condition (`table.shortfalls`: survives no less, tracks speed and the yaw rate no worse), and the
others, each with how many, and the median (range) of their gaits' nominal speed-tracking RMS
(m/s, random commands); then, per robot, the same over the distinct gaits of seed 0's runs: how
far one seed's searches differ on the GPU, where the search does not repeat.
"""

import sys
from pathlib import Path

from latency_cells import median
from table import flag, shortfalls
from training_summary import load_runs

NOMINAL, KEY = "nominal", "speed_tracking_rms"


def robot(run: dict) -> str:
    """The run's robot as its train flags name it (`--robot=menagerie:NAME`)."""
    return flag(run["argv"], "--robot").split(":")[-1]


def beats(run: dict) -> bool:
    """Whether the kept policy comes from training and beats its gait in every condition."""
    trained = (run.get("kept") or {}).get("policy_env_steps", 0) > 0
    return trained and not shortfalls(run["robustness"], run["gait_robustness"])


def spread(values: list[float]) -> str:
    if not values:
        return "none"
    return f"{len(values)}, {median(values):.3f} ({min(values):.3f}–{max(values):.3f})"


def lines(runs: dict) -> list[str]:
    measured = {
        name: run
        for name, run in runs.items()
        if run.get("gait_robustness") and run.get("robustness") and run.get("argv")
    }
    out = []
    for name in sorted({robot(run) for run in measured.values()}):
        mine = [run for run in measured.values() if robot(run) == name]
        gait = {True: [], False: []}
        for run in mine:
            gait[beats(run)].append(run["gait_robustness"][NOMINAL][KEY])
        # (runs from one given gait share its action centre: each gait once)
        zero = {
            run["action_centre"]: run["gait_robustness"][NOMINAL][KEY]
            for run in mine
            if flag(run["argv"], "--seed") == "0"
        }
        out += [
            f"{name}: SAC beats its gait in every condition: {spread(gait[True])}",
            f"{name}: it does not: {spread(gait[False])}",
            f"{name}: the distinct gaits of seed 0's runs: {spread(list(zero.values()))}",
        ]
    return out


if __name__ == "__main__":
    path = Path(sys.argv[1]) if sys.argv[1:] else Path(__file__).with_name("campaign.json")
    print("\n".join(lines(load_runs(path))))
