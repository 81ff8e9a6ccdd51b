"""What a critic may observe beyond the policy's observation (an asymmetric actor-critic: Pinto
et al. 2018, arXiv:1710.06542; FastTD3's critics on locomotion): the torso's velocities without
observation noise, then, for a randomised robot, its draw at its level (friction, torso mass,
servo gain, damping, strength, latency, CoM offset), the push on it and the action that still acts
for the latency's first steps, then, with commands, the drive's state (its gain, the heading
loop's correction, the low-passed yaw rate). A policy acts on its observation alone, so what it
learns needs none of this on a robot; the critic that trains it judges each robot as it is.

The trainer appends it to the observations it stores (`config.sac.privileged_critic`). Brax's
auto-reset keeps `info`, and the env draws a new robot in the step after it: an episode's first
stored observation carries the previous episode's draw (one transition of an episode's 1000)."""

from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from quadcos.env import randomization

_DRAW = 11  # `_draw`'s length


class Privileged(NamedTuple):
    """A critic's extra inputs for one env: `observe(states)` maps a batched `brax.envs.State`
    of the env (under any wrappers) to (num_envs, size); none (size 0) without them."""

    size: int
    observe: Callable[[Any], jax.Array] | None


def of(env: Any) -> Privileged:
    """The critic's extra inputs of a `QuadrupedEnv` `env` (under any wrappers); a ValueError for
    another env."""
    env = getattr(env, "unwrapped", env)
    if not hasattr(env, "randomized"):
        raise ValueError(
            f"config.sac.privileged_critic needs a quadcos env; {type(env).__name__} has no"
            " privileged inputs"
        )
    layout, physics_dt = env.layout, env.config.physics_dt
    size = 6 + (_DRAW + 3 + env.action_size) * env.randomized + 3 * env.commanded

    def observe(states: Any) -> jax.Array:
        qvel, info = states.pipeline_state.qvel, states.info
        parts = [qvel[:, layout.linear_velocity], qvel[:, layout.angular_velocity]]
        if env.randomized:
            physics = info["physics"]
            parts += [
                jax.vmap(_draw, (0, None))(physics, physics_dt),
                jax.vmap(randomization.push_force)(physics),
                info["action"],
            ]
        if env.commanded:
            command = info["velocity_command"]
            parts.append(jnp.stack([command.gain, command.correction, command.yaw_rate], -1))
        return jnp.concatenate(parts, axis=-1)

    return Privileged(size, observe)


def _draw(physics: randomization.Physics, physics_dt: float) -> jax.Array:
    """(11,) one robot's draw as it acts: the level, the friction drawn, the scales at the level,
    the latency (s), the CoM offset at the level, the seconds left of the push."""
    names = ("torso_mass_scale", "kp_scale", "damping_scale", "strength_scale")
    scales = [randomization.scale(physics, name) for name in names]
    latency = randomization.latency_steps(physics) * physics_dt
    return jnp.concatenate(
        [
            jnp.stack([physics.level, physics.friction, *scales, latency]),
            physics.level * physics.com_offset,
            physics.push_left_s[None],
        ]
    )
