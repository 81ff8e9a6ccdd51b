"""The command's feed-forward measured on the gait a search found (`commands.feed_forward`).

The feed-forward sets each side's hip swing to the scale that walks its commanded speed, the sides
apart by ω*·b (`quadcos.env.commands.drive_scales`): a differential drive. Neither the scale that
walks a speed nor the effective half track b is known before the gait is: a stride's speed is not
proportional to its scale and depends on the ground (on Go1's searched gait at scale 1: 1.34 m/s at
friction 0.4, 0.65 m/s at 1.5), a legged robot's feet slip and its diagonal pairs couple the sides,
so b is several times the hips' half track. Both are measured here on the found gait, walking in C
MuJoCo (with the training solver) for a few seconds on flat ground without randomisation or the
drive's loops (`commands.speed_gain_rate`, which corrects what the map misses: with it on, every
scale would walk its own command; `commands.heading_gain`: the sides' difference would turn at
the command's ω*): straight at each of `commands.SPEED_MAP_SCALES`, averaged over
the low end, the middle and the high end of the run's friction range, those at which it stays up
(the speed map, `commands.speed_map`, which the drive inverts); straight at scale 1 on the MJCF's
ground (v_ref), then with the sides at 1 ∓ δ (its yaw rate ω gives b = δ·v'/ω, v' the map's speed
per unit of scale, its speed at scale 1, or v_ref without a map; b < 0 where the gait's phases make
the longer strides of the right side turn it right). A fresh policy then walks near v* and turns
near ω*, and SAC learns what the drive misses.

`find_gait` is `quadcos.evaluation.gait_search.find_gait` with this measurement added to its
result ("feed_forward"), which `quadcos.training.run` applies to the run's config. The gait it
measures is the search's best that the sides turn both ways (at 1 ∓ δ and 1 ± δ): the search
scores candidates under a drive whose b is the hips' half track, which barely turns them, so its
best may be a gait that turns only one way, and no b steers that (`turning_centre`).
"""

import logging
import math
from typing import Any

import ml_collections
import numpy as np

from quadcos import env as env_lib
from quadcos.deploy import host_robot, twins
from quadcos.env import commands as env_commands
from quadcos.equations import oscillator
from quadcos.evaluation import gait_search, gait_tracking

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
    count = config.sac.gait_search.track_gaits
    if count:
        return search | tracked_gait(config, env_config, search, count)
    env_config.action_centre, yaw_rate = turning_centre(env_config, search, seed=config.sac.seed)
    return search | {
        "action_centre": env_config.action_centre,
        "feed_forward": measure(env_config, seed=config.sac.seed, yaw_rate=yaw_rate),
    }


def tracked_gait(
    config: ml_collections.ConfigDict,
    env_config: ml_collections.ConfigDict,
    search: dict[str, Any],
    count: int,
) -> dict[str, Any]:
    """{"action_centre", "feed_forward", "tracked_gaits"}: of the `count` best gaits of `search`
    that turn both ways (`turning_centres`), each with its feed-forward measured, the one that
    tracks random commands best (`gait_tracking.track`) without a fall and within the search's
    `max_attitude` where set (where none is, the best-tracking without a fall; where every one
    fell, the best-tracking); with `track_attitude` set, "best" counts its attitude against that
    target as `gait_tracking.score` does."""
    search_config = config.sac.gait_search
    seed, bound, target = config.sac.seed, search_config.max_attitude, search_config.track_attitude
    configs, feeds = [], []
    for centre, yaw_rate in turning_centres(env_config, search, seed=seed, count=count):
        gait = ml_collections.ConfigDict(env_config.to_dict())
        gait.action_centre = centre
        feeds.append(measure(gait, seed=seed, yaw_rate=yaw_rate))
        for key in ("reference_speed", "half_track", "speed_map"):
            gait.commands[key] = feeds[-1][key]
        configs.append(gait)
    lines = gait_tracking.track(config.env.terrain, configs, seed=seed)

    def rank(i: int) -> tuple:
        line = lines[i]
        attitude = max(line["mean_max_abs_roll"], line["mean_max_abs_pitch_error"])
        speed, yaw_rate = line["speed_tracking_rms"], line["yaw_rate_tracking_rms"]
        return gait_tracking.rank(line["fall_rate"] > 0, speed, yaw_rate, attitude, bound, target)

    best = max(range(len(lines)), key=rank)
    for i, line in enumerate(lines):
        logger.info(
            "gait tracking #%d %s: %.1f %% falls, %.3f m/s, %.3f rad/s, roll %.3f, pitch error"
            " %.3f rad%s", i + 1, configs[i].action_centre, 100 * line["fall_rate"],
            line["speed_tracking_rms"], line["yaw_rate_tracking_rms"], line["mean_max_abs_roll"],
            line["mean_max_abs_pitch_error"], ": kept" if i == best else "",
        )  # fmt: skip
    tracked = [{"action_centre": c.action_centre, **line} for c, line in zip(configs, lines)]
    return {
        "action_centre": configs[best].action_centre,
        "feed_forward": feeds[best],
        "tracked_gaits": tracked,
    }


