"""A quadruped as quadcos drives it, derived from its compiled MJCF: the base (the freejoint's
body), four legs labelled LF / RF / LB / RB by where their hips sit, each leg's joints by role
(abduction, hip pitch, knee), its foot (the chain's last sphere), the signs that turn the paper's
rhythm into joint motion, lengths, the standing height, a torso box for the fall check, the mass
and the actuators.

Signs come from the legs' kinematics at the home pose: `hip_sign` is +1 where a larger hip angle
moves the foot forward; `knee_sign` is +1 where a larger knee angle lifts the foot (on a straight
knee, where the lift is second order, the direction that folds the shank backwards, as the paper's
robot does). The paper's robot has joint zero = standing and every sign +1, so its rhythm is Eq. 3
unchanged.
"""

import dataclasses
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from quadcos.equations.kinematics import Chains

LEG_LABELS = ("LF", "RF", "LB", "RB")  # the paper's leg order (Eq. 3)
_FINITE_STEP = 0.05  # rad: the probe of each joint's effect on its foot
_LIFT_SLOPE = 0.02  # m/rad: below it a knee's lift is second order (a straight knee)
_ALIGNED = 0.7  # |cos| above which an axis counts as along x (abduction) or y (pitch)


@dataclasses.dataclass(frozen=True)
class Leg:
    """One leg: joint names by role (abduction None on a 2-joint leg), foot, signs, lengths."""

    label: str
    abduction: str | None
    hip: str
    knee: str
    foot_geom: int
    foot_radius: float  # m
    hip_sign: float  # +1: a larger hip angle swings the foot forward
    knee_sign: float  # +1: a larger knee angle lifts the foot
    hip_position: tuple[float, float, float]  # m, in the base frame
    thigh_length: float  # m, hip axis to knee axis
    shank_length: float  # m, knee axis to the foot's centre

    @property
    def joints(self) -> tuple[str, ...]:
        return tuple(name for name in (self.abduction, self.hip, self.knee) if name is not None)


@dataclasses.dataclass(frozen=True)
class Gains:
    """PD gains and torque limits per leg joint (`RobotDescription.joint_names` order)."""

    kp: tuple[float, ...]  # N m / rad
    kd: tuple[float, ...]  # N m s / rad
    torque_limit: tuple[float, ...]  # N m


@dataclasses.dataclass(frozen=True)
class RobotDescription:
    """What the env needs of a robot; every array in leg order (LF, RF, LB, RB), each leg's
    joints as (abduction,) hip, knee."""

    name: str
    root_body: str
    legs: tuple[Leg, ...]
    joint_names: tuple[str, ...]
    joint_qpos: tuple[int, ...]  # qpos address of each joint
    joint_qvel: tuple[int, ...]
    joint_ranges: tuple[tuple[float, float], ...]  # rad
    home: tuple[float, ...]  # rad: the standing pose
    hip_joint: tuple[int, ...]  # (4,) index into joint_names of each leg's hip
    knee_joint: tuple[int, ...]  # (4,)
    actuator_joint: tuple[int, ...]  # per actuator (model order): index into joint_names
    actuator_kind: str  # "position" or "motor" (torque: quadcos closes the PD loop)
    gains: Gains
    standing_height: float  # m: base origin above flat ground at the home pose
    torso_centre: tuple[float, float, float]  # m: the torso box's centre in the base frame
    torso_half_size: tuple[float, float, float]  # m
    mass: float  # kg
    orientation_sensor: str | None  # a framequat sensor on the base, else the base's pose is read
    chains: Chains  # NumPy arrays: the legs' forward kinematics
    root_qpos: int
    root_qvel: int

    def summary(self) -> dict:
        """The description as JSON-ready values (`python -m quadcos.robot describe`)."""
        return {
            "name": self.name,
            "root_body": self.root_body,
            "legs": [
                {
                    "label": leg.label,
                    "joints": {"abduction": leg.abduction, "hip": leg.hip, "knee": leg.knee},
                    "foot_geom": leg.foot_geom,
                    "foot_radius_m": round(leg.foot_radius, 4),
                    "hip_sign": leg.hip_sign,
                    "knee_sign": leg.knee_sign,
                    "hip_position_m": [round(v, 4) for v in leg.hip_position],
                    "thigh_length_m": round(leg.thigh_length, 4),
                    "shank_length_m": round(leg.shank_length, 4),
                }
                for leg in self.legs
            ],
            "home_rad": dict(zip(self.joint_names, (round(v, 4) for v in self.home))),
            "joint_ranges_rad": {
                name: [round(lo, 4), round(hi, 4)]
                for name, (lo, hi) in zip(self.joint_names, self.joint_ranges)
            },
            "standing_height_m": round(self.standing_height, 4),
            "torso_box_m": {
                "centre": [round(v, 4) for v in self.torso_centre],
                "half_size": [round(v, 4) for v in self.torso_half_size],
            },
            "mass_kg": round(self.mass, 3),
            "actuator_kind": self.actuator_kind,
            "gains": {
                name: {"kp": kp, "kd": kd, "torque_limit": limit}
                for name, kp, kd, limit in zip(
                    self.joint_names, self.gains.kp, self.gains.kd, self.gains.torque_limit
                )
            },
            "orientation": self.orientation_sensor or "base pose (no framequat sensor)",
        }


