"""The commanded-gait table of experiments/commands/README.md, from the evaluation and robustness
JSONs beside this file (`run_gpu.sh evaluate` writes them):

    python experiments/commands/table.py
"""

import json
from pathlib import Path

HERE = Path(__file__).parent
ROBOTS = ("unitree_go1", "unitree_go1_s1", "unitree_go2", "anybotics_anymal_c")
CONDITIONS = ("nominal", "latency 40 ms", "pushes 50 N, 0.1 s", "friction 0.4")
TARGETS = {  # issue 58's targets, one H100, 1024 episodes of 20 s, commands resampled every 5 s
    "survival": "≥ 0.99 each",
    "speed_tracking_rms": "≤ 0.10 m/s",
    "yaw_rate_tracking_rms": "≤ 0.15 rad/s",
    "mean_max_abs_pitch_error": "≤ 0.10 rad",
    "mean_max_abs_roll": "≤ 0.10 rad",
}


def _row(label: str, target: str, cells: list[str]) -> str:
    return f"| {label} | {target} | " + " | ".join(cells) + " |"


def table() -> str:
    evals = {r: json.loads((HERE / f"{r}_eval.json").read_text()) for r in ROBOTS}
    robust = {r: json.loads((HERE / f"{r}_robustness.json").read_text()) for r in ROBOTS}
    lines = [
        "| | target | " + " | ".join(f"`{r}`" for r in ROBOTS) + " |",
        "|---" * (len(ROBOTS) + 2) + "|",
        _row(
            "survival: " + " / ".join(CONDITIONS),
            TARGETS["survival"],
            [" / ".join(f"{robust[r]['conditions'][c]['success_rate']:.3f}" for c in CONDITIONS) for r in ROBOTS],
        ),
        _row("mean forward speed, m/s", "", [f"{e['mean_forward_speed']:.2f}" for e in evals.values()]),
    ]
    for key in ("speed_tracking_rms", "yaw_rate_tracking_rms", "mean_max_abs_pitch_error", "mean_max_abs_roll"):
        lines.append(_row(f"`{key}`", TARGETS[key], [f"{e[key]:.3f}" for e in evals.values()]))
    for key, unit in (("foot_slip_m_per_s", "m/s"), ("cost_of_transport", ""), ("peak_joint_torque_ratio", "")):
        cells = ["—" if e[key] is None else f"{e[key]:.2f}" for e in evals.values()]
        lines.append(_row(f"`{key}`" + (f", {unit}" if unit else ""), "", cells))
    return "\n".join(lines)


if __name__ == "__main__":
    print(table())
