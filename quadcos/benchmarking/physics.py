"""Simulation throughput: raw MJX physics steps and env steps (oscillator, estimator, reward
inside) of a batch of robots."""

from collections.abc import Callable

import jax
import jax.numpy as jnp
from brax.envs import base
from mujoco import mjx

from quadcos import env as env_lib
from quadcos.benchmarking.timing import Timing, _strongly_typed, time_calls


def make_batch_reset(env: base.Env) -> Callable[[int], base.State]:
    """num_envs -> `jax.vmap(env.reset)` of that many robots (strongly typed), compiled once per
    size, so that the physics and env measurements of one size share it."""
    reset_all = jax.jit(lambda keys: _strongly_typed(jax.vmap(env.reset)(keys)))
    return lambda num_envs: reset_all(jax.random.split(jax.random.PRNGKey(0), num_envs))


def measure_physics(env: env_lib.QuadrupedEnv, states: base.State, calls: int) -> Timing:
    """Raw `mjx.step` of `env.model` over the batch `states.pipeline_state`; one call =
    `env.substeps` physics steps (an env step's worth), looped as the env loops them
    (`substep_unroll`)."""
    step_all = jax.vmap(mjx.step, in_axes=(None, 0))

    def env_step_of_physics(data: mjx.Data) -> mjx.Data:
        data, _ = jax.lax.scan(
            lambda data, _: (step_all(env.model, data), None),
            data,
            None,
            length=env.substeps,
            unroll=env.substep_unroll,
        )
        return data

    return time_calls(env_step_of_physics, states.pipeline_state, calls)


def measure_env(env: env_lib.QuadrupedEnv, states: base.State, calls: int) -> Timing:
    """`jax.vmap(env.step)` over the batch `states` under the zero action (the action centre:
    the fixed trot)."""
    action = jnp.zeros((states.obs.shape[0], env.action_size))
    step_all = jax.vmap(env.step)
    return time_calls(lambda state: step_all(state, action), states, calls)
