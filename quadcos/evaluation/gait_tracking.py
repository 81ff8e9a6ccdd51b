"""Gaits compared by how well they track random commands, as SAC's step 0 meets them.

The gait search ranks candidates by the reward before the command's feed-forward is measured on
them, so its best gait need not be the one that tracks best, and SAC moves a gait's tracking
little (experiments/commands, "Gaits chosen by their tracking": Go1's searched gaits under one
preset track speed at 0.084–0.153 m/s at step 0; their kept policies a median 0.006 m/s
better). `track` walks several gaits, each with its own measured feed-forward, as one batch of
robots under random commands and the run's randomisation: their maps go in as data
(`rollout`'s `gaits`), so one program serves every gait.
"""

from collections.abc import Sequence
from typing import Any

import jax
import jax.numpy as jnp
import ml_collections
import numpy as np

from quadcos import env as env_lib
from quadcos.env import commands as env_commands
from quadcos.equations import oscillator
from quadcos.evaluation import rollout as rollout_lib
from quadcos.evaluation import sources

ROBOTS = 128  # robots that walk each gait
SECONDS = 20.0  # each robot's episode: four commands at the preset's 5-s resampling
TARGETS = (0.10, 0.15)  # m/s, rad/s: the tracking RMS a gait is scored against (issue 58's)


def score(
    speed_rms: float, yaw_rate_rms: float, attitude: float = 0.0, attitude_target: float = 0.0
) -> float:
    """A gait's tracking score: −max(speed RMS / 0.10 m/s, yaw-rate RMS / 0.15 rad/s) (`TARGETS`),
    > −1 where both are within; with an `attitude_target` > 0 (rad) also −`attitude` (its larger
    of the mean peak roll and pitch error) / `attitude_target`."""
    worst = max(speed_rms / TARGETS[0], yaw_rate_rms / TARGETS[1])
    return -max(worst, attitude / attitude_target) if attitude_target > 0 else -worst


def rank(
    fell: bool,
    speed_rms: float,
    yaw_rate_rms: float,
    attitude: float,
    max_attitude: float = 0.0,
    attitude_target: float = 0.0,
) -> tuple[bool, bool, float]:
    """How a measured gait ranks among others (higher is better): one that never fell first, then
    one within `max_attitude` (rad, where > 0), then by `score` (its attitude against
    `attitude_target`, where > 0)."""
    level = max_attitude <= 0 or attitude <= max_attitude
    return not fell, level, score(speed_rms, yaw_rate_rms, attitude, attitude_target)


def gait_maps(env_config: ml_collections.ConfigDict) -> dict[str, np.ndarray]:
    """The maps an env of `env_config` would hold for its action centre and feed-forward
    (`QuadrupedEnv.gait`), without building the env."""
    centre = oscillator.action_centre(env_config.action_centre, env_config.period_min)
    maps = {"action_map": np.asarray(oscillator.action_map(env_config.period_min, centre))}
    drive = env_commands.drive_map(env_lib.resolve(env_config).commands)
    return maps if drive is None else maps | {"drive_map": drive}


def track(
    terrain: str,
    env_configs: Sequence[ml_collections.ConfigDict],
    *,
    robots: int = ROBOTS,
    seconds: float = SECONDS,
    seed: int = 0,
) -> list[dict[str, Any]]:
    """Each config's gait (its action centre and feed-forward; the configs alike otherwise, with
    commands) walked by `robots` robots under random commands, the zero action acting, every
    gait on the same episodes (robot i of each: the same key, so the same commands and physics):
    per gait its "fall_rate", "speed_tracking_rms" (m/s), "yaw_rate_tracking_rms" (rad/s, both
    pooled over its robots' windows, as evaluations pool them), "mean_max_abs_roll",
    "mean_max_abs_pitch_error" (rad) and its "score"."""
    if not env_configs or robots < 1:
        raise ValueError(f"track needs gaits and robots >= 1; got {len(env_configs)}, {robots}")
    env = env_lib.QuadrupedEnv(terrain, env_configs[0])
    if not env.commanded:
        raise ValueError("track compares command tracking: the env config needs commands.spec")
    maps = [gait_maps(config) for config in env_configs]
    gaits = {name: np.repeat(np.stack([m[name] for m in maps]), robots, axis=0) for name in maps[0]}
    source = sources.ActionSource(
        name="gait", kind="gait", act=sources.zero_action,
        params=np.zeros(env.action_size, np.float32), env_overrides={}, training_terrain=terrain,
    )  # fmt: skip
    keys = jnp.tile(jax.random.split(jax.random.PRNGKey(seed), robots), (len(maps), 1))
    stats = rollout_lib.rollout(
        env, source, num_envs=robots * len(env_configs), num_steps=round(seconds / env.dt),
        gaits=gaits, keys=keys,
    ).stats  # fmt: skip
    return [_gait_entry(stats, slice(i * robots, (i + 1) * robots)) for i in range(len(maps))]


def _gait_entry(stats: rollout_lib.GaitEpisodeStats, robots: slice) -> dict[str, Any]:
    """One gait's line of `track`: its robots' (`robots`) falls, tracking and attitude."""
    windows = max(int(np.sum(stats.tracking.windows[robots])), 1)
    speed, yaw_rate = (
        float(np.sqrt(np.sum(errors[robots]) / windows))
        for errors in (stats.tracking.speed_sq_error, stats.tracking.yaw_rate_sq_error)
    )
    return {
        "fall_rate": float(np.mean(stats.fell[robots])),
        "speed_tracking_rms": speed,
        "yaw_rate_tracking_rms": yaw_rate,
        "mean_max_abs_roll": float(np.mean(stats.max_abs_roll[robots])),
        "mean_max_abs_pitch_error": float(np.mean(stats.max_abs_pitch_error[robots])),
        "score": score(speed, yaw_rate),
    }
