"""Cosine-oscillator rhythm controller (paper §3.1, Eqs. 1–4) and the trot action map (§3.3).

Pure JAX: every function broadcasts over leading dimensions and is jit/vmap-able.
Joint order everywhere: LF hip, LF knee, RF hip, RF knee, LB hip, LB knee, RB hip, RB knee.

Two forms of the same oscillator:
- the literal form `cosine_rhythm(t, ...)` evaluates Eq. 3 at time t with period T. When T changes
  (SAC picks a new T every control step) 2πt/T jumps, and so do the joint targets.
- the phase-continuous form carries the oscillator phase ψ and advances it by 2π·dt/T each physics
  step (`advance_phase`), then evaluates `rhythm_at_phase(ψ, ...)`. With T constant,
  ψ(t) = 2πt/T and both forms agree exactly; when T changes the targets stay continuous. It is the
  env's default because target jumps of up to 2·A_h rad per control step are not a gait.
"""

from typing import Any, NamedTuple

import jax.numpy as jnp
import numpy as np

TWO_PI = 2.0 * np.pi
_HIP_MASK = np.array([True, False] * 4)  # hips at even indices of the Eq. 3 order

AMPLITUDE_BOUND = 0.5  # rad: A_k, A_h ∈ [−0.5, 0.5] (§3.3)
PERIOD_MAX = 2.0  # s: T ∈ (0, 2] (§3.3)
PERIOD_MIN = 0.2  # s: the open end of (0, 2] made concrete: 10 control steps at 50 Hz per cycle.
PHASE_BOUND = TWO_PI  # rad: φ1, φ3 ∈ [−2π, 2π] (§3.3)


class RhythmParameters(NamedTuple):
    """The controller parameters a SAC action sets (§3.3): a = [A_k, A_h, T, φ1, φ3]."""

    amplitude_knee: jnp.ndarray  # (...,) rad
    amplitude_hip: jnp.ndarray  # (...,) rad
    period: jnp.ndarray  # (...,) s
    phi1: jnp.ndarray  # (...,) rad, LF and RB knee phase
    phi3: jnp.ndarray  # (...,) rad, RF and LB knee phase


def rhythm_at_phase(
    phase: jnp.ndarray,
    amplitude_hip: jnp.ndarray,
    amplitude_knee: jnp.ndarray,
    phases: jnp.ndarray,
) -> jnp.ndarray:
    """Eq. 2 for all four legs (Eq. 3) at oscillator phase ψ = 2πt/T.

    Hips: θ_h = A_h cos(ψ + φ_i). Knees: θ_k = A_k cos(ψ + φ_i) where that is ≥ 0, else 0.

    Args:
      phase: (...,) rad, the common phase ψ.
      amplitude_hip, amplitude_knee: (...,) rad.
      phases: (..., 8) rad, initial phases φ0..φ7.
    Returns:
      (..., 8) joint targets, rad.
    """
    phase = jnp.asarray(phase)[..., None]
    wave = jnp.cos(phase + phases)
    hip = jnp.asarray(amplitude_hip)[..., None] * wave
    knee = jnp.maximum(jnp.asarray(amplitude_knee)[..., None] * wave, 0.0)
    return jnp.where(_HIP_MASK, hip, knee)


def cosine_rhythm(
    t: jnp.ndarray,
    amplitude_hip: jnp.ndarray,
    amplitude_knee: jnp.ndarray,
    period: jnp.ndarray,
    phases: jnp.ndarray,
) -> jnp.ndarray:
    """Eq. 3, literally: the eight oscillators Y_i = A_i cos(2πt/T + φ_i), knees half-wave.

    Args:
      t: (...,) s. amplitude_hip, amplitude_knee: (...,) rad. period: (...,) s.
      phases: (..., 8) rad.
    Returns:
      (..., 8) joint targets, rad.
    """
    return rhythm_at_phase(TWO_PI * jnp.asarray(t) / period, amplitude_hip, amplitude_knee, phases)


def advance_phase(phase: jnp.ndarray, period: jnp.ndarray, dt: float) -> jnp.ndarray:
    """The phase-continuous form of Eq. 1: ψ ← ψ + 2π·dt/T, wrapped to [0, 2π)."""
    return jnp.mod(phase + TWO_PI * dt / period, TWO_PI)


def trot_phases(phi1: jnp.ndarray, phi3: jnp.ndarray) -> jnp.ndarray:
    """The trot of §3.3: φ0 = φ6 = 0, φ1 = φ7, φ2 = φ4 = π, φ3 = φ5.

    Args:
      phi1, phi3: (...,) rad.
    Returns:
      (..., 8) phases φ0..φ7, rad.
    """
    phi1, phi3 = jnp.broadcast_arrays(
        jnp.asarray(phi1, jnp.float32), jnp.asarray(phi3, jnp.float32)
    )
    zero = jnp.zeros_like(phi1)
    pi = jnp.full_like(phi1, jnp.pi)
    return jnp.stack([zero, phi1, pi, phi3, pi, phi3, zero, phi1], axis=-1)


