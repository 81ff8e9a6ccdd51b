"""A robot from a spec: its source (`sources.resolve`), preset (`presets`), prepared MJCF
(`prepare`) and derived description (`description.describe`), in one `Robot`."""

import dataclasses
import functools

import mujoco

from quadcos.robot import prepare, presets, sources
from quadcos.robot.description import RobotDescription, describe


@dataclasses.dataclass(frozen=True)
class Robot:
    """A quadruped ready for the env: where it came from, its settings and its description."""

    source: sources.RobotSource
    preset: presets.RobotPreset
    description: RobotDescription

    @property
    def name(self) -> str:
        return self.source.name

    @property
    def fall_min_height(self) -> float:
        """m: the base above the ground below which the robot has fallen."""
        if self.preset.fall_min_height is not None:
            return self.preset.fall_min_height
        return presets.FALL_HEIGHT_FRACTION * self.description.standing_height

    def spec(self) -> mujoco.MjSpec:
        """A fresh MjSpec of the robot, prepared for MJX (visual meshes stripped, the preset's
        collision profile and solver), to which a terrain attaches its ground."""
        spec = prepare.load_spec(self.source.path)
        if self.preset.collision != "asis":
            feet = [leg.foot_geom for leg in self.description.legs]
            prepare.apply_collision_profile(spec, feet, self.preset.collision)
        if self.preset.cone:
            prepare.set_cone(spec, self.preset.cone)
        if self.preset.joint_frictionloss is not None:
            for joint in spec.joints:
                if joint.type == mujoco.mjtJoint.mjJNT_HINGE:
                    joint.frictionloss = self.preset.joint_frictionloss
        return spec

    def provenance(self) -> dict:
        """Where the robot came from and the preset it ran with, for a run's config.json and an
        evaluation's setup."""
        return {
            "spec": self.source.spec,
            "name": self.source.name,
            "path": str(self.source.path),
            "menagerie_commit": self.source.menagerie_commit,
            "preset": dataclasses.asdict(self.preset),
        }

    def summary(self) -> dict:
        """The description with where it came from: `python -m quadcos.robot describe`."""
        return {
            "source": self.source.spec,
            "path": str(self.source.path),
            "menagerie_commit": self.source.menagerie_commit,
            **self.description.summary(),
            "fall_min_height_m": round(self.fall_min_height, 4),
            "physics": {
                "dt_s": self.preset.physics_dt,
                "solver_iterations": self.preset.solver_iterations or "the MJCF's",
                "ls_iterations": self.preset.ls_iterations or "the MJCF's",
                "cone": self.preset.cone or "the MJCF's",
                "joint_frictionloss": (
                    "the MJCF's"
                    if self.preset.joint_frictionloss is None
                    else self.preset.joint_frictionloss
                ),
                "collision": self.preset.collision,
            },
        }


@functools.lru_cache(maxsize=16)
def load(spec: str = "quadcos") -> Robot:
    """The robot named by `spec` ("quadcos", "quad12", an MJCF path, "menagerie:NAME" or a name
    registered with `sources.register`).

    Raises:
      FileNotFoundError: a missing MJCF.
      ValueError: a bad spec or an MJCF quadcos cannot drive, in one line naming it.
    """
    source = sources.resolve(spec)
    preset = presets.preset_for(source.name)
    model = _compile(prepare.load_spec(source.path), source)
    description = describe(  # its errors name the file: "robot MJCF PATH: ..."
        model, name=f"MJCF {source.path}", home=preset.home, kp=preset.kp, kd=preset.kd
    )
    description = dataclasses.replace(description, name=source.name)
    return Robot(source=source, preset=preset, description=description)


def _compile(spec: mujoco.MjSpec, source: sources.RobotSource) -> mujoco.MjModel:
    try:
        return spec.compile()
    except Exception as error:  # mujoco raises plain ValueError with the compiler's message
        raise ValueError(f"robot MJCF {source.path} failed to compile: {error}") from None
