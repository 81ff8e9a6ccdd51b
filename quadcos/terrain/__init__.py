"""Terrains: the ground a robot walks on, built from a profile, registered by name, parsed from a
spec (`parse`, the CLI's `--terrain`), or laid side by side as course lanes (`courses`).

A `Terrain` is an immutable description of the ground. On the host it adds the ground to a robot's
`mujoco.MjSpec` (`Terrain.attach`); inside the env its `height_at` / `slope_at` are pure
`jax.numpy` functions giving the ground-truth height and pitch.

World frame (MuJoCo): +x forward (the robot spawns at x = `spawn_x` = 0, y = 0 and walks along
+x), +y left, +z up; the paper's forward axis is its y. Slope angles are radians in code (> 0
uphill along +x) and degrees only in user-facing specs (`sections:ANGLE_DEG@LENGTH_M,...`).

Modules, lowest first: `ground` (`Terrain`, `Lane`), `builders` (`flat`, `sections`,
`heightfield`, the paper's `slope5` and `s4`), `registry` (names), `courses` (lanes, `random:`,
`testset:`), `external` (`heightfield:FILE.npy`, `MODULE:NAME`), `specs` (`parse`).
"""

from quadcos.terrain import builders, courses, external, ground, registry, specs
from quadcos.terrain.builders import (
    Section,
    flat,
    heightfield,
    s4,
    sections,
    slope5,
)
from quadcos.terrain.ground import (
    FLOOR_GEOM,
    FLOOR_HFIELD,
    GROUND_CONDIM,
    GROUND_FRICTION,
    Lane,
    Terrain,
)
from quadcos.terrain.registry import names, register, registered
from quadcos.terrain.specs import get, parse

__all__ = [
    "FLOOR_GEOM",
    "FLOOR_HFIELD",
    "GROUND_CONDIM",
    "GROUND_FRICTION",
    "Lane",
    "Section",
    "Terrain",
    "courses",
    "flat",
    "get",
    "heightfield",
    "names",
    "parse",
    "register",
    "registered",
    "s4",
    "sections",
    "slope5",
]