# Hip phases of other gaits (LF, RF, LB, RB), as fractions of a cycle, following the paper's
# convention that legs in phase share φ and legs half a cycle apart differ by π.
_GAIT_HIP_CYCLE = {
    "trot": (0.0, 0.5, 0.5, 0.0),  # diagonal pairs (§2.2)
    "pace": (0.0, 0.5, 0.0, 0.5),  # lateral pairs
    "bound": (0.0, 0.0, 0.5, 0.5),  # front pair, then rear pair
    "walk": (0.0, 0.5, 0.75, 0.25),  # lateral-sequence walk: LF, RB, RF, LB a quarter apart
    "pronk": (0.0, 0.0, 0.0, 0.0),  # all four together
}
GAITS = tuple(_GAIT_HIP_CYCLE)


def gait_phases(gait: str, knee_lead: float = np.pi / 2) -> jnp.ndarray:
    """Phase table φ0..φ7 of a named gait; each knee leads its hip by `knee_lead` (Fig. 4: π/2).

    With knee_lead = π/2 the knee is bent exactly while its hip swings forward (the swing half).
    "trot" equals `trot_phases(π/2, 3π/2)`.

    Returns:
      (8,) rad.
    """
    if gait not in _GAIT_HIP_CYCLE:
        raise ValueError(f"unknown gait {gait!r}; known: {', '.join(GAITS)}")
    hips = TWO_PI * jnp.asarray(_GAIT_HIP_CYCLE[gait])
    knees = jnp.mod(hips + knee_lead, TWO_PI)
    return jnp.stack([hips, knees], axis=-1).reshape(8)