def describe(
    model: mujoco.MjModel,
    *,
    name: str,
    home: Sequence[float] | Mapping[str, float] | str | None = None,
    kp: float | Mapping[str, float] | None = None,
    kd: float | Mapping[str, float] | None = None,
) -> RobotDescription:
    """Derive the description of the quadruped in `model`.

    Args:
      model: the compiled robot (on no ground, or any: the ground is no part of a leg).
      name: for messages.
      home: the standing pose: a keyframe name, joint values by name, or values in the order the
        joints appear in qpos; None: the keyframe "home" if there is one, else joint zero.
      kp, kd: PD gains for motor actuators (one value or per joint name); position actuators keep
        their own.

    Raises:
      ValueError: no freejoint, not four legs, a leg of one joint, a home pose outside the joint
        ranges, motor actuators without gains — in one line naming the robot.
    """
    root_joint = _one_freejoint(model, name)
    if model.jnt_qposadr[root_joint] != 0:
        raise ValueError(f"robot {name}: the base's freejoint must be the MJCF's first joint")
    root = int(model.jnt_bodyid[root_joint])
    legs_bodies = _leg_chains(model, root, name)
    qpos = _home_qpos(model, home, name)
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    data.qpos[model.jnt_qposadr[root_joint] : model.jnt_qposadr[root_joint] + 7] = [
        0,
        0,
        0,
        1,
        0,
        0,
        0,
    ]
    mujoco.mj_kinematics(model, data)

    legs, joint_ids = [], []
    for label, (bodies, foot) in _label_legs(model, data, legs_bodies, name).items():
        leg, ids = _describe_leg(model, data, label, bodies, foot, name)
        legs.append(leg)
        joint_ids += ids
    joint_names = tuple(model.joint(j).name or f"joint{j}" for j in joint_ids)
    ranges = tuple(
        (float(lo), float(hi)) if model.jnt_limited[j] else (-np.inf, np.inf)
        for j, (lo, hi) in zip(joint_ids, model.jnt_range[joint_ids])
    )
    home_values = tuple(float(qpos[model.jnt_qposadr[j]]) for j in joint_ids)
    for joint, value, (lo, hi) in zip(joint_names, home_values, ranges):
        if not lo - 1e-6 <= value <= hi + 1e-6:
            raise ValueError(
                f"robot {name}: home pose {joint} = {value:.3f} rad is outside its range"
                f" [{lo:.3f}, {hi:.3f}]: give a home pose (a keyframe or joint values)"
            )
    kind, actuator_joint, gains = _actuators(model, joint_ids, joint_names, kp, kd, name)
    feet_z = [data.geom_xpos[leg.foot_geom][2] - leg.foot_radius for leg in legs]
    centre, half = _torso_box(model, root, name)
    sensor = _orientation_sensor(model, root)
    per_leg = [len(leg.joints) for leg in legs]
    offsets = np.cumsum([0, *per_leg[:-1]])
    return RobotDescription(
        name=name,
        root_body=model.body(root).name,
        legs=tuple(legs),
        joint_names=joint_names,
        joint_qpos=tuple(int(model.jnt_qposadr[j]) for j in joint_ids),
        joint_qvel=tuple(int(model.jnt_dofadr[j]) for j in joint_ids),
        joint_ranges=ranges,
        home=home_values,
        hip_joint=tuple(int(o + n - 2) for o, n in zip(offsets, per_leg)),
        knee_joint=tuple(int(o + n - 1) for o, n in zip(offsets, per_leg)),
        actuator_joint=actuator_joint,
        actuator_kind=kind,
        gains=gains,
        standing_height=float(-min(feet_z)),
        torso_centre=centre,
        torso_half_size=half,
        mass=float(model.body_mass.sum()),
        orientation_sensor=sensor,
        chains=_chains(model, legs_bodies, _label_legs(model, data, legs_bodies, name), joint_ids),
        root_qpos=int(model.jnt_qposadr[root_joint]),
        root_qvel=int(model.jnt_dofadr[root_joint]),
    )