def turning_centre(
    env_config: ml_collections.ConfigDict, search: dict[str, Any], seed: int = 0, robots: int = 2
) -> tuple[str, float]:
    """(action centre, its yaw rate with the sides at 1 ∓ δ) of the best gait of `search` that
    turns both ways (`turning_centres`); of the best, with a warning, where none does."""
    return turning_centres(env_config, search, seed, robots)[0]


def turning_centres(
    env_config: ml_collections.ConfigDict,
    search: dict[str, Any],
    seed: int = 0,
    robots: int = 2,
    count: int = 1,
) -> list[tuple[str, float]]:
    """(action centre, its yaw rate with the sides at 1 ∓ δ) of each of the `count` best gaits
    of `search` (its "action_centre", then its "ranking"'s others without falls, in order) whose
    open-loop walk the sides at 1 ∓ δ and at 1 ± δ turn in opposite directions, each at
    MIN_YAW_RATE or more, walking MIN_SPEED or more (fewer where fewer do); of the best alone,
    with a warning, where none does."""
    ranked = [
        oscillator.centre_spec(c["parameters"].values())
        for c in search.get("ranking", [])
        if c.get("score") is not None
    ]
    centres = list(dict.fromkeys([search["action_centre"], *ranked]))
    config, seconds = _open_loop(env_config), SETTLE_S + MEASURE_S
    one_way = []  # (yaw rate at 1 ∓ δ, at 1 ± δ) of each better gait that turns one way
    found = []
    for centre in centres:
        config.action_centre = centre
        (speed_left, left), (speed_right, right) = (
            _walk(config, f"1,{side}@{seconds}", seed, robots)
            for side in (SIDE_DIFFERENCE, -SIDE_DIFFERENCE)
        )
        walks = min(speed_left, speed_right) >= MIN_SPEED
        if walks and min(abs(left), abs(right)) >= MIN_YAW_RATE and left * right < 0:
            if one_way and not found:
                logger.warning(
                    "feed-forward: the search's best gaits turn one way at most with the sides at"
                    " 1 -/+ %g / 1 +/- %g (%s); its #%d, %s, turns %s: kept",
                    SIDE_DIFFERENCE, SIDE_DIFFERENCE, _turns(one_way), len(one_way) + 1, centre,
                    _turns([(left, right)]),
                )  # fmt: skip
            found.append((centre, left))
            if len(found) == count:
                break
        else:
            one_way.append((left, right))
    if found:
        return found
    logger.warning(
        "feed-forward: none of the search's %d best gaits turns both ways with the sides at"
        " 1 -/+ %g / 1 +/- %g (%s): keeping its best",
        len(centres), SIDE_DIFFERENCE, SIDE_DIFFERENCE, _turns(one_way),
    )  # fmt: skip
    return [(search["action_centre"], one_way[0][0])]


def _turns(yaw_rates: list[tuple[float, float]]) -> str:
    """Gaits' turning walks for a log line: "left / right rad/s; ..."."""
    return "; ".join(f"{left:+.3f} / {right:+.3f} rad/s" for left, right in yaw_rates)


def _open_loop(env_config: ml_collections.ConfigDict) -> ml_collections.ConfigDict:
    """`env_config` for the calibration's walks: no randomisation, the drive's loops open (its
    gain would make every scale walk its command, its heading loop the sides' difference turn at
    the command's ω*), the command (1, ω*) the side scales themselves."""
    config = ml_collections.ConfigDict(env_config.to_dict())
    config.randomization.enabled = False
    config.commands.speed_gain_rate = 0.0
    config.commands.heading_gain = 0.0
    config.commands.reference_speed = 1.0
    config.commands.half_track = 1.0
    config.commands.speed_map = ()
    return config


