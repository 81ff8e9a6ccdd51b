"""The robot: its named parts and sizes (`constants`) and its MJCF, loaded and compiled on a ground
(`load_spec`, `build_model`). Host-side MuJoCo only."""

from quadcos.robot import constants
from quadcos.robot.mjcf import build_model, load_spec

__all__ = ["build_model", "constants", "load_spec"]