def parameter_bounds(period_min: float = PERIOD_MIN) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) of a = [A_k, A_h, T, φ1, φ3] (§3.3), each (5,).

    A_k, A_h ∈ [−0.5, 0.5] rad, T ∈ [period_min, 2] s (the paper's (0, 2] needs a positive floor:
    T → 0 is an infinitely fast oscillator), φ1, φ3 ∈ [−2π, 2π] rad.
    """
    lower = np.array([-AMPLITUDE_BOUND, -AMPLITUDE_BOUND, period_min, -PHASE_BOUND, -PHASE_BOUND])
    upper = np.array([AMPLITUDE_BOUND, AMPLITUDE_BOUND, PERIOD_MAX, PHASE_BOUND, PHASE_BOUND])
    return lower, upper


def _centre_and_spans(period_min: float, centre: RhythmParameters | None):
    lower, upper = parameter_bounds(period_min)
    mid = (lower + upper) / 2 if centre is None else np.asarray(centre, dtype=np.float64)
    if np.any(mid <= lower) or np.any(mid >= upper):
        raise ValueError(
            f"action centre {tuple(mid)} must lie strictly inside {tuple(lower)}..{tuple(upper)}"
        )
    return mid, upper - mid, mid - lower


def action_to_parameters(
    action: jnp.ndarray,
    period_min: float = PERIOD_MIN,
    centre: RhythmParameters | None = None,
    scale: float | np.ndarray = 1.0,
) -> RhythmParameters:
    """Map a policy action in [−1, 1]^5 onto the controller parameters' ranges (§3.3).

    Each component is piecewise linear: −1 ↦ its lower bound, 0 ↦ its centre, +1 ↦ its upper
    bound (`parameter_bounds`). With `centre=None` the centre is the middle of the range and the
    map is the plain linear one. A centre such as `FIXED_TROT` keeps every bound reachable but
    makes the zero action (where a fresh SAC policy starts) a walking trot. Actions outside
    [−1, 1] are clipped. `scale` < 1 (beyond the paper) reaches only that share of the way from
    the centre to each bound: ±1 ↦ centre + scale · span; a (5,) `scale` sets it per parameter
    (0: held at the centre, `env.held_rhythm`).

    Args:
      action: (..., 5).
    """
    return mapped_parameters(action, action_map(period_min, centre), scale)


def action_map(
    period_min: float = PERIOD_MIN, centre: RhythmParameters | None = None
) -> np.ndarray:
    """(3, 5) float32: the centre of `action_to_parameters`'s map and its spans above and below it,
    one column per parameter. As data (`mapped_parameters`) rather than constants, a compiled
    program serves every centre: a searched gait's run reuses a cached one.

    Raises:
      ValueError: a centre not strictly inside the bounds.
    """
    return np.stack(_centre_and_spans(period_min, centre)).astype(np.float32)


def mapped_parameters(
    action: jnp.ndarray, mapping: jnp.ndarray, scale: float | np.ndarray = 1.0
) -> RhythmParameters:
    """`action_to_parameters` through the map `mapping` (`action_map`: centre, span above, span
    below; (..., 3, 5) with the action's batch axes); `scale` a float or (5,) per parameter."""
    mid, above, below = mapping[..., 0, :], mapping[..., 1, :], mapping[..., 2, :]
    action = scale * jnp.clip(action, -1.0, 1.0)
    values = mid + jnp.where(action >= 0, action * above, action * below)
    return RhythmParameters(*(values[..., i] for i in range(5)))


def parameters_to_action(
    params: RhythmParameters,
    period_min: float = PERIOD_MIN,
    centre: RhythmParameters | None = None,
    scale: float | np.ndarray = 1.0,
) -> jnp.ndarray:
    """Inverse of `action_to_parameters` (for fixed-parameter baselines and tests). Returns
    (..., 5), beyond ±1 for parameters that `scale` puts out of reach."""
    return mapped_action(params, action_map(period_min, centre), scale)


def mapped_action(
    params: RhythmParameters, mapping: jnp.ndarray, scale: float | np.ndarray = 1.0
) -> jnp.ndarray:
    """`parameters_to_action` through the map `mapping` (`action_map`); 0 where `scale` (a
    float or (5,) per parameter) is 0: a parameter the action does not set."""
    mid, above, below = mapping[..., 0, :], mapping[..., 1, :], mapping[..., 2, :]
    values = jnp.stack(
        jnp.broadcast_arrays(*(jnp.asarray(p, jnp.float32) for p in params)), axis=-1
    )
    offset = values - mid
    scale = jnp.asarray(scale, jnp.float32)
    unscaled = jnp.where(offset >= 0, offset / above, offset / below)
    return jnp.where(scale > 0, unscaled / jnp.where(scale > 0, scale, 1.0), 0.0)


# Posture: an extension beyond §3.3, off by default (`env.posture_bound` = 0). The paper's rhythm
# swings every hip about zero, so the legs' mean stays perpendicular to the torso; leaning back on a
# steep descent (the feet ahead of the centre of mass) then has to come from amplitudes, period and
# phases alone (experiments/any_slope/downhill11). Two more action values shift the front hips (LF,
# RF) and the hind hips (LB, RB) by up to ± the bound.
RHYTHM_SIZE = len(RhythmParameters._fields)  # the values of §3.3's action
POSTURE_SIZE = 2
_FRONT_HIPS = np.array([1.0, 0, 1.0, 0, 0, 0, 0, 0])
_HIND_HIPS = np.array([0, 0, 0, 0, 1.0, 0, 1.0, 0])


def posture_offsets(posture: jnp.ndarray, bound: float) -> jnp.ndarray:
    """(..., 8) hip offsets (rad) that posture actions (..., 2) in [−1, 1] command: front hips by
    bound·p_front, hind hips by bound·p_hind; knees none. Actions outside [−1, 1] are clipped."""
    posture = bound * jnp.clip(posture, -1.0, 1.0)
    return posture[..., :1] * _FRONT_HIPS + posture[..., 1:2] * _HIND_HIPS


# Turning: an extension beyond §3.3, off by default (`env.turn_mode` "none"). Eq. 3 drives the
# left and right legs alike, so its gait walks straight; one more action value u ∈ [−1, 1] makes
# the rhythm asymmetric, in one of two ways (docs/env.md compares them). Both are exactly Eq. 3 at
# u = 0, and u > 0 turns left (yaw rate > 0) for a forward gait.
TURN_MODES = ("none", "hip_amplitude_difference", "abduction_stride")
TURN_SIZE = 1
_LEFT_HIPS = np.array([1.0, 0, 0, 0, 1.0, 0, 0, 0])  # LF, LB hips in the Eq. 3 order
_RIGHT_HIPS = np.array([0, 0, 1.0, 0, 0, 0, 1.0, 0])  # RF, RB hips
_STRIDE_ROTATION = np.array([1.0, 1.0, -1.0, -1.0])  # front legs one way, hind legs the other


def hip_amplitude_difference(rhythm: jnp.ndarray, turn: jnp.ndarray, bound: float) -> jnp.ndarray:
    """Eq. 3's outputs (..., 8) with left and right hip amplitudes apart: the right hips' swing
    (RF, RB) × (1 + bound·u), the left hips' (LF, LB) × (1 − bound·u), knees unchanged, for a turn
    action u (...,) in [−1, 1] (clipped): the right legs stride further and the robot turns left for
    u > 0. u = 0 multiplies every output by exactly 1: Eq. 3 unchanged."""
    turn = bound * jnp.clip(jnp.asarray(turn), -1.0, 1.0)[..., None]
    return rhythm * (1.0 + turn * (_RIGHT_HIPS - _LEFT_HIPS))


def side_scaled(rhythm: jnp.ndarray, scales: jnp.ndarray) -> jnp.ndarray:
    """Eq. 3's outputs (..., 8) with the left hips' swing (LF, LB) × scales[..., 0] and the right
    hips' (RF, RB) × scales[..., 1], knees unchanged: the command's feed-forward
    (`quadcos.env.commands.drive_scales`). Scales (1, 1) give Eq. 3 exactly."""
    left, right = scales[..., 0:1], scales[..., 1:2]
    return rhythm * (1.0 + (left - 1.0) * _LEFT_HIPS + (right - 1.0) * _RIGHT_HIPS)


def abduction_stride(rhythm: jnp.ndarray, turn: jnp.ndarray, bound: float) -> jnp.ndarray:
    """(..., 4) abduction angles (rad, LF, RF, LB, RB; positive moves the foot to the left) that
    rotate each leg's stride for a turn action u (...,) in [−1, 1] (clipped): a leg's abduction
    follows its hip's swing Y_hip (Eq. 3's output, rad), bound·u·Y_hip, the front legs' strides
    turned to the left and the hind legs' to the right for u > 0, so that their stance pushes
    yaw the body left. A constant abduction offset would shift the feet, not turn them: the
    sideways swing must follow the stride. For robots with abduction joints (12-joint); u = 0
    gives exactly 0."""
    turn = bound * jnp.clip(jnp.asarray(turn), -1.0, 1.0)[..., None]
    return turn * _STRIDE_ROTATION * rhythm[..., 0::2]


def start_ramp(time: jnp.ndarray, ramp_seconds: float) -> jnp.ndarray:
    """The share of the rhythm (Eq. 3's outputs, hip offsets included) that acts `time` s into an
    episode — an extension, not §3.3: rising linearly from 0 at the start to 1 at `ramp_seconds`,
    so that a robot steps off from standing instead of jumping to the rhythm's first targets;
    `ramp_seconds` 0 = all of it from the start (the paper)."""
    if ramp_seconds <= 0:
        return jnp.ones_like(jnp.asarray(time, jnp.float32))
    return jnp.clip(time / ramp_seconds, 0.0, 1.0)


# A fixed trot that walks on flat ground (~0.6 m/s) with the quadcos robot: the Fig. 15 baseline
# and the env's default action centre, found by a grid search over A_h, A_k, T with plain MuJoCo.
FIXED_TROT = RhythmParameters(
    amplitude_knee=0.4, amplitude_hip=0.15, period=0.6, phi1=np.pi / 2, phi3=-np.pi / 2
)


ACTION_CENTRES = {"trot": FIXED_TROT, "midpoint": None}
# An action centre that quadcos.train replaces, before it builds the env, with the gait its
# search phase finds (quadcos.gait_search): part of the run, timed with it.
SEARCH_CENTRE = "search"


def action_centre(spec: str, period_min: float) -> RhythmParameters | None:
    """The rhythm parameters the zero action commands: `ACTION_CENTRES[spec]`, or five
    comma-separated numbers A_k,A_h,T,φ1,φ3 (a gait found by search), each strictly inside its
    §3.3 range so that both halves of the action map keep a span.

    Raises:
      ValueError: naming the spec ("search" included: quadcos.train resolves it first).
    """
    if spec in ACTION_CENTRES:
        return ACTION_CENTRES[spec]
    names = f"{', '.join(ACTION_CENTRES)} or five numbers A_k,A_h,T,phi1,phi3"
    if spec == SEARCH_CENTRE:
        raise ValueError(
            "action_centre 'search' is resolved by quadcos.train (its gait search) before the env"
            f" is built; an env takes {names}"
        )
    try:
        values = [float(part) for part in str(spec).split(",")]
    except ValueError:
        values = []
    if len(values) != 5:
        raise ValueError(
            f"unknown action_centre {spec!r}; known: {names} (quadcos.train: 'search' too)"
        )
    lower, upper = parameter_bounds(period_min)
    for name, value, low, high in zip(RhythmParameters._fields, values, lower, upper):
        if not low < value < high:
            raise ValueError(
                f"action_centre {spec!r}: {name} = {value} is not strictly inside ({low:g}, {high:g})"
            )
    return RhythmParameters(*values)


def centre_spec(params: Any) -> str:
    """The action_centre string of rhythm parameters (A_k, A_h, T, φ1, φ3)."""
    return ",".join(f"{float(value):.6g}" for value in params)
