"""Eq. 5, the attitude convention, and forward kinematics checked against MuJoCo itself."""

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from quadcos import robot as quadcos_robot
from quadcos.equations import kinematics, slope
from quadcos.robot import constants


def test_slope_angle_eq5_quadcos_axes():
    a = np.array([0.0, 0.3, 0.0])
    b = np.array([0.64, -0.3, 0.64 * np.tan(np.deg2rad(5))])
    np.testing.assert_allclose(np.rad2deg(slope.slope_angle(a, b)), 5.0, atol=1e-4)
    np.testing.assert_allclose(np.rad2deg(slope.slope_angle(a, b * [1, 1, -1])), -5.0, atol=1e-4)


def test_slope_angle_random_against_arctan():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(100, 3))
    b = a + np.column_stack([rng.uniform(0.1, 1, 100), rng.normal(size=100), rng.normal(size=100)])
    want = np.arctan((b[:, 2] - a[:, 2]) / (b[:, 0] - a[:, 0]))
    np.testing.assert_allclose(slope.slope_angle(a, b), want, atol=1e-5)


@pytest.mark.parametrize(
    "roll, pitch_down, yaw", [(0.1, -0.2, 0.3), (-0.3, 0.15, -1.0), (0.0, 0.0, 2.0)]
)
def test_attitude_matches_scipy_zyx(roll, pitch_down, yaw):
    x, y, z, w = Rotation.from_euler("ZYX", [yaw, pitch_down, roll]).as_quat()
    body = slope.attitude(np.array([w, x, y, z]))
    np.testing.assert_allclose(
        [body.roll, body.pitch, body.yaw], [roll, -pitch_down, yaw], atol=1e-5
    )


def test_forward_kinematics_is_the_papers_two_link_legs_and_matches_mujoco():
    """The generic chain kinematics on the paper's robot: its closed form (thigh and shank, hip
    offsets) and MuJoCo's own foot positions."""
    description = quadcos_robot.load("quadcos").description
    model = mujoco.MjModel.from_xml_path(str(constants.MJCF_PATH))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    torso = model.body(constants.TORSO_BODY).id
    for _ in range(5):
        joints = rng.uniform(-1.0, 1.0, 8)
        data.qpos[constants.QPOS_JOINTS] = joints
        mujoco.mj_kinematics(model, data)
        world = np.stack([data.site(name).xpos for name in constants.FEET])
        in_torso = (world - data.xpos[torso]) @ data.xmat[torso].reshape(3, 3)
        hip, shank = joints[0::2], joints[0::2] - joints[1::2]
        x = constants.THIGH_LENGTH * np.sin(hip) + constants.SHANK_LENGTH * np.sin(shank)
        z = -constants.THIGH_LENGTH * np.cos(hip) - constants.SHANK_LENGTH * np.cos(shank)
        closed_form = np.asarray(constants.HIP_OFFSETS) + np.stack([x, 0 * x, z], axis=-1)
        feet = kinematics.foot_positions(description.chains, joints, xp=np)
        np.testing.assert_allclose(feet, in_torso, atol=1e-9)
        np.testing.assert_allclose(feet, closed_form, atol=1e-9)
        np.testing.assert_allclose(
            kinematics.foot_positions(description.chains, joints), closed_form, atol=1e-5
        )
