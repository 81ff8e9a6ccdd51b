"""Simulation throughput: raw MJX physics steps and env steps (oscillator, estimator, reward
inside) of a batch of robots."""

import functools
from collections.abc import Callable

import jax
import jax.numpy as jnp
from brax.envs import base
from mujoco import mjx

from quadcos import env as env_lib
from quadcos.benchmarking.timing import Timing, _strongly_typed, time_calls
from quadcos.env import backends


def make_batch_reset(env: base.Env) -> Callable[[int], base.State]:
    """num_envs -> `jax.vmap(env.reset)` of that many robots (strongly typed), compiled once per
    size, so that the physics and env measurements of one size share it."""
    reset_all = jax.jit(lambda keys: _strongly_typed(jax.vmap(env.reset)(keys)))
    return lambda num_envs: reset_all(jax.random.split(jax.random.PRNGKey(0), num_envs))


def measure_physics(env: env_lib.QuadrupedEnv, states: base.State, calls: int) -> Timing:
    """Raw `mjx.step` of `env.model` over the batch `states.pipeline_state`; one call =
    `env.substeps` physics steps (an env step's worth), looped as the env loops them
    (`substep_unroll`). The robots keep the controls they were reset with: they stand."""
    return time_calls(functools.partial(env_step_of_physics, env), states.pipeline_state, calls)


# Env steps a call of the gait measurement, as a training chunk steps its env steps in one call:
# stepped a call an env step, walking robots ran at 0.78 of the rate of 16 a call (MJX-Warp, one
# H200, flat; standing robots, with no XLA kernels before the physics' calls, at 1.00).
GAIT_STEPS_PER_CALL = 16


def measure_gait_physics(env: env_lib.QuadrupedEnv, states: base.State, calls: int) -> Timing:
    """`measure_physics` of robots walking the env's motion under the zero action (the action
    centre: the fixed trot), `GAIT_STEPS_PER_CALL` env steps a call (a `lax.scan`, as a training
    chunk runs them); each env step sets the controls of the targets at its start
    (`QuadrupedEnv.zero_action_targets`), held over its substeps. Robots in motion make the solver
    iterate more than standing ones (its early exit comes later), as in training. A robot with
    motors gets its PD torques towards those targets every substep, as the env computes them."""
    targets_at = jax.vmap(env.zero_action_targets)
    controls = jax.vmap(env.layout.controls)

    def walking(data: mjx.Data, _) -> tuple[mjx.Data, None]:
        targets = targets_at(data.time)

        def actuate(data: mjx.Data) -> mjx.Data:
            return data.replace(ctrl=controls(targets, data))

        if env.layout.motor:
            return env_step_of_physics(env, data, actuate), None
        return env_step_of_physics(env, actuate(data)), None

    return time_calls(
        lambda data: jax.lax.scan(walking, data, None, GAIT_STEPS_PER_CALL)[0],
        states.pipeline_state,
        calls,
    )


def env_step_of_physics(
    env: env_lib.QuadrupedEnv,
    data: mjx.Data,
    actuate: Callable[[mjx.Data], mjx.Data] | None = None,
) -> mjx.Data:
    """`env.substeps` vmapped `mjx.step`s of `env.model`, looped as the env loops them; with
    `actuate`, each after `actuate` set the batch's controls."""
    step_all = jax.vmap(backends.step, in_axes=(None, 0))  # the env's trace of MJX's step
    data, _ = jax.lax.scan(
        lambda data, _: (step_all(env.model, actuate(data) if actuate else data), None),
        data,
        None,
        length=env.substeps,
        unroll=env.substep_unroll,
    )
    return data


def measure_env(env: env_lib.QuadrupedEnv, states: base.State, calls: int) -> Timing:
    """`jax.vmap(env.step)` over the batch `states` under the zero action (the action centre:
    the fixed trot)."""
    action = jnp.zeros((states.obs.shape[0], env.action_size))
    step_all = jax.vmap(env.step)
    return time_calls(lambda state: step_all(state, action), states, calls)
