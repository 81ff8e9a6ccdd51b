"""Named constants of the quadcos robot (models/mjcf/quadruped.xml): one place for names and sizes."""

import pathlib

_PACKAGE = pathlib.Path(__file__).resolve().parent.parent
# The robot files live in the repository's models/mjcf/; a wheel carries them as quadcos/models/mjcf/
# (pyproject.toml maps the folder into the package).
MJCF_DIR = next(
    (d for d in (_PACKAGE / "models" / "mjcf", _PACKAGE.parent / "models" / "mjcf") if d.is_dir()),
    _PACKAGE.parent / "models" / "mjcf",
)
MJCF_PATH = MJCF_DIR / "quadruped.xml"

LEGS = ("LF", "RF", "LB", "RB")
# Paper Eq. 3 order: LF hip, LF knee, RF hip, RF knee, LB hip, LB knee, RB hip, RB knee.
JOINTS = tuple(f"{leg}_{joint}" for leg in LEGS for joint in ("hip", "knee"))
FEET = tuple(f"{leg}_foot" for leg in LEGS)
TORSO_BODY = "torso"
TORSO_GEOM = "torso"
IMU_ORIENTATION_SENSOR = "imu_orientation"

# Leg geometry (must match the MJCF; tests compare forward kinematics against MuJoCo).
HIP_OFFSETS = (  # hip position in the torso frame, metres, per leg in LEGS order
    (0.32, 0.315, 0.0),
    (0.32, -0.315, 0.0),
    (-0.32, 0.315, 0.0),
    (-0.32, -0.315, 0.0),
)
THIGH_LENGTH = 0.32
SHANK_LENGTH = 0.32
FOOT_RADIUS = 0.03
STANDING_HEIGHT = THIGH_LENGTH + SHANK_LENGTH + FOOT_RADIUS  # torso centre above flat ground

# qpos layout: the free-floating base (position, quaternion) followed by the 8 joints.
QPOS_QUATERNION = slice(3, 7)
QPOS_JOINTS = slice(7, 15)
