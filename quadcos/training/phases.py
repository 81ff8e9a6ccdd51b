"""A run in two phases: settings that change when SAC's actor starts learning.

`sac.at_actor_start` names run-config overrides (`KEY=VALUE` words apart by spaces or commas, as
the CLI's `--config.KEY=VALUE`) that take effect at the first chunk boundary at or past the
actor's first update (`host.actor_start_step`): the critics warm up on the replay of the first
settings, and the actor learns under the second, from the same state and replay
(`quadcos.training.session` runs both).
Only what leaves the training state's shapes alone may change: the reward's weights and SAC's
learning settings (`SWITCHABLE`).
"""

import copy
import re
from typing import Any

import jax
import ml_collections

from quadcos._util.overrides import apply_overrides, flatten, parse_value
from quadcos.training import config as config_lib
from quadcos.training import host, sac
from quadcos.training.checks import ConfigError

# Run-config keys (or key prefixes, ending in ".") that `sac.at_actor_start` may set.
SWITCHABLE = (
    "env.reward.",
    "sac.learning_rate.",
    "sac.smoothness.",
    "sac.target_entropy",
    "sac.policy_delay",
    "sac.discount",
    "sac.tau",
    "sac.reward_scaling",
    "sac.max_grad_norm",
    "sac.updates_per_step",
)


def parse(text: str) -> dict[str, Any]:
    """`sac.at_actor_start`'s words as {key: value} ({} for an empty string).

    Raises:
      ValueError: a word not KEY=VALUE, or a key outside `SWITCHABLE` (named).
    """
    overrides = {}
    for word in re.split(r"[\s,]+", text.strip()) if text.strip() else []:
        key, equals, value = word.partition("=")
        if not (equals and key and value):
            raise ValueError(f"config.sac.at_actor_start: {word!r} is not KEY=VALUE")
        if not any(key == name or (name.endswith(".") and key.startswith(name))
                   for name in SWITCHABLE):
            raise ValueError(
                f"config.sac.at_actor_start: {key!r} cannot change while a run trains (it may set"
                f" {', '.join(name + ('*' if name.endswith('.') else '') for name in SWITCHABLE)})"
            )
        overrides[key] = parse_value(value)
    return overrides


def second(config: ml_collections.ConfigDict) -> ml_collections.ConfigDict:
    """The run config (`{"env", "sac"}`) of the second phase: the first's with
    `sac.at_actor_start` applied, and cleared (a resumed second phase switches nothing).

    Raises:
      ValueError: as `parse`, or a value the config's field does not take.
    """
    overrides = parse(config.sac.at_actor_start)
    return apply_overrides(config, {**overrides, "sac.at_actor_start": ""})


def switch_step(config: ml_collections.ConfigDict) -> int:
    """The env step at which a run of trainer `config` that starts from nothing switches: where
    its actor starts learning, after the prefill (its first chunk's step)."""
    prefill = config_lib.prefill_steps(config) * config.num_envs
    return host.actor_start_step(config, 0, prefill) or prefill


def first_settings(config: ml_collections.ConfigDict) -> dict[str, Any]:
    """The first phase's values of the keys `sac.at_actor_start` sets (recorded in the run's
    config.json, whose config is the second phase's once it runs)."""
    flat = flatten(config.to_dict())
    return {key: flat[key] for key in parse(config.sac.at_actor_start)}


def ends_at_switch(config: ml_collections.ConfigDict) -> bool:
    """Whether trainer `config` is a first phase's (`trainer_until`'s): its run ends where its
    actor starts, and a second phase goes on from there."""
    return bool(config.at_actor_start.strip()) and config.num_timesteps == switch_step(config)


def carried(state: Any, template: Any) -> Any:
    """The arrays of `state` (the first phase's training state) in the structure of `template`
    (the second phase's trainer's `state_shapes`: clipped gradients add an optimiser state
    without arrays).

    Raises:
      ConfigError: the two hold arrays of other shapes or types.
    """
    arrays, (leaves, treedef) = jax.tree.leaves(state), jax.tree.flatten(template)
    shapes = [(tuple(a.shape), a.dtype) for a in arrays]
    expected = [(tuple(leaf.shape), leaf.dtype) for leaf in leaves]
    if shapes != expected:
        raise ConfigError(
            "config.sac.at_actor_start changes the training state's arrays"
            f" ({len(arrays)} arrays before the switch, {len(leaves)} after,"
            " or of other shapes): it may change rewards and learning settings only"
        )
    return jax.tree.unflatten(treedef, arrays)


def trainer_until(trainer: sac.SACTrainer, until: int | None) -> sac.SACTrainer:
    """`trainer`, or where `until` comes before its config's num_timesteps a shallow copy (its
    programs shared: they read no num_timesteps) whose run ends there."""
    if until is None or until >= trainer.config.num_timesteps:
        return trainer
    trainer = copy.copy(trainer)
    trainer.config = trainer.config.copy_and_resolve_references()
    trainer.config.num_timesteps = until
    return trainer