def _one_freejoint(model: mujoco.MjModel, name: str) -> int:
    free = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
    if len(free) != 1:
        raise ValueError(
            f"robot {name}: {'no freejoint' if not free else f'{len(free)} freejoints'}; a"
            " quadruped's base must be one free body (<freejoint/>)"
        )
    return free[0]


def _subtree(model: mujoco.MjModel, top: int) -> list[int]:
    bodies = [top]
    for body in range(top + 1, model.nbody):
        if model.body_parentid[body] in bodies:
            bodies.append(body)
    return bodies


def _depth(model: mujoco.MjModel, body: int) -> int:
    depth = 0
    while body != 0:
        body, depth = int(model.body_parentid[body]), depth + 1
    return depth


def _leg_chains(model: mujoco.MjModel, root: int, name: str) -> list[tuple[list[int], int]]:
    """(bodies from the base's child to the foot's body, foot geom) of each chain from the base
    that ends in a sphere."""
    chains = []
    for child in (b for b in range(model.nbody) if model.body_parentid[b] == root and b != root):
        spheres = [
            g
            for g in range(model.ngeom)
            if model.geom_bodyid[g] in _subtree(model, child)
            and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE
        ]
        if not spheres:
            continue
        deepest = max(_depth(model, model.geom_bodyid[g]) for g in spheres)
        last = [g for g in spheres if _depth(model, model.geom_bodyid[g]) == deepest]
        foot = max(last, key=lambda g: np.linalg.norm(model.geom_pos[g]))
        bodies, body = [], int(model.geom_bodyid[foot])
        while body != root:
            bodies.insert(0, body)
            body = int(model.body_parentid[body])
        chains.append((bodies, foot))
    if len(chains) != 4:
        found = ", ".join(model.body(bodies[0]).name or str(bodies[0]) for bodies, _ in chains)
        raise ValueError(
            f"robot {name}: {len(chains)} legs (chains from the base ending in a sphere foot:"
            f" {found or 'none'}); a quadruped has 4"
        )
    return chains


def _home_qpos(model: mujoco.MjModel, home, name: str) -> np.ndarray:
    qpos = model.qpos0.copy()
    if home is None:
        key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
        return model.key_qpos[key].copy() if key >= 0 else qpos
    if isinstance(home, str):
        key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, home)
        if key < 0:
            raise ValueError(f"robot {name}: no keyframe named {home!r} for the home pose")
        return model.key_qpos[key].copy()
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    if isinstance(home, Mapping):
        for joint, value in home.items():
            index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
            if index < 0:
                raise ValueError(f"robot {name}: home pose names an unknown joint {joint!r}")
            qpos[model.jnt_qposadr[index]] = value
        return qpos
    if len(home) != len(hinges):
        raise ValueError(
            f"robot {name}: home pose has {len(home)} values for {len(hinges)} hinge joints"
        )
    for joint, value in zip(hinges, home):
        qpos[model.jnt_qposadr[joint]] = value
    return qpos


def _label_legs(model, data, chains, name: str) -> dict[str, tuple[list[int], int]]:
    labelled = {}
    for bodies, foot in chains:
        x, y, _ = data.xpos[bodies[0]]
        label = ("L" if y > 0 else "R") + ("F" if x > 0 else "B")
        if label in labelled:
            raise ValueError(f"robot {name}: two legs' hips sit at the {label} corner of the base")
        labelled[label] = (bodies, foot)
    return {label: labelled[label] for label in LEG_LABELS}


