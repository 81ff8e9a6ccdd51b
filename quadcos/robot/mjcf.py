"""The quadruped's MJCF (models/mjcf/quadruped.xml) on a terrain: host-side MuJoCo only."""

import pathlib
from typing import Protocol

import mujoco

from quadcos.robot import constants


class Ground(Protocol):
    """What `build_model` needs of a terrain (`quadcos.terrain.Terrain` is one)."""

    name: str

    def attach(self, spec: mujoco.MjSpec) -> None: ...


def load_spec(mjcf_path: str | pathlib.Path | None = None) -> mujoco.MjSpec:
    """Parse the robot MJCF into an editable MjSpec.

    Raises:
      FileNotFoundError: the file does not exist.
      ValueError: the file is not valid MJCF, or lacks a joint, foot site or actuator that quadcos
        needs (see constants.JOINTS, constants.FEET).
    """
    path = pathlib.Path(mjcf_path) if mjcf_path is not None else constants.MJCF_PATH
    if not path.is_file():
        raise FileNotFoundError(f"MJCF file not found: {path}")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as error:  # mujoco raises plain ValueError/Exception with the parser message
        raise ValueError(f"MJCF {path} could not be parsed: {error}") from None
    _check_names(spec, path)
    return spec


def _check_names(spec: mujoco.MjSpec, path: pathlib.Path) -> None:
    joints = {joint.name for joint in spec.joints}
    sites = {site.name for site in spec.sites}
    actuators = [actuator.target for actuator in spec.actuators]
    missing = [name for name in constants.JOINTS if name not in joints]
    missing += [name for name in constants.FEET if name not in sites]
    missing += [name for name in (constants.ROOT_JOINT,) if name not in joints]
    if missing:
        raise ValueError(f"MJCF {path} lacks required element(s): {', '.join(missing)}")
    if actuators != list(constants.JOINTS):
        raise ValueError(
            f"MJCF {path} must actuate {', '.join(constants.JOINTS)} in that order; got {actuators}"
        )


def build_model(
    terrain: Ground,
    mjcf_path: str | pathlib.Path | None = None,
    *,
    timestep: float | None = None,
    solver_iterations: int | None = None,
    ls_iterations: int | None = None,
) -> mujoco.MjModel:
    """Compile the robot on `terrain` into an MjModel.

    Args:
      terrain: adds its ground geom (plane or heightfield) to the spec.
      mjcf_path: robot MJCF; defaults to models/mjcf/quadruped.xml.
      timestep: physics step, s (None keeps the MJCF's).
      solver_iterations, ls_iterations: constraint solver iterations (None keeps the MJCF's).

    Raises:
      FileNotFoundError, ValueError: a missing, malformed or non-compiling MJCF, named with its path.
    """
    spec = load_spec(mjcf_path)
    terrain.attach(spec)
    if timestep is not None:
        spec.option.timestep = timestep
    if solver_iterations is not None:
        spec.option.iterations = solver_iterations
    if ls_iterations is not None:
        spec.option.ls_iterations = ls_iterations
    try:
        return spec.compile()
    except Exception as error:
        path = mjcf_path if mjcf_path is not None else constants.MJCF_PATH
        raise ValueError(
            f"MJCF {path} failed to compile on terrain {terrain.name!r}: {error}"
        ) from None
