"""The randomisation ramp: a training robot's physics perturbations grow from none to the full
ranges over its first `env.randomization.ramp_s` seconds.

A randomised robot's draw acts at a level (`quadcos.randomization`: 0 is the nominal robot, 1 the
draw). `RandomizationRamp` counts each env's control steps across its episodes and, before every
step, sets its draw's level to min(1, steps · dt / ramp_s): a policy first learns on the nominal
robot and meets friction, mass, gains, latency and pushes as they grow. Only training is ramped:
evaluations draw at level 1.
"""

import jax
import jax.numpy as jnp
from brax import envs


class RandomizationRamp(envs.Wrapper):
    """The level ramp over the batched, auto-resetting training env `env` (see the module doc);
    `dt` is the control period (s). The state's info holds per env "ramp_steps" (int32)."""

    def __init__(self, env: envs.Env, dt: float, ramp_s: float):
        super().__init__(env)
        self._dt = float(dt)
        self._ramp_s = float(ramp_s)

    def level(self, steps: jax.Array) -> jax.Array:
        return jnp.minimum(1.0, steps * (self._dt / self._ramp_s))

    def _at_level(self, state: envs.State, steps: jax.Array) -> envs.State:
        physics = state.info["physics"]._replace(level=self.level(steps))
        return state.replace(info={**state.info, "physics": physics, "ramp_steps": steps})

    def reset(self, rng: jax.Array) -> envs.State:
        state = self.env.reset(rng)
        return self._at_level(state, jnp.zeros(state.done.shape, jnp.int32))

    def step(self, state: envs.State, action: jax.Array) -> envs.State:
        steps = state.info["ramp_steps"]
        state = self.env.step(self._at_level(state, steps), action)
        return state.replace(info={**state.info, "ramp_steps": steps + 1})
