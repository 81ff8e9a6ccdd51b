"""Where a command policy's speed-tracking error sits: its 0.5-s windows (the evaluation's,
`rollout.TRACKING_WINDOW_S`) grouped by the time since the command was last drawn (the episode's
start included), in C MuJoCo under random commands (resampled every `commands.resample_seconds`),
nothing randomised.

    MENAGERIE_ROOT=DIR python experiments/commands/tracking_windows.py \
        --policy=experiments/policies/unitree_go1_command --episodes=32 \
        --out=experiments/commands/unitree_go1_tracking_windows.json

Each window: the mean forward speed along the heading against the mean commanded v*. A window
holds whole control steps from the episode's start (the windows of an episode cut short by a fall
end there). Per group: the RMS of the windows' errors and their share of the squared error.
"""

import argparse
import json
import math
from pathlib import Path

import numpy as np

from quadcos.deploy import host_robot
from quadcos.evaluation import rollout


def window_errors(
    robot: host_robot.HostRobot, act, seed: int, seconds: float
) -> list[tuple[float, float]]:
    """(seconds since the command changed, speed error m/s) of each whole window of one
    episode."""
    obs, steps = robot.reset(seed), round(seconds / robot.dt)
    window = rollout.tracking_window_steps(robot.dt)
    period = robot.config.commands.resample_seconds
    commanded, progress = [], []
    for _ in range(steps):
        commanded.append(robot.commands.velocity[0])
        x0, y0 = robot.data.qpos[:2]
        result = robot.step(act(obs))
        obs, (x1, y1) = result.obs, robot.data.qpos[:2]
        yaw = result.body.yaw
        progress.append((x1 - x0) * math.cos(yaw) + (y1 - y0) * math.sin(yaw))
        if result.fell:
            break
    errors = []
    for start in range(0, len(progress) - window + 1, window):
        part = slice(start, start + window)
        speed = sum(progress[part]) / (window * robot.dt)
        since = round((start * robot.dt) % period, 3)
        errors.append((since, speed - float(np.mean(commanded[part]))))
    return errors


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--policy", required=True)
    parser.add_argument("--episodes", type=int, default=32)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--out")
    args = parser.parse_args()
    pilot = host_robot.Pilot.load(args.policy)
    robot = host_robot.HostRobot("flat", pilot.config, physics="training", commands="random")
    act = pilot.actor()
    errors = [
        e for seed in range(args.episodes) for e in window_errors(robot, act, seed, args.seconds)
    ]
    total = sum(error**2 for _, error in errors)
    groups = []
    for since in sorted({s for s, _ in errors}):
        squares = [error**2 for s, error in errors if s == since]
        groups.append(
            {
                "since_change_s": since,
                "windows": len(squares),
                "speed_rms": math.sqrt(float(np.mean(squares))),
                "share_of_squared_error": sum(squares) / total,
            }
        )
    record = {
        "policy": args.policy,
        "episodes": args.episodes,
        "seconds": args.seconds,
        "speed_tracking_rms": math.sqrt(total / len(errors)),
        "speed_tracking_rms_after_first_window": math.sqrt(
            float(np.mean([error**2 for s, error in errors if s > 0]))
        ),
        "groups": groups,
    }
    print(
        f"speed tracking RMS {record['speed_tracking_rms']:.3f} m/s over {len(errors)} windows;"
        f" without each change's first window {record['speed_tracking_rms_after_first_window']:.3f}"
    )
    for group in groups:
        print(
            f"  {group['since_change_s']:4.1f} s after a change: RMS {group['speed_rms']:.3f},"
            f" {group['share_of_squared_error']:.1%} of the squared error"
        )
    if args.out:
        Path(args.out).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
