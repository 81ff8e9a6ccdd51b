"""NumPy twins of the pure JAX functions on the controller path, for one robot stepped in C MuJoCo
with no JAX in the loop (`quadcos.sim2sim`).

Each twin names its original, which stays the home of the equation; tests/test_sim2sim.py checks
every twin against it at random inputs. Float64 throughout (C MuJoCo's precision).
"""

import functools

import numpy as np

from quadcos.env import commands
from quadcos.equations import oscillator, reward, slope
from quadcos.terrain import Terrain

_HIP_MASK = np.array([True, False] * 4)
_LEFT_HIPS = np.array([1.0, 0, 0, 0, 1.0, 0, 0, 0])  # LF, LB hips in the Eq. 3 order
_RIGHT_HIPS = np.array([0, 0, 1.0, 0, 0, 0, 1.0, 0])  # RF, RB hips
_STRIDE_ROTATION = np.array([1.0, 1.0, -1.0, -1.0])  # front legs one way, hind legs the other
# The map's centre and spans, computed once per (period_min, centre) instead of every substep.
_centre_and_spans = functools.lru_cache(oscillator._centre_and_spans)  # noqa: SLF001


def action_to_parameters(
    action: np.ndarray,
    period_min: float,
    centre: oscillator.RhythmParameters | None,
    scale: float | np.ndarray = 1.0,
) -> oscillator.RhythmParameters:
    """`oscillator.action_to_parameters` (§3.3): (5,) action in [−1, 1] → rhythm parameters."""
    mid, above, below = _centre_and_spans(period_min, centre)
    action = scale * np.clip(action, -1.0, 1.0)
    values = mid + np.where(action >= 0, action * above, action * below)
    return oscillator.RhythmParameters(*(float(value) for value in values))


def trot_phases(phi1: float, phi3: float) -> np.ndarray:
    """`oscillator.trot_phases` (§3.3): (8,) phases φ0..φ7, rad."""
    return np.array([0.0, phi1, np.pi, phi3, np.pi, phi3, 0.0, phi1])


def rhythm_at_phase(
    phase: float, amplitude_hip: float, amplitude_knee: float, phases: np.ndarray
) -> np.ndarray:
    """`oscillator.rhythm_at_phase` (Eqs. 2–3): (8,) joint targets, rad, at phase ψ."""
    wave = np.cos(phase + phases)
    return np.where(_HIP_MASK, amplitude_hip * wave, np.maximum(amplitude_knee * wave, 0.0))


def posture_offsets(posture: np.ndarray, bound: float) -> np.ndarray:
    """`oscillator.posture_offsets`: (8,) hip offsets, rad, of (2,) posture actions."""
    front, hind = bound * np.clip(posture, -1.0, 1.0)
    return np.array([front, 0.0, front, 0.0, hind, 0.0, hind, 0.0])


def hip_amplitude_difference(rhythm: np.ndarray, turn: float, bound: float) -> np.ndarray:
    """`oscillator.hip_amplitude_difference`: (8,) Eq. 3 outputs, right hips × (1 + bound·u),
    left hips × (1 − bound·u), for a turn action u."""
    turn = bound * float(np.clip(turn, -1.0, 1.0))
    return rhythm * (1.0 + turn * (_RIGHT_HIPS - _LEFT_HIPS))


