"""Where a command policy's tracking error sits: its 0.5-s windows (the evaluation's,
`quadcos.env.tracking.TRACKING_WINDOW_S`) grouped by the time since the command was last drawn
(the episode's start included), in C MuJoCo under random commands (resampled every
`commands.resample_seconds`), nothing randomised.

    MENAGERIE_ROOT=DIR python experiments/commands/tracking_windows.py \
        --policy=experiments/policies/unitree_go2_command --episodes=32 \
        --out=experiments/commands/unitree_go2_tracking_windows.json
    MENAGERIE_ROOT=DIR python experiments/commands/tracking_windows.py \
        --policy=experiments/policies/unitree_go1_command --episodes=32 --ablate \
        --out=experiments/commands/unitree_go1_tracking_windows.json

Each window: the mean forward speed along the heading against the mean commanded v*, and the
mean yaw rate (the true base's, as the evaluation's) against the mean commanded ω*. A window
holds whole control steps from the episode's start (the windows of an episode cut short by a
fall end there). Per group: the RMS of the windows' speed and yaw-rate errors and their share of
each squared error, beside the same for the zero action (the searched gait under the command's
feed-forward alone, without what SAC learned: `feed_forward_*`), on the same episodes. Past each
change's first window, `by_speed` splits the speed errors by the commanded v* (0.2-m/s bins) and
`by_yaw_rate` the yaw-rate errors by the commanded ω* (0.2-rad/s bins): the mean error is the
policy's steady bias there, the RMS about it what varies.

`--speed_gain_rate` and `--heading_gain` set the drive's loops (0: open) instead of the policy's.
`--ablate` adds what each of the policy's action values does to its tracking (`ablation`): the
policy with that value held at the zero action's (the gait's, each value in turn), and the zero
action with only that value the policy's, on the same episodes. `action_stats`: each action
value's mean, spread and RMS change from one control step to the next over the policy's steps (in
the action's [−1, 1]), and `phase_share`: the share of its variance that the oscillator's phase ψ
at the step explains: what the policy does within each stride rather than across strides.
"""

import argparse
import json
import math
from pathlib import Path
from typing import NamedTuple

import ml_collections
import numpy as np

from quadcos import env as env_lib
from quadcos.deploy import host_robot, twins
from quadcos.env import tracking
from quadcos.equations import oscillator
from quadcos.robot import constants

BIN = 0.2  # m/s, rad/s: the width of the commanded-speed and yaw-rate bins
# the names of an oscillator policy's action values (§3.3's, then posture and turn where present)
RHYTHM = tuple(oscillator.RhythmParameters._fields)
POSTURE = ("posture_front", "posture_hind")
SPEED, YAW_RATE = 0, 1  # the two tracked quantities, as in a command (v*, ω*)
HARMONICS = 3  # `phase_share`'s fit: a constant and cos kψ, sin kψ for k = 1..HARMONICS


class Window(NamedTuple):
    since: float  # s since the command was last drawn, at the window's start
    command: tuple[float, float]  # the window's mean (v*, ω*)
    error: tuple[float, float]  # its mean speed (m/s) and yaw-rate (rad/s) errors


def _yaw(robot: host_robot.HostRobot) -> float:
    """The base's true yaw (rad), as the evaluation's tracking measures it."""
    return twins.attitude(robot.data.qpos[constants.QPOS_QUATERNION]).yaw


def window_errors(robot: host_robot.HostRobot, act, seed: int, seconds: float) -> list[Window]:
    """The whole windows of one episode."""
    return windows_of(robot, *episode_series(robot, act, seed, seconds))


