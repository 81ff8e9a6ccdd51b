"""What the MJCF does not say about a robot, per robot: its home pose, PD gains for torque motors,
which geoms may touch the ground, the fall height, and the physics it is stable with.

The physics of each preset was chosen by measurement (experiments/robots/physics/: 32 robots of
each holding the home pose and walking the fixed trot for 10 s on flat and slope5 with MJX-JAX; the
cheapest step, cone and iterations without NaN or falls that holds within 5 % of the height the
robot settles at with converged physics).
"""

import dataclasses
from collections.abc import Mapping, Sequence

# The paper's robot falls below 0.35 m of its 0.67 m standing height: others, at the same fraction.
FALL_HEIGHT_FRACTION = 0.35 / 0.67
COLLISION_PROFILES = ("feet", "all", "asis")
# Contacts a world can make on a heightfield (a foot sphere touches several of its triangles at
# once) unless a preset says: enough for the paper's robot (12 at most) and Go1 (18 at most, over 14
# in 2 of 2600 physics steps); more rows cost MJX-Warp time (Go1 on slope5 with rows for 24
# contacts: 154 k instead of 241 k env steps/s, benchmarks/h100/hfield_contacts).
HFIELD_CONTACTS = 14


@dataclasses.dataclass(frozen=True)
class RobotPreset:
    """A robot's settings beyond its MJCF; every field has a default that derives or keeps.

    home: the standing pose: a keyframe name, joint values by name, or values in qpos order;
      None: the keyframe "home" if the MJCF has one, else joint zero.
    kp, kd: PD gains (N m/rad, N m s/rad; one value or per joint name) for torque motors.
    collision: "feet" (only the feet touch the ground, margins 0: what MJX can collide fast),
      "all" (margins 0) or "asis" (the MJCF unchanged).
    fall_min_height: m, the base above the ground under it below which the robot has fallen;
      None: FALL_HEIGHT_FRACTION of the standing height.
    physics_dt: s, the physics step. solver_iterations, ls_iterations: 0 keeps the MJCF's.
    cone: "pyramidal" or "elliptic" friction cones; "" keeps the MJCF's.
    joint_frictionloss: N m, every hinge's dry friction; None keeps the MJCF's.
    gpu_physics: what `impl="auto"` runs on a GPU: "warp" or "jax", whichever steps the robot
      faster (measured with `python -m quadcos.bench --only=physics --robot=...`).
    hfield_contacts: contacts a world can make on a heightfield, which sizes MJX-Warp's
      constraint rows (`quadcos.env.backends.constraint_rows`; beyond them Warp drops
      constraints: "nefc overflow"). Measured in C MuJoCo (experiments/robots/contacts): ANYmal C
      up to 23 on a 12° random course, Go1 18, the paper's robot 12.
    command_speed_max, command_yaw_rate_max: m/s, rad/s: the fastest forward speed and turn a
      velocity command asks of the robot (`quadcos.env.commands`: v* ∈ [0, max], ω* ∈ ±max);
      None derives them from the robot's hip height (`commands.speed_range`, `yaw_rate_range`).
    """

    home: str | Mapping[str, float] | Sequence[float] | None = None
    kp: float | Mapping[str, float] | None = None
    kd: float | Mapping[str, float] | None = None
    collision: str = "feet"
    fall_min_height: float | None = None
    physics_dt: float = 0.002
    solver_iterations: int = 0
    ls_iterations: int = 0
    cone: str = ""
    joint_frictionloss: float | None = None
    gpu_physics: str = "warp"
    hfield_contacts: int = HFIELD_CONTACTS
    command_speed_max: float | None = None
    command_yaw_rate_max: float | None = None

    def __post_init__(self):
        if self.collision not in COLLISION_PROFILES:
            raise ValueError(
                f"unknown collision profile {self.collision!r}; known: {', '.join(COLLISION_PROFILES)}"
            )
        if not self.physics_dt > 0:
            raise ValueError(f"physics_dt must be > 0 s; got {self.physics_dt}")
        if self.gpu_physics not in ("warp", "jax"):
            raise ValueError(f"unknown gpu_physics {self.gpu_physics!r}; known: warp, jax")
        if self.cone not in ("", "pyramidal", "elliptic"):
            raise ValueError(f"unknown cone {self.cone!r}; known: pyramidal, elliptic")
        if not (isinstance(self.hfield_contacts, int) and self.hfield_contacts >= 1):
            raise ValueError(
                f"hfield_contacts must be a whole number >= 1; got {self.hfield_contacts!r}"
            )
        if self.joint_frictionloss is not None and not self.joint_frictionloss >= 0:
            raise ValueError(f"joint_frictionloss must be >= 0 N m; got {self.joint_frictionloss}")
        for name in ("command_speed_max", "command_yaw_rate_max"):
            value = getattr(self, name)
            if value is not None and not 0 < value < float("inf"):
                raise ValueError(f"{name} must be finite and > 0; got {value}")


