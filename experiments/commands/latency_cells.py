"""What the 40-ms latency condition of `measure.py` measures: the latency delays only the policy's
action (`QuadrupedEnv._actuate`: the previous action acts for the step's first latency_steps),
while the feed-forward and the drive's loops act at once. Over every run of campaign.json:

    python experiments/commands/latency_cells.py [RECORD]   # default: campaign.json beside this

Prints, for the step-0 gaits measured (`gait_robustness`: the searched gait under the untrained
actor), the largest difference between their tracking at 40 ms and nominal; and for the kept
policies from training (`robustness`, policy_env_steps > 0), the median (range) of the ratio of
their tracking at 40 ms to nominal and how many track worse at 40 ms, speed and yaw rate each.
"""

import sys
from pathlib import Path

from training_summary import load_runs

TRACKING = (("speed", "speed_tracking_rms"), ("yaw rate", "yaw_rate_tracking_rms"))
LATE, NOMINAL = "latency 40 ms", "nominal"


def median(values: list[float]) -> float:
    ordered = sorted(values)
    middle = len(ordered) // 2
    return ordered[middle] if len(ordered) % 2 else (ordered[middle - 1] + ordered[middle]) / 2


def gaits(runs: dict) -> str:
    """The step-0 gaits: the most any tracks differently at 40 ms than nominal."""
    measured = [run["gait_robustness"] for run in runs.values() if run.get("gait_robustness")]
    spread = max(abs(c[LATE][key] - c[NOMINAL][key]) for c in measured for _, key in TRACKING)
    return f"{len(measured)} step-0 gaits: at 40 ms within {spread:.4f} of nominal (m/s, rad/s)"


def trained(runs: dict) -> str:
    """The kept policies from training: their tracking at 40 ms against nominal."""
    measured = [
        run["robustness"]
        for run in runs.values()
        if run.get("robustness") and (run.get("kept") or {}).get("policy_env_steps")
    ]
    parts = []
    for label, key in TRACKING:
        ratios = [c[LATE][key] / c[NOMINAL][key] for c in measured]
        parts.append(
            f"{label} ×{median(ratios):.3f} ({min(ratios):.3f}–{max(ratios):.3f}),"
            f" worse in {sum(r > 1 for r in ratios)}"
        )
    head = f"{len(measured)} kept policies from training, 40 ms against nominal: "
    return head + "; ".join(parts)


if __name__ == "__main__":
    path = Path(sys.argv[1]) if sys.argv[1:] else Path(__file__).with_name("campaign.json")
    runs = load_runs(path)
    print(gaits(runs))
    print(trained(runs))