def _hinges(model: mujoco.MjModel, bodies: list[int], label: str, name: str) -> list[int]:
    joints = []
    for body in bodies:
        for joint in range(
            model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body]
        ):
            if model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_HINGE:
                raise ValueError(f"robot {name}: leg {label} has a joint that is not a hinge")
            joints.append(joint)
    if len(joints) not in (2, 3):
        raise ValueError(
            f"robot {name}: leg {label} has {len(joints)} joint(s); a leg needs a hip and a knee"
            " (2 hinges) and may have an abduction (3)"
        )
    return joints


def _foot_after(model, data, foot: int, joint: int, step: float) -> np.ndarray:
    probe = mujoco.MjData(model)
    probe.qpos[:] = data.qpos
    probe.qpos[model.jnt_qposadr[joint]] += step
    mujoco.mj_kinematics(model, probe)
    return probe.geom_xpos[foot].copy()


def _describe_leg(model, data, label, bodies, foot, name) -> tuple[Leg, list[int]]:
    joints = _hinges(model, bodies, label, name)
    axes = [data.xaxis[j] for j in joints]
    abduction = None
    if len(joints) == 3:
        along_x = [abs(axis[0]) for axis in axes]
        abduction = joints[int(np.argmax(along_x))]
        if max(along_x) < _ALIGNED:
            raise ValueError(f"robot {name}: leg {label} has 3 hinges but none turns about x")
    hip, knee = [j for j in joints if j != abduction]
    effect = {
        j: (
            _foot_after(model, data, foot, j, _FINITE_STEP)
            - _foot_after(model, data, foot, j, -_FINITE_STEP)
        )
        / (2 * _FINITE_STEP)
        for j in (hip, knee)
    }
    hip_sign = 1.0 if effect[hip][0] > 0 else -1.0
    lift = effect[knee][2]
    knee_sign = (
        (1.0 if lift > 0 else -1.0)
        if abs(lift) > _LIFT_SLOPE
        else (-1.0 if effect[knee][0] > 0 else 1.0)
    )
    hip_anchor, knee_anchor = data.xanchor[hip], data.xanchor[knee]
    ordered = [j for j in (abduction, hip, knee) if j is not None]
    leg = Leg(
        label=label,
        abduction=None if abduction is None else model.joint(abduction).name,
        hip=model.joint(hip).name,
        knee=model.joint(knee).name,
        foot_geom=int(foot),
        foot_radius=float(model.geom_size[foot][0]),
        hip_sign=hip_sign,
        knee_sign=knee_sign,
        hip_position=tuple(float(v) for v in data.xpos[bodies[0]]),
        thigh_length=float(np.linalg.norm(knee_anchor - hip_anchor)),
        shank_length=float(np.linalg.norm(data.geom_xpos[foot] - knee_anchor)),
    )
    return leg, ordered