def episode_series(
    robot: host_robot.HostRobot, act, seed: int, seconds: float
) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """One episode's steps (to its end or fall): per step the command (v*, ω*) and what the
    robot did (speed along its heading, yaw rate)."""
    obs, steps = robot.reset(seed), round(seconds / robot.dt)
    commanded, moved = [], []
    for _ in range(steps):
        commanded.append(tuple(robot.commands.velocity))
        x0, y0 = robot.data.qpos[:2]
        yaw0 = _yaw(robot)
        result = robot.step(act(obs))
        obs, (x1, y1), yaw1 = result.obs, robot.data.qpos[:2], _yaw(robot)
        along = (x1 - x0) * math.cos(result.body.yaw) + (y1 - y0) * math.sin(result.body.yaw)
        turned = math.remainder(yaw1 - yaw0, 2 * math.pi)
        moved.append((along / robot.dt, turned / robot.dt))
        if result.fell:
            break
    return commanded, moved


def windows_of(robot: host_robot.HostRobot, commanded, moved) -> list[Window]:
    """The whole windows of an episode's `episode_series`."""
    window = tracking.window_steps(robot.dt)
    period = robot.config.commands.resample_seconds
    windows = []
    for start in range(0, len(moved) - window + 1, window):
        part = slice(start, start + window)
        command = np.mean(commanded[part], axis=0)
        error = np.mean(moved[part], axis=0) - command
        since = round((start * robot.dt) % period, 3)
        windows.append(Window(since, tuple(map(float, command)), tuple(map(float, error))))
    return windows


def by_command(windows: list[Window], which: int) -> list[dict]:
    """Past each change's first window: per bin of the commanded v* (`which` SPEED) or ω*
    (YAW_RATE), the windows' mean error (the bias) and their RMS about it."""
    bins: dict[int, list[float]] = {}
    for w in windows:
        if w.since > 0:
            bins.setdefault(math.floor(w.command[which] / BIN), []).append(w.error[which])
    return [
        {
            "commanded_from": round(index * BIN, 3),
            "commanded_to": round((index + 1) * BIN, 3),
            "windows": len(values),
            "mean_error": float(np.mean(values)),
            "rms_about_mean": float(np.std(values)),
        }
        for index, values in sorted(bins.items())
    ]


def rms(windows: list[Window], which: int) -> float:
    """The RMS of the windows' errors in speed (`which` SPEED) or yaw rate (YAW_RATE)."""
    return math.sqrt(float(np.mean([w.error[which] ** 2 for w in windows])))


def groups(windows: list[Window], alone: list[Window]) -> list[dict]:
    """Per time since a change: the policy's and the zero action's RMS and share of each
    squared error."""
    rows = []
    for since in sorted({w.since for w in windows}):
        row = {"since_change_s": since}
        for prefix, record in (("", windows), ("feed_forward_", alone)):
            part = [w for w in record if w.since == since]
            row[f"{prefix}windows"] = len(part)
            for name, which in (("speed", SPEED), ("yaw_rate", YAW_RATE)):
                total = sum(w.error[which] ** 2 for w in record)
                row[f"{prefix}{name}_rms"] = rms(part, which)
                row[f"{prefix}{name}_share_of_squared_error"] = (
                    sum(w.error[which] ** 2 for w in part) / total
                )
        rows.append(row)
    return rows


def action_names(config: ml_collections.ConfigDict) -> tuple[str, ...]:
    """The names of the oscillator controller's action values under `config` (the env's)."""
    posture = POSTURE if config.posture_bound > 0 else ()
    return RHYTHM + posture + (("turn",) if config.turn_mode != "none" else ())


def phase_share(actions: np.ndarray, phases: np.ndarray) -> np.ndarray:
    """Per column of `actions` (steps × values), the share of its variance that the phases ψ
    (rad, one a step) explain: 1 − the residual's variance over the column's after a least-squares
    fit of a constant and cos kψ, sin kψ (k = 1..HARMONICS). 1: the value repeats each stride; 0:
    nothing of it follows the stride (a constant value too)."""
    basis = [np.ones_like(phases)]
    for k in range(1, HARMONICS + 1):
        basis += [np.cos(k * phases), np.sin(k * phases)]
    basis = np.stack(basis, axis=1)
    fit, *_ = np.linalg.lstsq(basis, actions, rcond=None)
    spread, left = actions.var(axis=0), (actions - basis @ fit).var(axis=0)
    moves = spread > 1e-12  # (a held value's variance is rounding: actions lie in [−1, 1])
    return np.where(moves, 1.0 - left / np.where(moves, spread, 1.0), 0.0)