def side_scaled(rhythm: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """`oscillator.side_scaled`: (8,) Eq. 3 outputs, left hips × scales[0], right × scales[1]."""
    left, right = scales
    return rhythm * (1.0 + (left - 1.0) * _LEFT_HIPS + (right - 1.0) * _RIGHT_HIPS)


def drive_scales(
    velocity: np.ndarray,
    speeds: tuple[float, ...],
    half_track: float,
    scale_max: float,
    turn_max: float = 0.0,
):
    """`commands.drive_scales`: (2,) left and right hip-swing scales for a command (v*, ω*)."""
    return commands.drive_scales(
        np.asarray(velocity), speeds, half_track, scale_max, turn_max, np
    )


def abduction_stride(rhythm: np.ndarray, turn: float, bound: float) -> np.ndarray:
    """`oscillator.abduction_stride`: (4,) abduction angles, rad (LF, RF, LB, RB), following each
    hip's swing, for a turn action u."""
    turn = bound * float(np.clip(turn, -1.0, 1.0))
    return turn * _STRIDE_ROTATION * rhythm[0::2]


def start_ramp(time: float, ramp_seconds: float) -> float:
    """`oscillator.start_ramp`: the share of the rhythm acting `time` s into an episode."""
    return 1.0 if ramp_seconds <= 0 else float(np.clip(time / ramp_seconds, 0.0, 1.0))


def advance_phase(phase: float, period: float, dt: float) -> float:
    """`oscillator.advance_phase` (Eq. 1, phase form): ψ + 2π dt/T wrapped to [0, 2π)."""
    return float(np.mod(phase + oscillator.TWO_PI * dt / period, oscillator.TWO_PI))


def attitude(quaternion: np.ndarray) -> slope.Attitude:
    """`slope.attitude`: roll, nose-up pitch, yaw (rad) of a w-x-y-z quaternion."""
    w, x, y, z = quaternion
    roll = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch_about_y = np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return slope.Attitude(roll=float(roll), pitch=float(-pitch_about_y), yaw=float(yaw))


def estimate_slope(feet: np.ndarray, quaternion: np.ndarray) -> float:
    """`slope.estimate_slope` (§3.2, Eq. 5): rad, from (4, 3) torso-frame foot ends (LF, RF, LB,
    RB) and the IMU quaternion."""
    body = attitude(quaternion)
    cr, sr = np.cos(body.roll), np.sin(body.roll)
    cp, sp = np.cos(-body.pitch), np.sin(-body.pitch)
    z_r = sr * feet[:, 1] + cr * feet[:, 2]
    level_x, level_z = cp * feet[:, 0] + sp * z_r, -sp * feet[:, 0] + cp * z_r
    front = np.argmin(level_z[:2])  # lower of LF, RF: B
    rear = 2 + np.argmin(level_z[2:])  # lower of LB, RB: A
    return float(np.arctan2(level_z[front] - level_z[rear], level_x[front] - level_x[rear]))


def _cell(knots: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    i = np.clip(np.searchsorted(knots, q, side="right") - 1, 0, knots.shape[0] - 2)
    return i, np.clip((q - knots[i]) / (knots[i + 1] - knots[i]), 0.0, 1.0)


def _rows(terrain: Terrain, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if terrain.y_knots.size == 1:
        zero = np.zeros(y.shape, dtype=int)
        return zero, zero, np.zeros(y.shape)
    row, ty = _cell(terrain.y_knots, y)
    return row, row + 1, ty


def height_at(terrain: Terrain, x, y) -> np.ndarray:
    """`Terrain.height_at`: ground height (m) at (x, y), bilinear in the knots."""
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    ix, tx = _cell(terrain.x_knots, x)
    row, next_row, ty = _rows(terrain, y)
    heights = terrain.heights

    def along_x(r):
        return heights[r, ix] * (1.0 - tx) + heights[r, ix + 1] * tx

    return along_x(row) * (1.0 - ty) + along_x(next_row) * ty


def slope_at(terrain: Terrain, x, y) -> np.ndarray:
    """`Terrain.slope_at`: ground pitch along +x (rad), right-continuous, 0 off the grid."""
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    knots, heights = terrain.x_knots, terrain.heights
    ix, _ = _cell(knots, x)
    row, next_row, ty = _rows(terrain, y)

    def gradient_x(r):
        return (heights[r, ix + 1] - heights[r, ix]) / (knots[ix + 1] - knots[ix])

    gradient = gradient_x(row) * (1.0 - ty) + gradient_x(next_row) * ty
    return np.where((x >= knots[0]) & (x < knots[-1]), np.arctan(gradient), 0.0)


def wrap_angle(angle: float) -> float:
    """`reward.wrap_angle`: `angle` (rad) in [−π, π], unchanged where it already is."""
    if abs(angle) <= np.pi:
        return float(angle)
    return float(np.mod(angle + np.pi, 2 * np.pi) - np.pi)


def advance_heading(heading: float, yaw_rate: float, yaw: float, dt: float, leash: float) -> float:
    """`commands.advance_heading`: ψ* + ω*·dt (rad), moved back to within `leash` of the yaw."""
    target = wrap_angle(heading + yaw_rate * dt)
    lag = wrap_angle(target - yaw)
    if abs(lag) <= leash:
        return target
    return wrap_angle(yaw + float(np.clip(lag, -leash, leash)))


def reward_terms(
    *,
    x_now: float,
    x_last: float,
    y_now: float,
    y_last: float,
    body: slope.Attitude,
    slope_estimate: float,
    fell: bool,
    moving: bool,
    weights: reward.RewardWeights,
    variant: str,
    max_progress: float = np.inf,
    heading: float | None = None,
    commanded_progress: float | None = None,
    yaw_rate_error: float | None = None,
    tracked_progress: float | None = None,
    action_change: np.ndarray | None = None,
) -> dict[str, float]:
    """`reward.reward_terms` (Eqs. 8–13), each term weighted by α (fell) or β (alive); with a
    commanded `heading` ψ* (rad), `commanded_progress` v*·dt (m), `yaw_rate_error` (rad/s) and
    `tracked_progress` (m, the forward term's in place of the step's), the tracking terms; with
    the command's change over the step (`action_change`), its rate term."""
    alpha = float(fell)
    beta = 1.0 - alpha
    walking = beta if variant == "full" else 0.0
    progress, sideways, yaw = x_now - x_last, y_now - y_last, body.yaw
    if heading is not None:
        cos, sin = np.cos(heading), np.sin(heading)
        progress, sideways = progress * cos + sideways * sin, sideways * cos - progress * sin
        yaw = wrap_angle(yaw - heading)
    if yaw_rate_error is not None:
        yaw = yaw_rate_error
    if commanded_progress is not None and tracked_progress is not None:
        progress = tracked_progress
    progress = min(progress, max_progress)
    if commanded_progress is not None:
        progress = commanded_progress - abs(progress - commanded_progress)
    orientation = (
        -weights.pitch * abs(body.pitch - slope_estimate)
        - weights.yaw * abs(yaw)
        - weights.roll * abs(body.roll)
    )
    return {
        "fall": alpha * weights.fall_penalty,
        "survival": walking * (weights.survival if moving else 0.0),
        "forward": beta * weights.forward * progress,
        "lateral": beta * -weights.lateral * abs(sideways),
        "orientation": walking * orientation,
        "action_rate": (
            0.0
            if action_change is None
            else walking * -weights.action_rate * float(np.sum(np.square(action_change)))
        ),
    }
