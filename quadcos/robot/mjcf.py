"""A robot on a ground, compiled: host-side MuJoCo only."""

from typing import Protocol

import mujoco

from quadcos.robot import prepare
from quadcos.robot.loading import Robot


class Ground(Protocol):
    """What `build_model` needs of a terrain (`quadcos.terrain.Terrain` is one)."""

    name: str

    def attach(self, spec: mujoco.MjSpec) -> None: ...


def build_model(
    terrain: Ground,
    robot: Robot,
    *,
    timestep: float,
    solver_iterations: int = 0,
    ls_iterations: int = 0,
    cone: str = "",
    servo: tuple[float, float] | None = None,
) -> mujoco.MjModel:
    """Compile `robot` on `terrain` into an MjModel.

    Args:
      terrain: adds its ground geom (plane or heightfield) to the robot's spec.
      robot: the robot (`quadcos.robot.load`).
      timestep: the physics step, s.
      solver_iterations, ls_iterations: constraint solver iterations (0 keeps the MJCF's).
      cone: "pyramidal" or "elliptic" friction cones; "" keeps the robot preset's (else the
        MJCF's).
      servo: (kp, kd) of every position servo (`prepare.set_servo_gains`); None keeps the MJCF's.

    Raises:
      ValueError: the robot does not compile on the terrain, or has a ground of its own, naming
        both; servo gains for a robot without position servos.
    """
    spec = robot.spec()
    try:
        terrain.attach(spec)
    except ValueError as error:  # the MJCF has a ground of its own
        raise ValueError(
            f"robot {robot.source.spec} ({robot.source.path}) cannot take terrain"
            f" {terrain.name!r}: {error}. quadcos adds the ground: name the robot's own MJCF, not a"
            " scene that includes it (a Menagerie scene.xml includes the robot's file)"
        ) from None
    spec.option.timestep = timestep
    if solver_iterations:
        spec.option.iterations = solver_iterations
    if ls_iterations:
        spec.option.ls_iterations = ls_iterations
    if cone:
        prepare.set_cone(spec, cone)
    if servo is not None:
        try:
            prepare.set_servo_gains(spec, *servo)
        except ValueError as error:
            raise ValueError(f"robot {robot.source.spec}: {error}") from None
    try:
        return spec.compile()
    except Exception as error:  # mujoco raises plain ValueError with the compiler's message
        raise ValueError(
            f"robot {robot.source.spec} ({robot.source.path}) failed to compile on terrain"
            f" {terrain.name!r}: {error}"
        ) from None
