"""The controller (paper Fig. 3): an action → the robot's joint targets at oscillator phase ψ and
time t. The oscillator controller maps the action to §3.3's rhythm parameters and those to joint
targets by Eq. 3 — with hip offsets (`posture_bound`), a turn (`turn_mode`), the velocity
command's feed-forward and a start ramp where the config sets them; `controller="joint"` takes
the joint targets straight from the action (the "DRL-only" baseline of §5).

Pure functions of one robot's arrays (jit / vmap-able; batch with `jax.vmap`): the env's config
and `Layout` and its gait's maps (`action_map` (3, 5), `drive_map` (5,): data a trainer may trace,
`QuadrupedEnv.gait`) are arguments. `QuadrupedEnv` calls them.
"""

import jax
import jax.numpy as jnp
import ml_collections
import numpy as np

from quadcos.env import commands
from quadcos.env.config import action_size, rhythm_scales
from quadcos.env.layout import Layout
from quadcos.equations import oscillator

JOINT_TARGET_BOUND = oscillator.AMPLITUDE_BOUND  # rad: the joint controller's target range


def rhythm_parameters(
    config: ml_collections.ConfigDict, action_map: jax.Array | np.ndarray, action: jax.Array
) -> oscillator.RhythmParameters:
    """The rhythm parameters (§3.3) that the oscillator controller's `action` sets."""
    return oscillator.mapped_parameters(
        action[..., : oscillator.RHYTHM_SIZE], action_map, rhythm_scales(config)
    )


def action_for(
    config: ml_collections.ConfigDict,
    action_map: jax.Array | np.ndarray,
    params: oscillator.RhythmParameters,
) -> jax.Array:
    """The (..., action_size) action that commands rhythm parameters `params` (no posture
    offset; 0 for the parameters `held_rhythm` holds)."""
    action = oscillator.mapped_action(params, action_map, rhythm_scales(config))
    padding = [(0, 0)] * (action.ndim - 1) + [(0, action_size(config) - oscillator.RHYTHM_SIZE)]
    return jnp.pad(action, padding)


def period(
    config: ml_collections.ConfigDict, action_map: jax.Array | np.ndarray, command: jax.Array
) -> jax.Array:
    """The oscillator period T (s) that `command` sets; the joint controller has none, so its
    phase runs at the fixed trot's period (it is observable with `observe_phase` only)."""
    if config.controller == "joint":
        return jnp.asarray(oscillator.FIXED_TROT.period, jnp.float32)
    return rhythm_parameters(config, action_map, command).period


def drive_for(
    config: ml_collections.ConfigDict, drive_map: jax.Array | np.ndarray | None, velocity: jax.Array
) -> jax.Array | None:
    """(..., 2) the left and right hip-swing scales that velocity commands (..., 2) set
    (`commands.drive`; a command's loops closed: `commands.Command.driven`), or None without
    the feed-forward (`drive_map` None)."""
    if drive_map is None:
        return None
    return commands.drive(config.commands, velocity, drive_map)


def zero_action_targets(
    config: ml_collections.ConfigDict,
    layout: Layout,
    action_map: jax.Array | np.ndarray,
    time: jax.Array,
) -> jax.Array:
    """(J,) joint targets of a robot that has held the zero action (the action centre) since
    its reset, at time t (s since the episode's start): its command stays at the centre and its
    phase is 2π·t/T, T the centre's period."""
    command = jnp.zeros(action_size(config))
    phase = oscillator.advance_phase(jnp.zeros(()), period(config, action_map, command), time)
    return joint_targets(config, layout, action_map, command, phase, time)


def joint_targets(
    config: ml_collections.ConfigDict,
    layout: Layout,
    action_map: jax.Array | np.ndarray,
    action: jax.Array,
    phase: jax.Array,
    time: jax.Array,
    drive: jax.Array | None = None,
) -> jax.Array:
    """(J,) joint targets (rad; the robot's leg joints, `RobotDescription.joint_names`) that
    `action` commands at oscillator phase ψ / time t (s since the episode's start): the home
    pose moved by the rhythm; `drive`: the command's feed-forward (`drive_for`)."""
    if config.controller == "joint":
        return layout.home + JOINT_TARGET_BOUND * jnp.clip(action, -1.0, 1.0)
    targets = layout.rhythm_targets(rhythm(config, action_map, action, phase, time, drive))
    if config.turn_mode == "abduction_stride":
        swing = _swing(config, action_map, action, phase, time, drive) * _ramp(config, time)
        turn = action[..., _turn_index(config)]
        abduction = oscillator.abduction_stride(swing, turn, config.turn_bound)
        targets = targets + layout.abduction_targets(abduction)
    return targets


def rhythm(
    config: ml_collections.ConfigDict,
    action_map: jax.Array | np.ndarray,
    action: jax.Array,
    phase: jax.Array,
    time: jax.Array,
    drive: jax.Array | None = None,
) -> jax.Array:
    """(8,) Eq. 3's oscillator outputs (rad; LF hip, LF knee, ..., RB knee) that the oscillator
    controller's `action` commands at phase ψ / time t (s since the episode's start), hip
    offsets included and, with `start_ramp_s`, a growing share of it in the first seconds
    (the "abduction_stride" turn acts on other joints: `joint_targets`)."""
    targets = _swing(config, action_map, action, phase, time, drive)
    if config.posture_bound > 0:
        targets += oscillator.posture_offsets(
            action[..., oscillator.RHYTHM_SIZE :], config.posture_bound
        )
    return targets * _ramp(config, time)


def _turn_index(config: ml_collections.ConfigDict) -> int:
    """Where the turn value sits in an action (after the rhythm and the posture values)."""
    posture = oscillator.POSTURE_SIZE if config.posture_bound > 0 else 0
    return oscillator.RHYTHM_SIZE + posture


def _ramp(config: ml_collections.ConfigDict, time: jax.Array) -> jax.Array | float:
    """The share of the rhythm acting at time t (`start_ramp_s`; 1 without a ramp)."""
    if config.start_ramp_s > 0:  # a growing share in an episode's first seconds
        return oscillator.start_ramp(time, config.start_ramp_s)
    return 1.0


def _swing(
    config: ml_collections.ConfigDict,
    action_map: jax.Array | np.ndarray,
    action: jax.Array,
    phase: jax.Array,
    time: jax.Array,
    drive: jax.Array | None,
) -> jax.Array:
    """(8,) Eq. 3's outputs for `action`, left and right hips apart with the
    "hip_amplitude_difference" turn and the feed-forward's `drive`; no posture offsets, no
    ramp."""
    params = rhythm_parameters(config, action_map, action)
    phases = oscillator.trot_phases(params.phi1, params.phi3)
    if config.oscillator_form == "literal":
        targets = oscillator.cosine_rhythm(
            time, params.amplitude_hip, params.amplitude_knee, params.period, phases
        )
    else:
        targets = oscillator.rhythm_at_phase(
            phase, params.amplitude_hip, params.amplitude_knee, phases
        )
    if config.turn_mode == "hip_amplitude_difference":
        turn = action[..., _turn_index(config)]
        targets = oscillator.hip_amplitude_difference(targets, turn, config.turn_bound)
    if drive is not None:
        targets = oscillator.side_scaled(targets, drive)
    return targets
