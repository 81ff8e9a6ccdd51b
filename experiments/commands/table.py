"""The commanded-gait table of experiments/commands/README.md, from the evaluation and robustness
JSONs beside this file (`run_gpu.sh evaluate` writes them; per-episode data removed) and the
policies' configs:

    python experiments/commands/table.py     # the results table, then the levers' rows
"""

import json
from pathlib import Path

HERE = Path(__file__).parent
POLICIES = HERE.parent / "policies"
# column -> the policy folder it evaluates (None: the policy is not kept)
RUNS = {
    "unitree_go1": "unitree_go1_command",
    "unitree_go1_s1": None,
    "unitree_go1_nofeed": None,
    "unitree_go2": "unitree_go2_command",
    "anybotics_anymal_c": None,
}
CONDITIONS = ("nominal", "latency 40 ms", "pushes 50 N, 0.1 s", "friction 0.4")
TARGETS = {  # issue 58's targets, 1024 episodes of 20 s, commands resampled every 5 s
    "survival": "≥ 0.99 each",
    "speed_tracking_rms": "≤ 0.10 m/s",
    "yaw_rate_tracking_rms": "≤ 0.15 rad/s",
    "mean_max_abs_pitch_error": "≤ 0.10 rad",
    "mean_max_abs_roll": "≤ 0.10 rad",
}


def _row(label: str, target: str, cells: list[str]) -> str:
    return f"| {label} | {target} | " + " | ".join(cells) + " |"


def _load(name: str) -> dict | None:
    path = HERE / name
    return json.loads(path.read_text()) if path.exists() else None


def _survival(robust: dict | None) -> str:
    if robust is None:
        return "—"
    return " / ".join(f"{robust['conditions'][c]['success_rate']:.3f}" for c in CONDITIONS)


def table() -> str:
    evals = {r: _load(f"{r}_eval.json") for r in RUNS}
    robust = {r: _load(f"{r}_robustness.json") for r in RUNS}
    commands = {r: e["setup"]["env"]["commands"] for r, e in evals.items()}
    lines = [
        "| | target | " + " | ".join(f"`{r}`" for r in RUNS) + " |",
        "|---" * (len(RUNS) + 2) + "|",
        _row("feed-forward: v_ref m/s, b m", "", [
            f"{c['reference_speed']:.2f}, {c['half_track']:.2f}" if c.get("feed_forward") else "off"
            for c in commands.values()
        ]),
        _row("`policy_env_steps`", "", [f"{e['setup']['policy_env_steps']:,}" for e in evals.values()]),
        _row("survival, 1024 episodes: " + " / ".join(CONDITIONS), TARGETS["survival"],
             [_survival(robust[r]) for r in RUNS]),
        _row("survival, 64 episodes", "", [f"{e['success_rate']:.3f}" for e in evals.values()]),
        _row("mean forward speed, m/s", "", [f"{e['mean_forward_speed']:.2f}" for e in evals.values()]),
    ]
    for key in ("speed_tracking_rms", "yaw_rate_tracking_rms", "mean_max_abs_pitch_error", "mean_max_abs_roll"):
        lines.append(_row(f"`{key}`", TARGETS[key], [f"{e[key]:.3f}" for e in evals.values()]))
    for key in ("cost_of_transport", "peak_joint_torque_ratio"):
        cells = ["—" if e[key] is None else f"{e[key]:.2f}" for e in evals.values()]
        lines.append(_row(f"`{key}`", "", cells))
    return "\n".join(lines)


LEVERS = {  # run in training_feed_forward.json -> its change from the preset
    "go1_s0": "—",
    "go1_s1": "— (seed 1)",
    "go2_s0": "— (Go2)",
    "go1_s0_leash": "`heading_leash` 0.1",
    "scale05_go1_s0": "`action_scale` 0.5",
    "scale05_go1_s1": "`action_scale` 0.5 (seed 1)",
    "scale05_go2_s0": "`action_scale` 0.5 (Go2)",
    "scale05_anymal_s0": "`action_scale` 0.5 (ANYmal C)",
}


def levers() -> str:
    """The rows of the levers table: each run's last evaluation in training."""
    runs = json.loads((HERE / "training_feed_forward.json").read_text())["runs"]
    rows = []
    for name, change in LEVERS.items():
        e = runs[name]["last_evaluation"]
        rows.append(
            f"| `{name}` | {change} | {e['env_steps'] / 1e6:.1f} M | {e['eval_reward']:.0f} |"
            f" {e['speed']:.3f} | {e['fall_rate']:.3f} |"
        )
    return "\n".join(rows)


if __name__ == "__main__":
    print(table())
    print()
    print(levers())
