"""The robot: any quadruped MJCF — the paper's (the default), the test robot `quad12`, MuJoCo
Menagerie's (`menagerie:NAME`), a path, or one registered from Python — loaded (`load`), described
(which joints are hip and knee, which way they swing, where the feet are, how high it stands:
`RobotDescription`) and compiled on a ground (`build_model`). Host-side MuJoCo only.

Modules, lowest first: `constants` (the paper's robot), `sources` (spec → MJCF file), `prepare`
(MJCF → an MjSpec MJX can run), `presets` (what the MJCF does not say), `description` (derived
from the compiled model), `loading` (`Robot`, `load`), `mjcf` (`build_model`).
"""

from quadcos.robot import constants, prepare, presets, sources
from quadcos.robot.description import Leg, RobotDescription, describe
from quadcos.robot.loading import Robot, load
from quadcos.robot.mjcf import build_model
from quadcos.robot.presets import RobotPreset
from quadcos.robot.sources import register

__all__ = [
    "Leg",
    "Robot",
    "RobotDescription",
    "RobotPreset",
    "build_model",
    "constants",
    "describe",
    "load",
    "prepare",
    "presets",
    "register",
    "sources",
]
