"""What the policy observes of one robot, in order: torso velocity (3), pitch / yaw / roll (3),
the leg joints, the slope estimate (Eq. 5; `observe_slope`), cos ψ / sin ψ (`observe_phase`), the
filtered action (`action_filter_tau` > 0), the torso's angular velocity in its own frame (3;
`observe_angular_velocity`), then, with commands, the observed speed
(`commands.observed_speed_tau` > 0), the drive's state (`commands.observe_drive`) and (v*, ω*)."""

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import ml_collections

from quadcos._util.quiet import warp_absence_unprinted
from quadcos.env.layout import Layout
from quadcos.equations import kinematics, slope

with warp_absence_unprinted():  # MJX prints a notice to stdout when warp-lang is absent
    from mujoco import mjx


class Observed(NamedTuple):
    """What one look at the robot yields: the policy's observation and the estimator's outputs."""

    obs: jax.Array
    attitude: slope.Attitude
    slope_estimate: jax.Array


def size(
    config: ml_collections.ConfigDict, layout: Layout, action_size: int, commanded: bool
) -> int:
    """The observation's length under an env `config`: `observe`'s parts, then `with_command`'s;
    counted, as tracing a reset for its shape would cost seconds of every env's start."""
    filtered = action_size if config.action_filter_tau > 0 else 0
    drive = 3 * config.commands.observe_drive
    command = (2 + (config.commands.observed_speed_tau > 0) + drive) * commanded
    joints = len(layout.joint_qpos)
    gyro = 3 * config.observe_angular_velocity
    return 6 + joints + config.observe_slope + 2 * config.observe_phase + filtered + gyro + command


def observe(
    config: ml_collections.ConfigDict,
    layout: Layout,
    data: mjx.Data,
    phase: jax.Array,
    command: jax.Array,
) -> Observed:
    """One robot's observation (without the velocity command) at oscillator phase `phase` under
    the filtered action `command`, with its attitude and slope estimate."""
    quaternion = layout.orientation(data)
    body = slope.attitude(quaternion)
    joints = data.qpos[layout.joint_qpos]
    feet = kinematics.foot_positions(layout.chains, joints)
    slope_estimate = slope.estimate_slope(feet, quaternion)
    parts = [
        data.qvel[layout.linear_velocity],
        jnp.stack([body.pitch, body.yaw, body.roll]),
        joints,
    ]
    if config.observe_slope:
        parts.append(slope_estimate[None])
    if config.observe_phase:
        parts.append(jnp.stack([jnp.cos(phase), jnp.sin(phase)]))
    if config.action_filter_tau > 0:
        parts.append(command)
    if config.observe_angular_velocity:
        parts.append(data.qvel[layout.angular_velocity])
    return Observed(obs=jnp.concatenate(parts), attitude=body, slope_estimate=slope_estimate)


def with_command(
    config: ml_collections.ConfigDict, obs: jax.Array, info: dict[str, Any]
) -> jax.Array:
    """`obs` with the velocity command (v*, ω*) of `info["velocity_command"]` last; before it the
    observed speed (`commands.observed_speed_tau`) and the drive's state (`commands.observe_drive`:
    g, s, the low-passed yaw rate)."""
    command = info["velocity_command"]
    parts = [obs]
    if config.commands.observed_speed_tau > 0:
        parts.append(command.speed[None])
    if config.commands.observe_drive:
        parts.append(jnp.stack([command.gain, command.correction, command.yaw_rate]))
    return jnp.concatenate([*parts, command.velocity])
