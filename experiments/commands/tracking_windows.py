"""Where a command policy's speed-tracking error sits: its 0.5-s windows (the evaluation's,
`quadcos.env.tracking.TRACKING_WINDOW_S`) grouped by the time since the command was last drawn
(the episode's start included), in C MuJoCo under random commands (resampled every
`commands.resample_seconds`), nothing randomised.

    MENAGERIE_ROOT=DIR python experiments/commands/tracking_windows.py \
        --policy=experiments/policies/unitree_go2_command --episodes=32 \
        --out=experiments/commands/unitree_go2_tracking_windows.json

Each window: the mean forward speed along the heading against the mean commanded v*. A window
holds whole control steps from the episode's start (the windows of an episode cut short by a fall
end there). Per group: the RMS of the windows' errors and their share of the squared error. Past
each change's first window, `by_speed` splits the errors by the commanded v* (0.2-m/s bins): the
mean error is the policy's steady bias at that speed, the RMS about it what varies;
`feed_forward_by_speed` is the same for the zero action (the searched gait under the command's
feed-forward alone, without what SAC learned), on the same episodes.
"""

import argparse
import json
import math
from pathlib import Path

import ml_collections
import numpy as np

from quadcos.deploy import host_robot
from quadcos.env import tracking

SPEED_BIN = 0.2  # m/s: the width of the commanded-speed bins of `by_speed`


def window_errors(
    robot: host_robot.HostRobot, act, seed: int, seconds: float
) -> list[tuple[float, float, float]]:
    """(seconds since the command changed, commanded v* m/s, speed error m/s) of each whole
    window of one episode."""
    obs, steps = robot.reset(seed), round(seconds / robot.dt)
    window = tracking.window_steps(robot.dt)
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
        command = float(np.mean(commanded[part]))
        errors.append((since, command, speed - command))
    return errors


def by_speed(errors: list[tuple[float, float, float]]) -> list[dict]:
    """Past each change's first window: per bin of commanded speed, the windows' mean error (the
    bias) and their RMS about it."""
    bins: dict[int, list[float]] = {}
    for since, command, error in errors:
        if since > 0:
            bins.setdefault(int(command // SPEED_BIN), []).append(error)
    return [
        {
            "commanded_from": round(index * SPEED_BIN, 3),
            "commanded_to": round((index + 1) * SPEED_BIN, 3),
            "windows": len(values),
            "mean_error": float(np.mean(values)),
            "rms_about_mean": float(np.std(values)),
        }
        for index, values in sorted(bins.items())
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--policy", required=True)
    parser.add_argument("--episodes", type=int, default=32)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument(
        "--speed_gain_rate",
        type=float,
        help="the drive's speed-gain rate (1/s, env.commands.speed_gain_rate); default: the policy's",
    )
    parser.add_argument("--out")
    args = parser.parse_args()
    pilot = host_robot.Pilot.load(args.policy)
    config = pilot.config
    if args.speed_gain_rate is not None:
        config = ml_collections.ConfigDict(config.to_dict())
        config.commands.speed_gain_rate = args.speed_gain_rate
    robot = host_robot.HostRobot("flat", config, physics="training", commands="random")
    act = pilot.actor()
    errors = [
        e for seed in range(args.episodes) for e in window_errors(robot, act, seed, args.seconds)
    ]
    zero = np.zeros(robot.action_size)
    alone = [
        e
        for seed in range(args.episodes)
        for e in window_errors(robot, lambda obs: zero, seed, args.seconds)
    ]
    total = sum(error**2 for _, _, error in errors)
    groups = []
    for since in sorted({s for s, _, _ in errors}):
        squares = [error**2 for s, _, error in errors if s == since]
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
        "speed_gain_rate": config.commands.speed_gain_rate,
        "episodes": args.episodes,
        "seconds": args.seconds,
        "speed_tracking_rms": math.sqrt(total / len(errors)),
        "speed_tracking_rms_after_first_window": math.sqrt(
            float(np.mean([error**2 for s, _, error in errors if s > 0]))
        ),
        "groups": groups,
        "by_speed": by_speed(errors),
        "feed_forward_speed_tracking_rms": math.sqrt(
            float(np.mean([error**2 for _, _, error in alone]))
        ),
        "feed_forward_by_speed": by_speed(alone),
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
    alone_bias = {
        row["commanded_from"]: row["mean_error"] for row in record["feed_forward_by_speed"]
    }
    for row in record["by_speed"]:
        print(
            f"  v* {row['commanded_from']:.1f}-{row['commanded_to']:.1f} m/s: mean error"
            f" {row['mean_error']:+.3f}, RMS about it {row['rms_about_mean']:.3f}"
            f" ({row['windows']} windows); the feed-forward alone"
            f" {alone_bias.get(row['commanded_from'], math.nan):+.3f}"
        )
    if args.out:
        Path(args.out).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