def measure(
    env_config: ml_collections.ConfigDict,
    seed: int = 0,
    robots: int = 2,
    yaw_rate: float | None = None,
) -> dict[str, float]:
    """{"reference_speed" (m/s), "half_track" (m), "speed_map" (m/s at SPEED_MAP_SCALES, or ()),
    "yaw_rate" (rad/s, of the turning walk)} measured on the zero action of `env_config` (its
    action centre) with `robots` robots each (reset seeds seed, seed + 1, ...). Where the gait is
    too slow, does not turn or its map does not grow with the scale, the config's resolved values
    are kept and a warning says why. `yaw_rate`: the turning walk's, where already walked
    (`turning_centre`)."""
    frictions = [None]  # the MJCF's
    if env_config.randomization.enabled:
        low, high = env_config.randomization.friction
        frictions = [low, (low + high) / 2, high]
    config = _open_loop(env_config)
    seconds = SETTLE_S + MEASURE_S
    speed = _walk(config, f"1,0@{seconds}", seed, robots)[0]
    if yaw_rate is None:
        yaw_rate = _walk(config, f"1,{SIDE_DIFFERENCE}@{seconds}", seed, robots)[1]
    resolved = env_lib.resolve(env_config)
    result = {
        "reference_speed": resolved.commands.reference_speed,
        "half_track": resolved.commands.half_track,
        "speed_map": resolved.commands.speed_map,
        "speed": speed,
        "yaw_rate": yaw_rate,
    }
    if not speed >= MIN_SPEED:
        logger.warning(
            "feed-forward: the gait %s: keeping v_ref %.2f m/s, b %.3f m",
            "falls" if math.isnan(speed) else f"walks {speed:.2f} m/s (< {MIN_SPEED:g})",
            result["reference_speed"],
            result["half_track"],
        )
        return result
    result["reference_speed"] = round(speed, 4)
    walks = {  # (scale, friction) -> speed, NaN where the gait fell
        (scale, friction): _walk(config, f"{scale},0@{seconds}", seed, robots, friction)[0]
        for scale in env_commands.SPEED_MAP_SCALES
        for friction in frictions
    }
    fell = [key for key, speed in walks.items() if math.isnan(speed)]
    if fell:
        logger.warning("feed-forward: the gait falls at (scale, friction) %s: left out", fell)
    speeds = [
        standing_mean([walks[scale, friction] for friction in frictions], 1)
        for scale in env_commands.SPEED_MAP_SCALES
    ]
    slope = speed  # v': m/s per unit of scale, as the drive turns side speeds into scales
    if all(a < b for a, b in zip([0.0, *speeds], speeds, strict=False)):
        result["speed_map"] = tuple(round(float(value), 4) for value in speeds)
        slope = speeds[-1] / env_commands.SPEED_MAP_SCALES[-1]
    else:
        logger.warning(
            "feed-forward: the speeds %s at the scales %s do not grow: keeping v_ref × scale",
            np.round(speeds, 3),
            env_commands.SPEED_MAP_SCALES,
        )
    if abs(yaw_rate) >= MIN_YAW_RATE:  # b < 0 where the right side's longer strides turn right
        result["half_track"] = round(float(SIDE_DIFFERENCE * slope / yaw_rate), 4)
    else:
        logger.warning(
            "feed-forward: sides at 1 -/+ %g turn the gait %.3f rad/s: keeping b %.3f m",
            SIDE_DIFFERENCE,
            yaw_rate,
            result["half_track"],
        )
    # The drive asks each side for v* -/+ ω*·b: where the fastest turn needs more than the
    # gait's full stride gives, turns saturate (and one side's strides stop).
    turn, top = abs(result["half_track"]) * resolved.commands.yaw_rate_max, slope
    if turn > top:
        logger.warning(
            "feed-forward: a turn at ω* %.2f rad/s asks each side for -/+ %.2f m/s, more than the"
            " gait's %.2f m/s at full stride: turns above %.2f rad/s saturate",
            resolved.commands.yaw_rate_max,
            turn,
            top,
            top / abs(result["half_track"]),
        )
    logger.info(
        "feed-forward: v_ref %.2f m/s, b %.3f m (sides at 1 -/+ %g: %.2f rad/s), speed map %s"
        " m/s at the scales %s",
        result["reference_speed"],
        result["half_track"],
        SIDE_DIFFERENCE,
        yaw_rate,
        result["speed_map"] or "v_ref × scale",
        env_commands.SPEED_MAP_SCALES,
    )
    return result


def standing_mean(values: list[float], min_standing: int) -> float:
    """The mean of `values` that are not NaN (a fall), NaN where fewer than `min_standing` are:
    a robot's or a friction's fall leaves the others' speeds as the gait's, not the whole walk
    void (ANYmal C's searched gaits lost one robot of two in the calibration walk)."""
    standing = [value for value in values if not math.isnan(value)]
    return float(np.mean(standing)) if len(standing) >= max(min_standing, 1) else math.nan


def _walk(
    config: ml_collections.ConfigDict,
    schedule: str,
    seed: int,
    robots: int,
    friction: float | None = None,
) -> tuple[float, float]:
    """(speed along the heading, m/s; yaw rate, rad/s) of the zero action under `schedule`,
    over the last MEASURE_S s of each robot's walk, averaged over the robots that stay up (NaN
    where more than half of them fall), with every geom's sliding friction set to `friction`
    (None: the MJCF's)."""
    walking = ml_collections.ConfigDict(config.to_dict())
    walking.commands.spec = schedule  # its own: not warned of past the ranges
    robot = host_robot.HostRobot("flat", walking, physics=PHYSICS)
    if friction is not None:  # as the randomisation draws it: every geom's
        robot.model.geom_friction[:, 0] = friction
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
                break
            if step == settle - 1:
                start = (*robot.data.qpos[:2], result.body.yaw, robot.data.time)
        if result.fell:
            speeds.append(math.nan)
            yaw_rates.append(math.nan)
            continue
        x0, y0, yaw0, t0 = start
        elapsed = robot.data.time - t0
        turned = twins.wrap_angle(result.body.yaw - yaw0)
        heading = yaw0 + turned / 2
        x1, y1 = robot.data.qpos[:2]
        speeds.append(((x1 - x0) * math.cos(heading) + (y1 - y0) * math.sin(heading)) / elapsed)
        yaw_rates.append(turned / elapsed)
    min_standing = robots - robots // 2  # more than half fall: NaN
    return standing_mean(speeds, min_standing), standing_mean(yaw_rates, min_standing)