_ANYMAL_STANDING = {  # anymal_c_mjx.xml's "standing" keyframe: knees bent inwards (X)
    **{f"{leg}_HAA": 0.0 for leg in ("LF", "RF", "LH", "RH")},
    **{f"{leg}_HFE": 0.5236 for leg in ("LF", "RF")},
    **{f"{leg}_KFE": -0.7854 for leg in ("LF", "RF")},
    **{f"{leg}_HFE": -0.5236 for leg in ("LH", "RH")},
    **{f"{leg}_KFE": 0.7854 for leg in ("LH", "RH")},
}

PRESETS: dict[str, RobotPreset] = {
    # The paper's robot as its results were made: its MJCF's collisions, solver and step.
    # Commands up to 1.0 m/s: its policies walk 0.94-0.98 m/s (experiments/any_slope,
    # experiments/from_scratch), the fixed trot 0.6; ω* up to 0.5 rad/s, a 2-m turn at full speed
    # as the Go1 and ANYmal C ranges. (Its hip height's Froude default would say 1.2 m/s,
    # faster than any gait it has shown.)
    "quadcos": RobotPreset(
        collision="asis",
        fall_min_height=0.35,
        physics_dt=0.005,
        command_speed_max=1.0,
        command_yaw_rate_max=0.5,
    ),
    # MJX-JAX on a CPU, 32 robots for 10 s holding the home pose and walking the fixed trot, flat
    # and slope5 (experiments/robots/physics): the cheapest setting without NaN or falls.
    # Pyramidal cones blow up at every step and iteration count tried (impratio 100).
    "quad12": RobotPreset(
        home="home", physics_dt=0.005, cone="elliptic", solver_iterations=4, ls_iterations=8
    ),
    "unitree_go1": RobotPreset(
        home="home",
        physics_dt=0.005,
        cone="pyramidal",
        solver_iterations=4,
        ls_iterations=8,
        command_speed_max=1.0,  # the ranges, as MuJoCo Playground's Go1 joystick's
        command_yaw_rate_max=0.5,
    ),
    # go2.xml drives torque motors: go2_mjx.xml's kp 50 lets it sag 12 % and barely trot; kp 100.
    "unitree_go2": RobotPreset(
        home="home",
        kp=100.0,
        kd=1.0,
        physics_dt=0.005,
        cone="pyramidal",
        solver_iterations=4,
        ls_iterations=8,
        command_speed_max=1.0,
        command_yaw_rate_max=0.5,
    ),
    # The only setting tried without NaN. Its joints' 0.1 N m friction loss makes MJX sink it to
    # 0.84 of its standing height where C MuJoCo holds 0.93 with or without it; MJX without it
    # holds 0.93 too (experiments/robots/physics/anymal_probe.json), so the preset drops it.
    "anybotics_anymal_c": RobotPreset(
        home=_ANYMAL_STANDING,
        physics_dt=0.0025,
        cone="elliptic",
        solver_iterations=4,
        ls_iterations=8,
        joint_frictionloss=0.0,
        # Up to 23 contacts on a 12° random course, over 14 in 7 % of its physics steps
        # (experiments/robots/contacts): rows for 24.
        hfield_contacts=24,
        command_speed_max=0.8,  # heavier and slower for its size than the Unitree robots
        command_yaw_rate_max=0.4,
    ),
}


def preset_for(name: str) -> RobotPreset:
    """The preset the library ships for robot `name` (a source's short name), else the defaults."""
    return PRESETS.get(name, RobotPreset())
