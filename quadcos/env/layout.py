"""Where a robot's state sits in MuJoCo's arrays, and how the rhythm and joint targets become its
controls: the env's fixed data about its robot (`quadcos.robot.RobotDescription`), as jax.numpy
arrays for the env or NumPy arrays for the robot in C MuJoCo (`quadcos.deploy.host_robot`)."""

import dataclasses
from types import ModuleType
from typing import Any

import jax.numpy as jnp
import mujoco
import numpy as np

from quadcos.equations import kinematics
from quadcos.equations.kinematics import Chains
from quadcos.robot.description import RobotDescription
from quadcos.terrain.ground import FLOOR_GEOM


@dataclasses.dataclass(frozen=True)
class Layout:
    """Index arrays into qpos / qvel / sensordata and the robot's fixed values (all (J,) arrays in
    `RobotDescription.joint_names` order; (4,) arrays in leg order LF, RF, LB, RB)."""

    xp: ModuleType  # jax.numpy or numpy: what the arrays below are
    position: Any  # (3,) qpos indices of the base position
    quaternion: Any  # (4,) qpos indices of the base orientation (w, x, y, z)
    linear_velocity: Any  # (3,) qvel indices (world frame)
    angular_velocity: Any  # (3,) qvel indices (the torso's frame, as a gyro reads it)
    orientation_sensor: Any | None  # (4,) sensordata indices of a framequat on the base
    joint_qpos: Any  # (J,)
    joint_qvel: Any  # (J,)
    home: Any  # (J,) rad
    rhythm_map: Any  # (J, 8): Eq. 3's outputs onto the joints, with each joint's sign
    # (J, 4): each leg's abduction angle (positive: foot to the left) onto its abduction joint,
    # with the joint's sign; zeros for legs without one
    abduction_map: Any
    actuator_joint: Any  # (nu,) index into the joints of each actuator's joint
    motor: bool  # torque actuators: quadcos closes the PD loop
    kp: Any  # (J,)
    kd: Any  # (J,)
    torque_limit: Any  # (J,)
    chains: Chains
    standing_height: float
    torso_centre: Any  # (3,)
    torso_half_size: Any  # (3,)
    foot_geoms: Any  # (4,) geom ids of the feet
    foot_radius: Any  # (4,) m
    mass: float  # kg, the whole robot

    @classmethod
    def of(cls, description: RobotDescription, model: mujoco.MjModel, xp=jnp) -> "Layout":
        """The layout of `description`'s robot compiled as `model`, in `xp` arrays."""
        root_qpos, root_qvel = description.root_qpos, description.root_qvel
        sensor = None
        if description.orientation_sensor is not None:
            address = model.sensor(description.orientation_sensor).adr[0]
            sensor = np.arange(address, address + 4)
        rhythm_map = np.zeros((len(description.joint_names), 8))
        for index, leg in enumerate(description.legs):
            rhythm_map[description.hip_joint[index], 2 * index] = leg.hip_sign
            rhythm_map[description.knee_joint[index], 2 * index + 1] = leg.knee_sign
        abduction_map = _abduction_map(description, model)
        real = xp.float32 if xp is jnp else xp.float64

        def array(values, dtype=real):
            return xp.asarray(np.asarray(values), dtype)

        return cls(
            xp=xp,
            position=array(np.arange(root_qpos, root_qpos + 3), xp.int32),
            quaternion=array(np.arange(root_qpos + 3, root_qpos + 7), xp.int32),
            linear_velocity=array(np.arange(root_qvel, root_qvel + 3), xp.int32),
            angular_velocity=array(np.arange(root_qvel + 3, root_qvel + 6), xp.int32),
            orientation_sensor=None if sensor is None else array(sensor, xp.int32),
            joint_qpos=array(description.joint_qpos, xp.int32),
            joint_qvel=array(description.joint_qvel, xp.int32),
            home=array(description.home),
            rhythm_map=array(rhythm_map),
            abduction_map=array(abduction_map),
            actuator_joint=array(description.actuator_joint, xp.int32),
            motor=description.actuator_kind == "motor",
            kp=array(description.gains.kp),
            kd=array(description.gains.kd),
            torque_limit=array(description.gains.torque_limit),
            chains=Chains(
                *(
                    array(field, xp.int32 if name == "joint" else real)
                    for name, field in zip(Chains._fields, description.chains)
                )
            ),
            standing_height=description.standing_height,
            torso_centre=array(description.torso_centre),
            torso_half_size=array(description.torso_half_size),
            foot_geoms=array(
                [leg.foot_geom + _geoms_before_robot(model) for leg in description.legs], xp.int32
            ),
            foot_radius=array([leg.foot_radius for leg in description.legs]),
            mass=description.mass,
        )

    def abduction_targets(self, abduction):
        """(J,) joint offsets (rad) for (4,) abduction angles per leg (LF, RF, LB, RB; positive
        moves the foot to the left, `oscillator.abduction_stride`); other joints none."""
        return (self.abduction_map * abduction).sum(-1)

    def rhythm_targets(self, rhythm):
        """(J,) joint targets, rad: the home pose moved by Eq. 3's (8,) oscillator outputs (LF hip,
        LF knee, ..., RB knee), each along its joint's forward / lift sign; abduction stays home."""
        # Elementwise, not a matrix product: exact in float32 (no TF32 on a GPU).
        return self.home + (self.rhythm_map * rhythm).sum(-1)

    def controls(self, targets, data, strength=1.0):
        """(nu,) actuator controls for (J,) joint targets: the targets for position servos, PD
        torques for motors, clipped to the torque limits × `strength` (a randomised draw's; the
        servos' limits are their model's `actuator_forcerange`)."""
        if self.motor:
            error = targets - data.qpos[self.joint_qpos]
            torque = self.kp * error - self.kd * data.qvel[self.joint_qvel]
            limit = self.torque_limit * strength
            targets = self.xp.clip(torque, -limit, limit)
        return targets[self.actuator_joint]

    def foot_positions(self, data):
        """(4, 3) foot centres in the torso frame (forward kinematics of the joint encoders)."""
        return kinematics.foot_positions(self.chains, data.qpos[self.joint_qpos], self.xp)

    def orientation(self, data):
        """(4,) the base's orientation quaternion (w, x, y, z): the IMU's where the robot has a
        framequat sensor on its base, else the base pose."""
        if self.orientation_sensor is not None:
            return data.sensordata[self.orientation_sensor]
        return data.qpos[self.quaternion]


