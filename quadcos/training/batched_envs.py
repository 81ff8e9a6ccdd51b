"""The training envs as one batch: the keys a batched reset takes, the envs' observation size,
and the jitted reset (keys → states) and step of all of them, which `SACTrainer` calls inside its
programs (`quadcos.training.sac`).
"""

from typing import Any

import jax
import jax.numpy as jnp
from brax import envs
from jax.sharding import PartitionSpec

from quadcos.training import parallel
from quadcos.training import state as state_lib


def env_keys(num_envs: int) -> jax.ShapeDtypeStruct:
    """The shape of the keys a batched env's reset takes."""
    return jax.ShapeDtypeStruct((num_envs,) + jax.random.PRNGKey(0).shape, jnp.uint32)


def observation_size(env: envs.Env, reset_envs: Any, num_envs: int) -> int:
    """Length of `env`'s flat observation vector: its own count (`QuadrupedEnv`'s: no trace), or,
    for Brax's (a reset, run), read off the trace of the batched `reset_envs` (keys → states)."""
    counted = type(getattr(env, "unwrapped", env)).observation_size
    if counted is not envs.PipelineEnv.observation_size:
        return env.observation_size
    obs = jax.eval_shape(reset_envs, env_keys(num_envs)).obs
    if not hasattr(obs, "shape") or len(obs.shape) != 2:
        raise ValueError(f"SAC needs a flat observation vector; got {obs}")
    return obs.shape[1]


def reset_and_step(
    env: envs.Env,
    layout: parallel.Layout,
    num_envs: int,
    gait: dict[str, jax.Array] | None,
    impl: str,
) -> tuple[Any, Any]:
    """The jitted reset (keys → states) and step of the `num_envs` batched training envs `env`
    (wrapped), whose states carry `gait`, on physics `impl`. On several devices with MJX-Warp,
    each device resets and steps its own envs (`parallel.per_device`); the JAX physics is split
    by the SPMD partitioner with the rest of the program."""
    if layout.mesh is None or impl != "warp":
        return jax.jit(env.reset), jax.jit(env.step)
    fresh = jax.eval_shape(env.reset, env_keys(num_envs))
    specs = parallel.env_specs(fresh, num_envs)
    mapped = jax.eval_shape(state_lib.with_gait, fresh, gait)
    step_specs = parallel.env_specs(mapped, num_envs)  # the states the trainer steps
    envs_axis = PartitionSpec(parallel.AXIS)
    reset = parallel.per_device(env.reset, layout, envs_axis, specs)
    step = parallel.per_device(env.step, layout, (step_specs, envs_axis), step_specs)
    return jax.jit(reset), jax.jit(step)