def _actuators(model, joint_ids, joint_names, kp, kd, name):
    actuator_joint, kinds = [], set()
    for actuator in range(model.nu):
        if model.actuator_trntype[actuator] != mujoco.mjtTrn.mjTRN_JOINT:
            raise ValueError(f"robot {name}: actuator {actuator} does not drive a joint")
        joint = int(model.actuator_trnid[actuator][0])
        if joint not in joint_ids:
            raise ValueError(f"robot {name}: actuator {actuator} drives a joint outside the legs")
        actuator_joint.append(joint_ids.index(joint))
        affine = model.actuator_biastype[actuator] == mujoco.mjtBias.mjBIAS_AFFINE
        kinds.add("position" if affine and model.actuator_biasprm[actuator][1] < 0 else "motor")
    missing = [joint_names[i] for i in range(len(joint_ids)) if i not in actuator_joint]
    if missing or len(kinds) != 1:
        problem = f"no actuator for {', '.join(missing)}" if missing else "mixed actuator kinds"
        raise ValueError(f"robot {name}: {problem}; every leg joint needs one actuator of one kind")
    (kind,) = kinds
    by_joint = {j: a for a, j in enumerate(actuator_joint)}
    limits = []
    for index in range(len(joint_ids)):
        actuator = by_joint[index]
        bounds = (
            model.actuator_forcerange[actuator]
            if model.actuator_forcelimited[actuator]
            else (model.actuator_ctrlrange[actuator] if kind == "motor" else (-np.inf, np.inf))
        )
        limits.append(float(max(abs(bounds[0]), abs(bounds[1]))))
    if kind == "position":
        kps = [float(model.actuator_gainprm[by_joint[i]][0]) for i in range(len(joint_ids))]
        kds = [
            max(0.0, -float(model.actuator_biasprm[by_joint[i]][2])) for i in range(len(joint_ids))
        ]
    else:
        if kp is None or kd is None:
            raise ValueError(
                f"robot {name}: motor (torque) actuators without gains: give kp and kd (the PD"
                " loop quadcos closes), e.g. in a robot preset"
            )
        kps = [_per_joint(kp, joint, name, "kp") for joint in joint_names]
        kds = [_per_joint(kd, joint, name, "kd") for joint in joint_names]
    return kind, tuple(actuator_joint), Gains(tuple(kps), tuple(kds), tuple(limits))


def _per_joint(value, joint: str, name: str, what: str) -> float:
    if isinstance(value, Mapping):
        if joint not in value:
            raise ValueError(f"robot {name}: no {what} for joint {joint}")
        return float(value[joint])
    return float(value)


def _torso_box(model: mujoco.MjModel, root: int, name: str):
    """The base's geoms' bounding box in the base frame: (centre, half size)."""
    corners = []
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    for geom in (g for g in range(model.ngeom) if model.geom_bodyid[g] == root):
        centre, half = model.geom_aabb[geom][:3], model.geom_aabb[geom][3:]
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, model.geom_quat[geom])
        local = centre + signs * half
        corners.append(model.geom_pos[geom] + local @ rotation.reshape(3, 3).T)
    if not corners:
        raise ValueError(f"robot {name}: the base has no geometry for the fall check")
    points = np.concatenate(corners)
    low, high = points.min(0), points.max(0)
    return tuple(float(v) for v in (low + high) / 2), tuple(float(v) for v in (high - low) / 2)


def _orientation_sensor(model: mujoco.MjModel, root: int) -> str | None:
    for sensor in range(model.nsensor):
        if (
            model.sensor_type[sensor] == mujoco.mjtSensor.mjSENS_FRAMEQUAT
            and model.sensor_objtype[sensor] == mujoco.mjtObj.mjOBJ_SITE
            and model.site_bodyid[model.sensor_objid[sensor]] == root
        ):
            return model.sensor(sensor).name
    return None


def _chains(model, chains, labelled, joint_ids) -> Chains:
    """The legs' kinematic chains as arrays (see `quadcos.equations.kinematics.Chains`)."""
    length = max(len(bodies) for bodies, _ in labelled.values())
    arrays = {field: [] for field in Chains._fields}
    for bodies, foot in labelled.values():
        links = {
            field: [] for field in ("offset", "rotation", "axis", "anchor", "joint", "reference")
        }
        for index in range(length):
            if index < len(bodies):
                body = bodies[index]
                rotation = np.zeros(9)
                mujoco.mju_quat2Mat(rotation, model.body_quat[body])
                joint = model.body_jntadr[body] if model.body_jntnum[body] else -1
                links["offset"].append(model.body_pos[body])
                links["rotation"].append(rotation.reshape(3, 3))
            else:
                joint = -1
                links["offset"].append(np.zeros(3))
                links["rotation"].append(np.eye(3))
            links["axis"].append(model.jnt_axis[joint] if joint >= 0 else np.zeros(3))
            links["anchor"].append(model.jnt_pos[joint] if joint >= 0 else np.zeros(3))
            links["joint"].append(joint_ids.index(joint) if joint >= 0 else 0)
            links["reference"].append(model.qpos0[model.jnt_qposadr[joint]] if joint >= 0 else 0.0)
        for field, values in links.items():
            arrays[field].append(np.array(values))
        arrays["foot"].append(model.geom_pos[foot].copy())
    return Chains(**{field: np.array(values) for field, values in arrays.items()})