def _geoms_before_robot(model: mujoco.MjModel) -> int:
    """Geoms that `model` has before the robot's own that its description does not count: a
    terrain's ground (a world geom, so numbered before every body's) where `model` has one. The
    description's geom ids are those of the robot compiled alone."""
    return int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, FLOOR_GEOM) >= 0)


def _abduction_map(description: RobotDescription, model: mujoco.MjModel) -> np.ndarray:
    """(J, 4): +1 / −1 where leg i's abduction joint moves its foot to the left / right with a
    larger angle (at the home pose), 0 elsewhere."""
    mapping = np.zeros((len(description.joint_names), 4))
    data = mujoco.MjData(model)
    data.qpos[np.asarray(description.joint_qpos)] = description.home
    mujoco.mj_kinematics(model, data)
    for index, leg in enumerate(description.legs):
        if leg.abduction is None:
            continue
        joint = model.joint(leg.abduction).id
        lever = data.geom_xpos[leg.foot_geom] - data.xanchor[joint]
        sideways = np.cross(data.xaxis[joint], lever)[1]
        mapping[description.joint_names.index(leg.abduction), index] = np.sign(sideways)
    return mapping


# m/s and rad/s: faster, the physics blew up though it stayed finite (MJX's finite blow-ups reach
# 1e4-1e6 m/s; no robot's joint turns at 1000 rad/s).
MAX_SPEED = 1_000.0


def blown_up(qpos: Any, qvel: Any, xp: ModuleType = jnp) -> Any:
    """Whether a robot's physics blew up: a non-finite position or a speed beyond `MAX_SPEED`
    (MJX can blow up and stay finite). `xp`: jax.numpy (MJX) or numpy (C MuJoCo)."""
    return ~(xp.isfinite(qpos).all() & (xp.abs(qvel) < MAX_SPEED).all())


def fallen(
    layout: Layout, terrain: Any, config: Any, data: Any, torso: int, body: Any, slope_truth: Any
) -> Any:
    """Whether a robot (MJX data, one robot) has fallen: its torso lower than `fall_min_height`
    above `terrain`, its roll or pitch error (against the true slope, rad) beyond the config's
    limits, or a corner of its torso box (body id `torso`) below the ground; `body` its attitude."""
    position = data.qpos[layout.position]
    clearance = position[2] - terrain.height_at(position[0], position[1])
    signs = jnp.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    box = layout.torso_centre + signs * layout.torso_half_size
    corners = data.xpos[torso] + box @ data.xmat[torso].T
    corner_clearance = corners[:, 2] - terrain.height_at(corners[:, 0], corners[:, 1])
    return (
        (clearance < config.fall_min_height)
        | (jnp.abs(body.roll) > config.fall_max_roll)
        | (jnp.abs(body.pitch - slope_truth) > config.fall_max_pitch_error)
        | (corner_clearance.min() < 0.0)
    )
