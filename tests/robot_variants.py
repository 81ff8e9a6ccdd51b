"""Variants of the test quadruped quad12 (models/mjcf/quad12.xml) for the robot tests: each
function edits quad12's MjSpec, writes it as `DIR/quad12_<variant>.xml` and returns that path.

Robots quadcos should drive: `knees_inward` (hind knees bent forwards, ANYmal C's X stance),
`motors_without_gains` (torque motors, as Go2), `no_keyframe` (no standing pose in the file).
Robots it should refuse with a clear error: `no_freejoint`, `three_legs`, `five_legs`,
`one_joint_leg`. Variants with a freejoint keep a keyframe "home" that stands (where position
servos hold it; tests/test_robot_sources.py checks).
"""

import pathlib

import mujoco
import numpy as np

from quadcos.robot import constants

QUAD12 = constants.MJCF_DIR / "quad12.xml"
LEGS = ("FR", "FL", "RR", "RL")
HIND_LEGS = ("RR", "RL")
HOME_HEIGHT = 0.27  # m: the trunk in quad12's keyframe "home"
HOME_ANGLES = {"hip": 0.0, "thigh": 0.9, "calf": -1.8}  # rad, per joint kind
HIND_HIP_SHIFT = 0.03  # m: knees_inward's hind hips, further back than quad12's


def knees_inward(directory: pathlib.Path) -> pathlib.Path:
    """quad12 with the hind knees bent forwards, so that all knees point inward (ANYmal C's "X").

    Hind thigh and calf ranges are mirrored (thigh -4.501..0.686, calf 0.888..2.818) and their home
    angles negated (thigh -0.9, calf +1.8): the hind feet stay under the hips. The hind hips move
    HIND_HIP_SHIFT further back, or the thighs of a side would touch at the knees.
    """
    spec = _quad12()
    for leg in HIND_LEGS:
        spec.body(f"{leg}_hip").pos[0] -= HIND_HIP_SHIFT
        for kind in ("thigh", "calf"):
            joint = spec.joint(f"{leg}_{kind}_joint")
            joint.range = [-joint.range[1], -joint.range[0]]
            spec.actuator(f"{leg}_{kind}").ctrlrange = joint.range
    angles = {
        f"{leg}_{kind}_joint": -HOME_ANGLES[kind] for leg in HIND_LEGS for kind in ("thigh", "calf")
    }
    _set_home(spec, angles)
    return _write(spec, directory, "knees_inward")


def motors_without_gains(directory: pathlib.Path) -> pathlib.Path:
    """quad12 with torque motors instead of position servos: ctrl is N m, ctrlrange = the servo's
    forcerange, no kp; the keyframe's ctrl is 0."""
    spec = _quad12()
    for actuator in spec.actuators:
        torque_range = list(actuator.forcerange)
        actuator.set_to_motor()
        actuator.ctrlrange = torque_range
        actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE
    _set_home(spec)
    return _write(spec, directory, "motors_without_gains")


def no_keyframe(directory: pathlib.Path) -> pathlib.Path:
    """quad12 without its keyframe: the only pose in the file is qpos0 (straight legs)."""
    spec = _quad12()
    return _write(spec, directory, "no_keyframe")


def no_freejoint(directory: pathlib.Path) -> pathlib.Path:
    """quad12 with its trunk fixed to the world (no freejoint): not a free-floating robot."""
    spec = _quad12()
    spec.delete(next(j for j in spec.joints if j.type == mujoco.mjtJoint.mjJNT_FREE))
    _set_home(spec)
    return _write(spec, directory, "no_freejoint")


def three_legs(directory: pathlib.Path) -> pathlib.Path:
    """quad12 without its left hind leg (RL) and that leg's actuators."""
    spec = _quad12()
    _delete_actuators(spec, [f"RL_{kind}_joint" for kind in HOME_ANGLES])
    spec.delete(spec.body("RL_hip"))
    _set_home(spec)
    return _write(spec, directory, "three_legs")


