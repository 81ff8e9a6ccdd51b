"""The command's feed-forward measured on the gait a search found (`commands.feed_forward`).

The feed-forward scales each side's hip swing by its commanded speed over the unscaled rhythm's
speed v_ref, the sides apart by ω*·b (`quadcos.env.commands.drive_scales`): a differential drive.
Neither v_ref nor the effective half track b is known before the gait is: a legged robot's feet
slip and its diagonal pairs couple the sides, so b is several times the hips' half track. Both are
measured here on the found gait, walking in C MuJoCo (the converged reference solver) for a few
seconds on flat ground without randomisation: straight with both sides at scale 1 (its speed is
v_ref), then with the sides at 1 ∓ δ (its yaw rate ω gives b = δ·v_ref / ω; negative where the
gait's phases make the longer strides of the right side turn it right). A fresh policy then
walks near v* and turns near ω*, and SAC learns what the drive misses.

`find_gait` is `quadcos.evaluation.gait_search.find_gait` with this measurement added to its
result ("feed_forward"), which `quadcos.training.run` applies to the run's config.
"""

import logging
import math
from typing import Any

import ml_collections
import numpy as np

from quadcos import env as env_lib
from quadcos.deploy import host_robot, twins
from quadcos.env import commands as env_commands
from quadcos.evaluation import gait_search

logger = logging.getLogger("quadcos.train")

SIDE_DIFFERENCE = 0.3  # δ: the sides' scales 1 ∓ δ of the turning measurement
SETTLE_S = 2.0  # s walked before measuring
MEASURE_S = 4.0  # s measured
MIN_SPEED = 0.05  # m/s: slower, the gait cannot be scaled to a command
MIN_YAW_RATE = 0.01  # rad/s: less, the sides do not steer it
PHYSICS = "training"  # the solver iterations the env trains with


def find_gait(config: ml_collections.ConfigDict) -> dict[str, Any]:
    """The gait search of a run config ({"env", "sac"}), and with `env.commands.feed_forward` its
    feed-forward measured on the gait found: the result's "feed_forward" holds the
    `env.commands` values (reference_speed, half_track) and what they came from."""
    search = gait_search.find_gait(config)
    commands = config.env.commands
    if not (commands.feed_forward and env_commands.parse_commands(commands.spec).enabled):
        return search
    env_config = ml_collections.ConfigDict(config.env.to_dict())
    env_config.action_centre = search["action_centre"]
    return search | {"feed_forward": measure(env_config, seed=config.sac.seed)}


def measure(
    env_config: ml_collections.ConfigDict, seed: int = 0, robots: int = 2
) -> dict[str, float]:
    """{"reference_speed" (m/s), "half_track" (m), "yaw_rate" (rad/s, of the turning walk)}
    measured on the zero action of `env_config` (its action centre) with `robots` robots each
    (reset seeds seed, seed + 1, ...). Where the gait is too slow or does not turn, the config's
    resolved values are kept and a warning says why."""
    config = ml_collections.ConfigDict(env_config.to_dict())
    config.randomization.enabled = False
    config.commands.reference_speed = 1.0  # the command (1, ω*) is then the scales themselves
    config.commands.half_track = 1.0
    seconds = SETTLE_S + MEASURE_S
    straight = _walk(config, f"1,0@{seconds}", seed, robots)
    turning = _walk(config, f"1,{SIDE_DIFFERENCE}@{seconds}", seed, robots)
    speed, yaw_rate = straight[0], turning[1]
    resolved = env_lib.resolve(env_config)
    result = {
        "reference_speed": resolved.commands.reference_speed,
        "half_track": resolved.commands.half_track,
        "speed": speed,
        "yaw_rate": yaw_rate,
    }
    if not speed >= MIN_SPEED:
        logger.warning(
            "feed-forward: the gait walks %.2f m/s (< %g): keeping v_ref %.2f m/s, b %.3f m",
            speed,
            MIN_SPEED,
            result["reference_speed"],
            result["half_track"],
        )
        return result
    result["reference_speed"] = round(speed, 4)
    if abs(yaw_rate) >= MIN_YAW_RATE:  # b < 0 where the right side's longer strides turn right
        result["half_track"] = round(SIDE_DIFFERENCE * speed / yaw_rate, 4)
    else:
        logger.warning(
            "feed-forward: sides at 1 -/+ %g turn the gait %.3f rad/s: keeping b %.3f m",
            SIDE_DIFFERENCE,
            yaw_rate,
            result["half_track"],
        )
    logger.info(
        "feed-forward: v_ref %.2f m/s, b %.3f m (sides at 1 -/+ %g: %.2f rad/s)",
        result["reference_speed"],
        result["half_track"],
        SIDE_DIFFERENCE,
        yaw_rate,
    )
    return result


def _walk(
    config: ml_collections.ConfigDict, schedule: str, seed: int, robots: int
) -> tuple[float, float]:
    """(speed along the heading, m/s; yaw rate, rad/s) of the zero action under `schedule`,
    over the last MEASURE_S s of each robot's walk, averaged over the robots (NaN for a fall)."""
    robot = host_robot.HostRobot("flat", config, commands=schedule, physics=PHYSICS)
    steps = round((SETTLE_S + MEASURE_S) / robot.dt)
    settle = round(SETTLE_S / robot.dt)
    action = np.zeros(robot.action_size)
    speeds, yaw_rates = [], []
    for index in range(robots):
        robot.reset(seed + index)
        start = None
        for step in range(steps):
            result = robot.step(action)
            if result.fell:
                return math.nan, math.nan
            if step == settle - 1:
                start = (*robot.data.qpos[:2], result.body.yaw, robot.data.time)
        x0, y0, yaw0, t0 = start
        elapsed = robot.data.time - t0
        turned = twins.wrap_angle(result.body.yaw - yaw0)
        heading = yaw0 + turned / 2
        x1, y1 = robot.data.qpos[:2]
        speeds.append(((x1 - x0) * math.cos(heading) + (y1 - y0) * math.sin(heading)) / elapsed)
        yaw_rates.append(turned / elapsed)
    return float(np.mean(speeds)), float(np.mean(yaw_rates))
