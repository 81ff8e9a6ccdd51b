"""Forward kinematics of four legs from joint angles: the foot-end coordinates that the slope
estimator (§3.2, Eq. 5) levels and compares, for any leg of hinges.

A leg is a chain of bodies from the torso to the foot, each placed in its parent by a fixed offset
and rotation and turned by at most one hinge, as MuJoCo composes them (`mj_kinematics`): the
hinge turns its body about `axis` through `anchor` (both in the body's frame) by q − q0. The
chains come from `quadcos.robot.description`; the functions here take arrays only and work with
jax.numpy (the env) or NumPy (the C-MuJoCo twin), picked by `xp`.
"""

from typing import Any, NamedTuple

import jax.numpy as jnp


class Chains(NamedTuple):
    """Four legs' body chains, padded to one length L with fixed identity links.

    offset: (4, L, 3) m, each link's position in its parent's frame.
    rotation: (4, L, 3, 3), each link's orientation in its parent's frame.
    axis: (4, L, 3) unit hinge axis in the link's frame (zero: no hinge).
    anchor: (4, L, 3) m, the hinge's point in the link's frame.
    joint: (4, L) int, the hinge's index into the joint-angle vector (0 where there is none).
    reference: (4, L) rad, the angle q0 at which the link sits at `offset` / `rotation`.
    foot: (4, 3) m, the foot's centre in the last link's frame.
    """

    offset: Any
    rotation: Any
    axis: Any
    anchor: Any
    joint: Any
    reference: Any
    foot: Any


def axis_rotation(axis, angle, xp=jnp):
    """(..., 3, 3) rotation by `angle` (...) rad about unit `axis` (..., 3) (Rodrigues)."""
    x, y, z = axis[..., 0], axis[..., 1], axis[..., 2]
    zero = xp.zeros_like(x)
    cross = xp.stack(
        [xp.stack([zero, -z, y], -1), xp.stack([z, zero, -x], -1), xp.stack([-y, x, zero], -1)], -2
    )
    outer = axis[..., :, None] * axis[..., None, :]
    cos, sin = xp.cos(angle)[..., None, None], xp.sin(angle)[..., None, None]
    return cos * xp.eye(3) + sin * cross + (1.0 - cos) * outer


def foot_positions(chains: Chains, joint_angles, xp=jnp):
    """(4, 3) foot centres (m) in the torso frame, legs in LF, RF, LB, RB order.

    Args:
      chains: the legs (see `Chains`).
      joint_angles: (J,) rad, the robot's leg joints in `RobotDescription.joint_names` order.
    """
    angles = xp.asarray(joint_angles)[chains.joint] - chains.reference  # (4, L)
    has_hinge = xp.linalg.norm(chains.axis, axis=-1) > 0
    angles = xp.where(has_hinge, angles, 0.0)
    position = xp.zeros((4, 3))
    frame = xp.broadcast_to(xp.eye(3), (4, 3, 3))
    for link in range(chains.offset.shape[1]):
        position = position + _apply(frame, chains.offset[:, link])
        frame = _compose(frame, chains.rotation[:, link])
        anchor = position + _apply(frame, chains.anchor[:, link])
        frame = _compose(frame, axis_rotation(chains.axis[:, link], angles[:, link], xp))
        position = anchor - _apply(frame, chains.anchor[:, link])
    return position + _apply(frame, chains.foot)


# Products written elementwise rather than as matrix products: exact float32 on a GPU, where XLA
# would run a matrix product in TF32.
def _apply(frame, vector):
    """(4, 3) = (4, 3, 3) frames applied to (4, 3) vectors."""
    return (frame * vector[:, None, :]).sum(-1)


def _compose(frame, rotation):
    """(4, 3, 3) = (4, 3, 3) frames times (4, 3, 3) rotations."""
    return (frame[:, :, :, None] * rotation[:, None, :, :]).sum(-2)
