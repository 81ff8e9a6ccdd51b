"""Checks of a trainer config before anything is built or written: consistent values, and a
training state that fits in the device's memory."""

import math
import os
from typing import Any

import jax
import ml_collections

from quadcos._util.overrides import flat_keys
from quadcos.training import best_policy, sac
from quadcos.training import config as config_lib

# Config fields that size device arrays (or index them with int32).
_SHAPES = (
    "num_envs",
    "batch_size",
    "replay_size",
    "episode_length",
    "steps_per_chunk",
    "updates_per_step",
    "num_eval_envs",
    "eval_episode_length",
)


class ConfigError(ValueError):
    """The config cannot run: inconsistent values, or more memory than the device has.

    `train` raises it before writing anything.
    """


def check_config(config: ml_collections.ConfigDict) -> None:
    """Raises ConfigError naming the first inconsistent or unknown field of a trainer config."""
    try:
        _check_config(config)
        for name in _SHAPES:
            if config[name] >= 2**31:
                raise ValueError(f"config.{name} must be < 2**31, got {config[name]}")
        for kind in ("policy", "q"):
            sizes = config.hidden_sizes[kind]
            if not all(isinstance(size, int) and 1 <= size < 2**31 for size in sizes):
                raise ValueError(
                    f"config.hidden_sizes.{kind} must be layer widths >= 1, got {sizes}"
                )
        if not (isinstance(config.noise_hold_steps, int) and config.noise_hold_steps >= 1):
            raise ValueError(
                f"config.noise_hold_steps must be a whole number >= 1, got {config.noise_hold_steps}"
            )
        search = config.gait_search
        for name in ("num_candidates", "robots_per_candidate", "rounds", "elite"):
            if not (isinstance(search[name], int) and search[name] >= 1):
                raise ValueError(
                    f"config.gait_search.{name} must be a whole number >= 1, got {search[name]}"
                )
        if search.min_speed_of not in ("mean", "slowest"):
            raise ValueError(
                "config.gait_search.min_speed_of must be 'mean' or 'slowest', got"
                f" {search.min_speed_of!r}"
            )
        for name in ("max_attitude", "track_attitude"):
            if not 0 <= search[name] < math.inf:
                raise ValueError(
                    f"config.gait_search.{name} must be a finite angle >= 0 (rad; 0: off), got"
                    f" {search[name]}"
                )
        envs = search.num_candidates * search.robots_per_candidate
        if not (
            isinstance(search.confirm_robots, int)
            and search.confirm_robots >= 0
            and (search.confirm_robots == 0 or envs % search.confirm_robots == 0)
        ):
            raise ValueError(
                "config.gait_search.confirm_robots must be 0 or a whole number dividing"
                f" num_candidates x robots_per_candidate = {envs}, got {search.confirm_robots}"
            )
        if not (isinstance(search.track_gaits, int) and search.track_gaits >= 0):
            raise ValueError(
                "config.gait_search.track_gaits must be a whole number >= 0 (0: off), got"
                f" {search.track_gaits}"
            )
        if not 0 < search.seconds < math.inf:
            raise ValueError(
                f"config.gait_search.seconds must be finite and > 0, got {search.seconds}"
            )
        if not 0 <= search.max_fraction <= 1:
            raise ValueError(
                f"config.gait_search.max_fraction must be in [0, 1], got {search.max_fraction}"
            )
        lessons = config.curriculum
        if not (isinstance(lessons.promote_lanes, int) and lessons.promote_lanes >= 1):
            raise ValueError(
                "config.curriculum.promote_lanes must be a whole number >= 1, got"
                f" {lessons.promote_lanes}"
            )
        if not (0 < lessons.start_fraction <= 1 and 0 < lessons.promote_m < math.inf):
            raise ValueError(
                "config.curriculum.start_fraction must be in (0, 1] and promote_m finite and > 0,"
                f" got {lessons.start_fraction} and {lessons.promote_m}"
            )
        if not 0 < lessons.restart_fraction <= 1:
            raise ValueError(
                f"config.curriculum.restart_fraction must be in (0, 1], got {lessons.restart_fraction}"
            )
        if not -(2**63) <= config.seed < 2**63:
            raise ValueError(f"config.seed must fit in 64 bits, got {config.seed}")
        if not (0 <= config.discount <= 1 and 0 < config.tau <= 1):
            raise ValueError(
                f"config.discount must be in [0, 1] and config.tau in (0, 1], got"
                f" {config.discount} and {config.tau}"
            )
        rates = {f"learning_rate.{name}": rate for name, rate in config.learning_rate.items()}
        for name, value in (("init_alpha", config.init_alpha), *rates.items()):
            if not value > 0:
                raise ValueError(f"config.{name} must be > 0, got {value}")
    except ValueError as error:
        raise ConfigError(str(error)) from None


