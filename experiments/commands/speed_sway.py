"""How much of a mean speed error the forward term sees, on the shipped command policies: each
walks a straight command in C MuJoCo (the physics it trained with), and over its steady strides
the forward term's |d − c| is charged on its own per-step progress d put on the command c, and on
d shifted by a mean error δ; once per step (`commands.speed_tau` 0) and once on the progress
low-passed over τ (`commands.speed_tau` τ, `commands.low_passed_speed`):

    MENAGERIE_ROOT=DIR python experiments/commands/speed_sway.py \\
        --policies experiments/policies/unitree_go1_command \\
        experiments/policies/unitree_go2_command experiments/policies/anybotics_anymal_c_command \\
        --out experiments/commands/speed_sway.json

A row per policy: its mean speed and the swing of its per-step speed about it (std, m/s) over
the steady part of each episode (after `--settle` s), and for each δ the share of the error the
term charges, per step and low-passed (1: all of it, as a term on the mean speed would).
"""

import argparse
import json
import math
from pathlib import Path

import numpy as np

from quadcos.deploy import host_robot, twins
from quadcos.env import commands as env_commands


def speeds(
    pilot: host_robot.Pilot, command: str, episodes: int, seconds: float
) -> tuple[np.ndarray, float]:
    """(episodes, steps) m/s: each step's progress along the heading at its start, over dt; and
    dt (s)."""
    robot = host_robot.HostRobot("flat", pilot.config, commands=command)
    act, steps, rows = pilot.actor(), round(seconds / robot.dt), []
    for seed in range(episodes):
        obs, row = robot.reset(seed), []
        for _ in range(steps):
            x, y, _ = robot.data.qpos[robot.layout.position]
            heading = twins.attitude(robot.layout.orientation(robot.data)).yaw
            result = robot.step(act(obs))
            if result.fell:
                raise RuntimeError(f"{pilot.name} fell in episode {seed}: no steady strides")
            x_now, y_now, _ = robot.data.qpos[robot.layout.position]
            along = (x_now - x) * math.cos(heading) + (y_now - y) * math.sin(heading)
            row.append(along / robot.dt)
            obs = result.obs
        rows.append(row)
    return np.asarray(rows), robot.dt


def seen(series: np.ndarray, commanded: float, error: float, steady: int) -> float:
    """The share of a mean error `error` (m/s) that mean |s − v*| over the steady steps charges,
    for `series` (episodes, steps) m/s put on the command (its steady mean moved to v*)."""
    centred = series - series[:, steady:].mean() + commanded
    cost = [np.abs(centred[:, steady:] - shift - commanded).mean() for shift in (0.0, error)]
    return float((cost[1] - cost[0]) / error)


def row(pilot: host_robot.Pilot, args: argparse.Namespace) -> dict:
    series, dt = speeds(pilot, args.command, args.episodes, args.seconds)
    commanded = float(args.command.split(",")[0])
    low_passed = np.zeros_like(series)
    for episode, episode_speeds in enumerate(series):
        speed = 0.0
        for step, value in enumerate(episode_speeds):  # the env's filter, from rest at reset
            speed = env_commands.low_passed_speed(speed, value * dt, dt, args.tau)
            low_passed[episode, step] = speed
    steady = round(args.settle / dt)
    return {
        "policy": pilot.name,
        "mean_speed": round(float(series[:, steady:].mean()), 4),
        "speed_swing_std": round(float(series[:, steady:].std()), 4),
        "low_passed_swing_std": round(float(low_passed[:, steady:].std()), 4),
        "seen": {
            f"{error:g}": {
                "per_step": round(seen(series, commanded, error, steady), 3),
                "low_passed": round(seen(low_passed, commanded, error, steady), 3),
            }
            for error in args.errors
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--policies", nargs="+", required=True)
    parser.add_argument("--command", default="0.5,0@20", help="one segment: v*,ω*@seconds")
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--settle", type=float, default=2.0, help="s before the steady strides")
    parser.add_argument("--tau", type=float, default=0.25, help="s: the low-pass's time constant")
    parser.add_argument("--errors", type=float, nargs="+", default=[0.05, 0.1], help="m/s")
    parser.add_argument("--out")
    args = parser.parse_args()
    rows = [row(host_robot.Pilot.load(policy), args) for policy in args.policies]
    record = {
        "command": args.command, "episodes": args.episodes, "seconds": args.seconds,
        "settle": args.settle, "tau": args.tau, "rows": rows,
    }
    for entry in rows:
        print(json.dumps(entry))
    if args.out:
        Path(args.out).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