def five_legs(directory: pathlib.Path) -> pathlib.Path:
    """quad12 with a fifth leg "MR" (a right leg at mid-trunk), built like the others."""
    spec = _quad12()
    hip = spec.body("trunk").add_body(name="MR_hip", pos=[0.0, -0.04675, 0.0])
    hip.add_joint(spec.find_default("abduction"), name="MR_hip_joint")
    hip.add_geom(spec.find_default("hip_housing"), pos=[0.0, -0.035, 0.0])
    thigh = hip.add_body(name="MR_thigh", pos=[0.0, -0.08, 0.0])
    thigh.add_joint(spec.find_default("hip"), name="MR_thigh_joint")
    thigh.add_geom(spec.find_default("thigh"))
    calf = thigh.add_body(name="MR_calf", pos=[0.0, 0.0, -0.213])
    calf.add_joint(spec.find_default("knee"), name="MR_calf_joint")
    calf.add_geom(spec.find_default("calf"))
    calf.add_geom(spec.find_default("foot"), name="MR")
    for kind, default in (("hip", "abduction"), ("thigh", "hip"), ("calf", "knee")):
        spec.add_actuator(
            spec.find_default(default),
            name=f"MR_{kind}",
            target=f"MR_{kind}_joint",
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
        )
    _set_home(spec)
    return _write(spec, directory, "five_legs")


def one_joint_leg(directory: pathlib.Path) -> pathlib.Path:
    """quad12 whose left hind leg (RL) keeps only its knee: no abduction or hip joint there."""
    spec = _quad12()
    removed = ["RL_hip_joint", "RL_thigh_joint"]
    _delete_actuators(spec, removed)
    for name in removed:
        spec.delete(spec.joint(name))
    _set_home(spec)
    return _write(spec, directory, "one_joint_leg")


def _quad12() -> mujoco.MjSpec:
    """quad12's spec without its keyframe (`_set_home` adds one that fits the variant: MuJoCo
    checks a keyframe's sizes on every edit)."""
    spec = mujoco.MjSpec.from_file(str(QUAD12))
    for key in list(spec.keys):
        spec.delete(key)
    return spec


def _delete_actuators(spec: mujoco.MjSpec, joints: list[str]) -> None:
    for actuator in [a for a in spec.actuators if a.target in joints]:
        spec.delete(actuator)


def _set_home(spec: mujoco.MjSpec, angles: dict[str, float] | None = None) -> None:
    """Add the keyframe "home": the trunk at HOME_HEIGHT, every hinge at its kind's
    HOME_ANGLES value unless `angles` names it, position servos aimed there, other ctrl 0."""
    model = spec.compile()
    qpos = model.qpos0.copy()
    targets = {}
    for joint in range(model.njnt):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, joint) or ""
        address = model.jnt_qposadr[joint]
        if model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_FREE:
            qpos[address : address + 7] = [0.0, 0.0, HOME_HEIGHT, 1.0, 0.0, 0.0, 0.0]
            continue
        kind = name.removesuffix("_joint").split("_")[-1]
        targets[joint] = qpos[address] = (angles or {}).get(name, HOME_ANGLES.get(kind, 0.0))
    ctrl = np.zeros(model.nu)
    for actuator in range(model.nu):
        is_servo = model.actuator_biastype[actuator] == mujoco.mjtBias.mjBIAS_AFFINE
        if is_servo:
            ctrl[actuator] = targets.get(model.actuator_trnid[actuator, 0], 0.0)
    spec.add_key(name="home", qpos=qpos.tolist(), ctrl=ctrl.tolist())


def _write(spec: mujoco.MjSpec, directory: pathlib.Path, variant: str) -> pathlib.Path:
    path = pathlib.Path(directory) / f"quad12_{variant}.xml"
    path.write_text(spec.to_xml())
    return path