def check_tracked(config: ml_collections.ConfigDict, env: Any) -> None:
    """Raises ConfigError where a trainer `config` keeps the best evaluation's policy ranked by
    command tracking (`best_policy_by` "tracking" or "gait") but the robots of `env` follow no
    commands."""
    tracked = config.keep_best_policy and config.best_policy_by in best_policy.TRACKED
    if tracked and not getattr(env, "commanded", False):
        raise ConfigError(
            f"config.best_policy_by {config.best_policy_by!r} ranks evaluations by command"
            " tracking: the env's robots must follow velocity commands (env.commands.spec)"
        )


def check_memory(trainer: sac.SACTrainer) -> None:
    """Raises ConfigError when the training state would not fit in the device's memory.

    The estimate counts what stays allocated: the training state (replay buffer and training
    envs included) and the evaluation envs' states; not the temporaries of a step.
    """
    config = trainer.config
    state = trainer.state_shapes
    replay_bytes = _nbytes(state.replay)
    env_bytes = _nbytes(state.env_state) * (1 + config.num_eval_envs / config.num_envs)
    # Spread over the devices (the replicated networks are small beside the buffer and envs).
    shards = trainer.layout.shards
    total = (_nbytes(state) - _nbytes(state.env_state) + env_bytes) / shards
    replay_bytes, env_bytes = replay_bytes / shards, env_bytes / shards
    device = jax.local_devices()[0]
    capacity = _memory_bytes(device)
    if total > capacity:
        raise ConfigError(
            f"the run needs about {total / 1e9:.3g} GB (replay buffer of {config.replay_size}"
            f" transitions: {replay_bytes / 1e9:.3g} GB; {config.num_envs} training and"
            f" {config.num_eval_envs} evaluation envs: {env_bytes / 1e9:.3g} GB) but the"
            f" {device.platform} device has {capacity / 1e9:.3g} GB"
            + (f" (per device, over {shards})" if shards > 1 else "")
            + ";"
            " lower the SAC config's replay_size or num_envs (quadcos.train:"
            " --config.sac.replay_size, --num_envs)"
        )


def _nbytes(tree: Any) -> int:
    return sum(math.prod(leaf.shape) * leaf.dtype.itemsize for leaf in jax.tree.leaves(tree))


def _memory_bytes(device: jax.Device) -> int:
    """Memory of an accelerator (its allocator's limit), or of the host for the CPU."""
    stats = device.memory_stats() if device.platform != "cpu" else None
    if stats and "bytes_limit" in stats:
        return stats["bytes_limit"]
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def _check_critic(config: ml_collections.ConfigDict) -> None:
    """Raises ValueError where the distributional critics' settings cannot make a support."""
    if config.critic_atoms == 0:
        return
    if config.critic_atoms < 2:
        raise ValueError(f"config.critic_atoms must be 0 (off) or >= 2, got {config.critic_atoms}")
    value_range = config.critic_value_range
    numbers = all(isinstance(v, int | float) for v in value_range)
    if (
        len(value_range) != 2
        or not numbers
        or not -math.inf < value_range[0] < value_range[1] < math.inf
    ):
        raise ValueError(
            f"config.critic_value_range must be two finite returns v_min < v_max, got {value_range}"
        )


