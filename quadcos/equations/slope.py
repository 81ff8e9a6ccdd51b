"""Proprioceptive slope estimation (paper §3.2, Eq. 5) and body attitude from the IMU.

Pure JAX, written for one robot; batch with jax.vmap. Nothing here sees MuJoCo: the estimator
gets joint angles (encoders) and the torso orientation quaternion (IMU / state estimator) only.

Axes: the paper walks along world Y; quadcos walks along MuJoCo's +x. Eq. 5's
θ = arctan((z_B − z_A)/(y_B − y_A)) is therefore written with x in place of y.
Attitude: roll about +x, pitch NOSE-UP positive (so that walking up a slope θ > 0 gives
pitch ≈ θ, the target of Eq. 12), yaw about +z; Z-Y-X Euler angles.
"""

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

_FRONT = np.array([0, 1])  # LF, RF in leg order (LF, RF, LB, RB)
_REAR = np.array([2, 3])  # LB, RB


class Attitude(NamedTuple):
    roll: jnp.ndarray  # rad
    pitch: jnp.ndarray  # rad, nose up positive
    yaw: jnp.ndarray  # rad


def attitude(quaternion: jnp.ndarray) -> Attitude:
    """Roll, nose-up pitch and yaw (rad) of a (..., 4) w-x-y-z unit quaternion."""
    w, x, y, z = (quaternion[..., i] for i in range(4))
    roll = jnp.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch_about_y = jnp.arcsin(jnp.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    yaw = jnp.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return Attitude(roll=roll, pitch=-pitch_about_y, yaw=yaw)


def slope_angle(foot_a: jnp.ndarray, foot_b: jnp.ndarray) -> jnp.ndarray:
    """Eq. 5 in quadcos axes: θ = arctan((z_B − z_A) / (x_B − x_A)), radians.

    Args:
      foot_a: (..., 3) rear foot end A. foot_b: (..., 3) front foot end B (x_B > x_A).
    Computed as arctan2 so that x_B = x_A gives ±π/2 instead of a division by zero; for
    x_B > x_A it equals the arctan of the quotient exactly.
    """
    return jnp.arctan2(foot_b[..., 2] - foot_a[..., 2], foot_b[..., 0] - foot_a[..., 0])


def level_frame(points: jnp.ndarray, body: Attitude) -> jnp.ndarray:
    """Rotate torso-frame points (..., 3) into the gravity-aligned heading frame (yaw removed)."""
    cr, sr = jnp.cos(body.roll), jnp.sin(body.roll)
    # MuJoCo's rotation about +y is nose-down positive: undo our sign flip.
    cp, sp = jnp.cos(-body.pitch), jnp.sin(-body.pitch)
    x, y, z = points[..., 0], points[..., 1], points[..., 2]
    y_r, z_r = cr * y - sr * z, sr * y + cr * z  # R_x(roll)
    x_p, z_p = cp * x + sp * z_r, -sp * x + cp * z_r  # then R_y(pitch)
    return jnp.stack([x_p, y_r, z_p], axis=-1)


def estimate_slope(feet: jnp.ndarray, quaternion: jnp.ndarray) -> jnp.ndarray:
    """The paper's proprioceptive slope estimate (§3.2), radians, positive uphill along +x.

    Foot ends (from joint angles by forward kinematics: `quadcos.equations.kinematics`), levelled
    by the IMU's roll and pitch; the lower front foot is B and the lower rear foot is A (the stance
    feet: a swing foot is lifted), and Eq. 5 gives θ.

    Args:
      feet: (4, 3) foot ends in the torso frame, m, legs LF, RF, LB, RB.
      quaternion: (4,) torso orientation, w-x-y-z.
    """
    feet = level_frame(feet, attitude(quaternion))
    front, rear = feet[_FRONT], feet[_REAR]
    foot_b = front[jnp.argmin(front[:, 2])]
    foot_a = rear[jnp.argmin(rear[:, 2])]
    return slope_angle(foot_a, foot_b)