class Recorder:
    """An actor that keeps each episode's actions and the `robot`'s oscillator phase at each
    (`start` before each episode)."""

    def __init__(self, act, robot: host_robot.HostRobot):
        self.act, self.robot, self.episodes, self.phases = act, robot, [], []

    def start(self) -> None:
        self.episodes.append([])
        self.phases.append([])

    def __call__(self, obs):
        action = np.asarray(self.act(obs))
        self.episodes[-1].append(action)
        self.phases[-1].append(self.robot.phase)
        return action

    def stats(self, names: tuple[str, ...]) -> dict:
        """Per action value: its mean and spread over the steps, the RMS of its change from one
        control step to the next (in the action's [−1, 1]) and its `phase_share`."""
        actions = np.concatenate(self.episodes)
        changes = np.concatenate(
            [np.diff(np.array(e), axis=0) for e in self.episodes if len(e) > 1]
        )
        within = phase_share(actions, np.concatenate(self.phases))
        return {
            name: {
                "mean": float(actions[:, i].mean()),
                "std": float(actions[:, i].std()),
                "rms_step_change": float(np.sqrt(np.mean(changes[:, i] ** 2))),
                "phase_share": float(within[i]),
            }
            for i, name in enumerate(names)
        }


def ablation(robot: host_robot.HostRobot, act, args) -> list[dict]:
    """Per action value the env acts on (not those `held_rhythm` holds): the tracking RMS of the
    policy without it (held at the zero action's) and of the zero action with it alone
    (`--ablate`)."""

    def mixed(index: int, alone: bool):
        def choose(obs):
            action = np.asarray(act(obs))
            chosen = np.zeros_like(action) if alone else action.copy()
            chosen[index] = action[index] if alone else 0.0
            return chosen

        return choose

    rows = []
    held = env_lib.rhythm_scales(robot.config) == 0  # values the env ignores (`held_rhythm`)
    for index, name in enumerate(action_names(robot.config)):
        if index < held.size and held[index]:
            continue
        row = {"value": name}
        for key, alone in (("without", False), ("alone", True)):
            policy = mixed(index, alone)
            windows = [
                w
                for s in range(args.episodes)
                for w in window_errors(robot, policy, s, args.seconds)
            ]
            row[f"{key}_speed_rms"] = rms(windows, SPEED)
            row[f"{key}_yaw_rate_rms"] = rms(windows, YAW_RATE)
        print(
            f"  {name}: the policy without it {row['without_speed_rms']:.3f} m/s,"
            f" {row['without_yaw_rate_rms']:.3f} rad/s; the zero action with it alone"
            f" {row['alone_speed_rms']:.3f}, {row['alone_yaw_rate_rms']:.3f}"
        )
        rows.append(row)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--policy", required=True)
    parser.add_argument("--episodes", type=int, default=32)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument(
        "--speed_gain_rate",
        type=float,
        help="the drive's speed-gain rate (1/s, env.commands.speed_gain_rate); default: the"
        " policy's",
    )
    parser.add_argument(
        "--heading_gain",
        type=float,
        help="the drive's heading loop (1/s, env.commands.heading_gain; 0: open); default: the"
        " policy's",
    )
    parser.add_argument(
        "--ablate",
        action="store_true",
        help="also each action value held at the zero action's, and alone (`ablation`)",
    )
    parser.add_argument("--out")
    args = parser.parse_args()
    pilot = host_robot.Pilot.load(args.policy)
    config = pilot.config
    loops = {"speed_gain_rate": args.speed_gain_rate, "heading_gain": args.heading_gain}
    if any(value is not None for value in loops.values()):
        config = ml_collections.ConfigDict(config.to_dict())
        config.commands.update({k: value for k, value in loops.items() if value is not None})
    robot = host_robot.HostRobot("flat", config, physics="training", commands="random")
    act, recorder = pilot.actor(), Recorder(pilot.actor(), robot)
    windows = []
    for seed in range(args.episodes):
        recorder.start()
        windows += window_errors(robot, recorder, seed, args.seconds)
    zero = np.zeros(robot.action_size)
    alone = [
        w
        for seed in range(args.episodes)
        for w in window_errors(robot, lambda obs: zero, seed, args.seconds)
    ]
    later = [w for w in windows if w.since > 0]
    record = {
        "policy": args.policy,
        "speed_gain_rate": config.commands.speed_gain_rate,
        "heading_gain": config.commands.heading_gain,
        "episodes": args.episodes,
        "seconds": args.seconds,
        "speed_tracking_rms": rms(windows, SPEED),
        "speed_tracking_rms_after_first_window": rms(later, SPEED),
        "yaw_rate_tracking_rms": rms(windows, YAW_RATE),
        "yaw_rate_tracking_rms_after_first_window": rms(later, YAW_RATE),
        "groups": groups(windows, alone),
        "by_speed": by_command(windows, SPEED),
        "by_yaw_rate": by_command(windows, YAW_RATE),
        "feed_forward_speed_tracking_rms": rms(alone, SPEED),
        "feed_forward_yaw_rate_tracking_rms": rms(alone, YAW_RATE),
        "feed_forward_by_speed": by_command(alone, SPEED),
        "feed_forward_by_yaw_rate": by_command(alone, YAW_RATE),
        "action_stats": recorder.stats(action_names(robot.config)),
    }
    _print(record, len(windows))
    if args.ablate:
        record["ablation"] = ablation(robot, act, args)
    if args.out:
        Path(args.out).write_text(json.dumps(record, indent=1) + "\n")


