"""The state of a SAC run (`TrainingState`) and the pieces of an env step the trainer keeps."""

from collections.abc import Callable
from typing import Any

import flax
import jax
import jax.numpy as jnp
import optax
from brax import envs
from brax.training import types
from brax.training.acme import running_statistics

from quadcos.env.quadruped import GAIT_KEY
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
    # With `n_step` n > 1: the last n − 1 vectorised steps (quadcos.training.n_step.Queue)
    n_step_queue: Any = None


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
    env_state: envs.State,
    actions: jax.Array,
    next_env_state: envs.State,
    privileged: Callable[[envs.State], jax.Array] | None = None,
) -> types.Transition:
    """The transitions of a vectorised env step, as Brax's SAC stores them; with `privileged`
    (a batched state's critic inputs: `quadcos.env.privileged`) each observation followed by
    them."""

    def observed(env_state: envs.State) -> jax.Array:
        if privileged is None:
            return env_state.obs
        return jnp.concatenate([env_state.obs, privileged(env_state)], axis=-1)

    return types.Transition(
        observation=observed(env_state),
        action=actions,
        reward=next_env_state.reward,
        discount=1 - next_env_state.done,
        next_observation=observed(next_env_state),
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


def gait_of(env: envs.Env) -> dict[str, jax.Array] | None:
    """The gait's maps of a quadcos env (`QuadrupedEnv.gait`) under any wrappers; None for
    another env."""
    gait = getattr(getattr(env, "unwrapped", env), "gait", None)
    return None if gait is None else {name: jnp.asarray(value) for name, value in gait.items()}


def with_gait(env_state: envs.State, gait: dict[str, jax.Array] | None) -> envs.State:
    """The batched `env_state` with the gait's maps `gait` in every env's `info[GAIT_KEY]` (the
    env steps through them: quadcos.env.quadruped), or as it is for None."""
    if gait is None:
        return env_state
    batch = env_state.done.shape
    batched = {name: jnp.broadcast_to(value, batch + value.shape) for name, value in gait.items()}
    return env_state.replace(info={**env_state.info, GAIT_KEY: batched})


def carry_gait(fresh: envs.State, env_state: envs.State) -> envs.State:
    """`fresh` (a reset) with the gait `env_state` steps through, where it has one."""
    if GAIT_KEY not in env_state.info:
        return fresh
    return fresh.replace(info={**fresh.info, GAIT_KEY: env_state.info[GAIT_KEY]})


class GaitEnv(envs.Wrapper):
    """A batched env whose resets carry the gait's maps `gait` (`with_gait`)."""

    def __init__(self, env: envs.Env, gait: dict[str, jax.Array]):
        super().__init__(env)
        self.gait = gait

    def reset(self, rng: jax.Array) -> envs.State:
        return with_gait(self.env.reset(rng), self.gait)
