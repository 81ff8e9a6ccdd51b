"""The state of a SAC run (`TrainingState`) and the pieces of an env step the trainer keeps."""

from typing import Any

import flax
import jax
import jax.numpy as jnp
import optax
from brax import envs
from brax.training import types
from brax.training.acme import running_statistics

from quadcos.env.quadruped import MAP_KEY
from quadcos.training import replay as replay_lib


@flax.struct.dataclass
class TrainingState:
    """Everything that changes during training; a checkpoint stores all of it.

    Parameters are flax param dicts; `log_alpha` is the log of the SAC
    temperature; `env_state` is the batched state of the wrapped training envs;
    `key` is the PRNG key of the next chunk. The counters are 64-bit (two
    uint32 halves) so that they do not wrap in long GPU runs: `env_steps`
    counts transitions (prefill included), `gradient_steps` SAC updates and
    `nan_resets` envs reset by the NaN guard. `exploration_noise` (num_envs, action_size) is each
    env's standard-normal exploration draw, held for `noise_hold_steps` steps on average.

    On several devices `env_state`, `exploration_noise` and `replay` are split along their first
    axis (the replay holds one ring per device, its positions one entry per device); everything
    else is replicated. Global shapes do not depend on the device count except the replay's
    positions.
    """

    policy_params: types.Params
    policy_optimizer_state: optax.OptState
    q_params: types.Params
    q_optimizer_state: optax.OptState
    target_q_params: types.Params
    log_alpha: jax.Array
    alpha_optimizer_state: optax.OptState
    normalizer_params: running_statistics.RunningStatisticsState
    env_state: envs.State
    replay: replay_lib.ReplayState
    key: jax.Array
    env_steps: types.UInt64
    gradient_steps: types.UInt64
    nan_resets: types.UInt64
    exploration_noise: jax.Array


# A vectorised env step's transitions and which of them are finite (to be stored).
Pending = tuple[types.Transition, jax.Array]
# The fields that SAC updates change.
LEARNER = (
    "policy_params",
    "policy_optimizer_state",
    "q_params",
    "q_optimizer_state",
    "target_q_params",
    "log_alpha",
    "alpha_optimizer_state",
    "gradient_steps",
)


def transitions(
    env_state: envs.State, actions: jax.Array, next_env_state: envs.State
) -> types.Transition:
    """The transitions of a vectorised env step, as Brax's SAC stores them."""
    return types.Transition(
        observation=env_state.obs,
        action=actions,
        reward=next_env_state.reward,
        discount=1 - next_env_state.done,
        next_observation=next_env_state.obs,
        extras={
            "state_extras": {"truncation": next_env_state.info["truncation"]},
            "policy_extras": {},
        },
    )


def where_per_env(mask: jax.Array, new: jax.Array, old: jax.Array) -> jax.Array:
    """`new` for the envs where the (num_envs,) `mask` holds, `old` elsewhere, for one leaf of a
    batched state. Leaves without the env axis (MJX-Warp's shared, often zero-size, buffers) are
    kept as they are."""
    if old.ndim < mask.ndim or old.shape[: mask.ndim] != mask.shape:
        return old
    mask = jnp.reshape(mask, mask.shape + (1,) * (old.ndim - mask.ndim))
    return jnp.where(mask, new, old).astype(old.dtype)


def strongly_typed(tree: Any) -> Any:
    """Drops weak types so a jitted function's outputs match its inputs.

    A leaf that enters weakly typed (e.g. a Python float from `reset`) and
    leaves strongly typed would make the next call retrace.
    """
    return jax.tree.map(lambda x: jax.lax.convert_element_type(x, jnp.asarray(x).dtype), tree)


def keeps_first_state(env_state: envs.State) -> bool:
    """Whether the training wrappers keep each env's first state (Brax's AutoReset does)."""
    return "first_pipeline_state" in env_state.info


def restart_where(mask: jax.Array, env_state: envs.State) -> envs.State:
    """The (num_envs,) `mask`ed envs restarted as at the end of an episode under Brax's
    AutoReset: physics and observation back to the episode's first state, done = 1 (the env
    restarts its own `info` where its clock reads 0), reward, metrics and what else of the env
    is non-finite (the episode sums of Brax's wrappers) 0. A select: a reset would put a second
    MJX program into every training program (a third of the smoke trainer's chunk and prefill
    compile times on the CPU)."""
    info = env_state.info
    first = lambda start, now: where_per_env(mask, start, now)
    zero = lambda now: where_per_env(mask, jnp.zeros_like(now), now)

    def finite(now: jax.Array) -> jax.Array:
        if not jnp.issubdtype(now.dtype, jnp.floating):
            return now
        return where_per_env(mask, jnp.where(jnp.isfinite(now), now, 0), now)

    return env_state.replace(
        pipeline_state=jax.tree.map(first, info["first_pipeline_state"], env_state.pipeline_state),
        obs=jax.tree.map(first, info["first_obs"], env_state.obs),
        reward=zero(env_state.reward),
        metrics=jax.tree.map(zero, env_state.metrics),
        done=jnp.where(mask, jnp.ones_like(env_state.done), env_state.done),
        info=jax.tree.map(finite, info),
    )


def action_map_of(env: envs.Env) -> jax.Array | None:
    """The (3, 5) action map of a quadcos env (`QuadrupedEnv.action_map`) under any wrappers;
    None for another env."""
    mapping = getattr(getattr(env, "unwrapped", env), "action_map", None)
    return None if mapping is None else jnp.asarray(mapping)


def with_action_map(env_state: envs.State, mapping: jax.Array | None) -> envs.State:
    """The batched `env_state` with the action map `mapping` (3, 5) in every env's
    `info[MAP_KEY]` (the env steps through it: quadcos.env.quadruped), or as it is for None."""
    if mapping is None:
        return env_state
    batch = env_state.done.shape
    info = {**env_state.info, MAP_KEY: jnp.broadcast_to(mapping, batch + mapping.shape[-2:])}
    return env_state.replace(info=info)


def carry_action_map(fresh: envs.State, env_state: envs.State) -> envs.State:
    """`fresh` (a reset) with the action map `env_state` steps through, where it has one."""
    if MAP_KEY not in env_state.info:
        return fresh
    return fresh.replace(info={**fresh.info, MAP_KEY: env_state.info[MAP_KEY]})


class MappedEnv(envs.Wrapper):
    """A batched env whose resets carry the action map `mapping` (`with_action_map`)."""

    def __init__(self, env: envs.Env, mapping: jax.Array):
        super().__init__(env)
        self.mapping = mapping

    def reset(self, rng: jax.Array) -> envs.State:
        return with_action_map(self.env.reset(rng), self.mapping)