def _check_config(config: ml_collections.ConfigDict) -> None:
    """Raises ValueError naming the first inconsistent or unknown field."""
    expected = set(flat_keys(config_lib.default_config()))
    given = set(flat_keys(config))
    if unknown := sorted(given - expected):
        raise ValueError(f"unknown config keys: {unknown}")
    if missing := sorted(expected - given):
        raise ValueError(f"missing config keys: {missing}")
    positive = (
        "num_envs",
        "num_timesteps",
        "episode_length",
        "batch_size",
        "updates_per_step",
        "policy_delay",
        "n_step",
        "replay_size",
        "steps_per_chunk",
        "eval_interval",
        "num_eval_envs",
        "eval_episode_length",
        "checkpoint_interval",
        "keep_checkpoints",
    )
    for name in positive:
        if config[name] < 1:
            raise ValueError(f"config.{name} must be >= 1, got {config[name]}")
    if not 0 <= config.max_seconds < math.inf:
        raise ValueError(f"config.max_seconds must be finite and >= 0, got {config.max_seconds}")
    if not 0 <= config.best_policy_max_fall_rate <= 1:
        raise ValueError(
            "config.best_policy_max_fall_rate must be a fraction in [0, 1], got"
            f" {config.best_policy_max_fall_rate}"
        )
    if not 0 <= config.best_policy_max_attitude < math.inf:
        raise ValueError(
            "config.best_policy_max_attitude must be a finite angle >= 0 (rad; 0: off), got"
            f" {config.best_policy_max_attitude}"
        )
    if config.best_policy_by not in best_policy.RANKS:
        raise ValueError(
            f"config.best_policy_by must be one of {', '.join(best_policy.RANKS)}, got"
            f" {config.best_policy_by!r}"
        )
    targets = tuple(config.best_policy_tracking_targets)
    if len(targets) != 2 or not all(0 < t < math.inf for t in targets):
        raise ValueError(
            "config.best_policy_tracking_targets must be two finite speeds > 0 (m/s, rad/s), got"
            f" {targets}"
        )
    _check_critic(config)
    if config.actor_warmup_steps < 0:
        raise ValueError(f"config.actor_warmup_steps must be >= 0, got {config.actor_warmup_steps}")
    for name, value in config.smoothness.items():
        if not 0 <= value < math.inf:
            raise ValueError(f"config.smoothness.{name} must be finite and >= 0, got {value}")
    if config.num_devices is not None and config.num_devices < 1:
        raise ValueError(f"config.num_devices must be >= 1 or None (all), got {config.num_devices}")
    if config.replay_size < config.num_envs:
        raise ValueError(
            f"config.replay_size ({config.replay_size}) must hold one step of all"
            f" envs (num_envs = {config.num_envs})"
        )
    if not 0 <= config.min_replay_size <= config.replay_size:
        raise ValueError(
            f"config.min_replay_size ({config.min_replay_size}) must be in"
            f" [0, replay_size = {config.replay_size}]"
        )
    if config.prefill_actions not in sac.PREFILL_ACTIONS:
        raise ValueError(
            f"config.prefill_actions must be one of {sac.PREFILL_ACTIONS}, got {config.prefill_actions!r}"
        )
    if config.init_std is not None and not config.init_std > sac.MIN_STD:
        raise ValueError(f"config.init_std must be > {sac.MIN_STD}, got {config.init_std}")
    prefill_steps = config_lib.prefill_steps(config) * config.num_envs
    if prefill_steps >= config.num_timesteps:
        raise ValueError(
            f"no training would happen: the prefill of min_replay_size"
            f" ({config.min_replay_size}) takes {prefill_steps} env steps >="
            f" num_timesteps ({config.num_timesteps})"
        )