def _print(record: dict, count: int) -> None:
    """The record in lines: the policy's tracking, then the zero action's, group by group."""
    for name, unit in (("speed", "m/s"), ("yaw_rate", "rad/s")):
        print(
            f"{name} tracking RMS {record[f'{name}_tracking_rms']:.3f} {unit} over {count} windows"
            f" (the feed-forward alone {record[f'feed_forward_{name}_tracking_rms']:.3f});"
            f" without each change's first window"
            f" {record[f'{name}_tracking_rms_after_first_window']:.3f}"
        )
    for g in record["groups"]:
        print(
            f"  {g['since_change_s']:4.1f} s after a change: speed RMS {g['speed_rms']:.3f}"
            f" ({g['feed_forward_speed_rms']:.3f}), yaw-rate RMS {g['yaw_rate_rms']:.3f}"
            f" ({g['feed_forward_yaw_rate_rms']:.3f}); the feed-forward alone in brackets"
        )
    for name, unit in (("speed", "m/s"), ("yaw_rate", "rad/s")):
        alone = {
            row["commanded_from"]: row["mean_error"] for row in record[f"feed_forward_by_{name}"]
        }
        for row in record[f"by_{name}"]:
            print(
                f"  {name} {row['commanded_from']:+.1f} to {row['commanded_to']:+.1f} {unit}: mean"
                f" error {row['mean_error']:+.3f}, RMS about it {row['rms_about_mean']:.3f}"
                f" ({row['windows']} windows); the feed-forward alone"
                f" {alone.get(row['commanded_from'], math.nan):+.3f}"
            )
    for name, stats in record["action_stats"].items():
        print(
            f"  action {name}: mean {stats['mean']:+.3f}, spread {stats['std']:.3f}, change a step"
            f" {stats['rms_step_change']:.3f}, the phase's share {stats['phase_share']:.2f}"
        )


if __name__ == "__main__":
    main()
