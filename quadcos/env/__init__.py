"""The env: the quadruped on a terrain under MJX, as a Brax `Env` (`QuadrupedEnv`, `make_env`).

Modules, lowest first: `backends` (the MJX implementation: JAX or Warp), `randomization` (a
robot's physics drawn per episode), `config` (the env's options, defaults and checks), `episodes`
(the one deterministic rollout loop), `tracking` (command tracking as evaluations measure it),
`layout` (where the robot's state sits, and its controls), `controller` (an action → joint
targets: the oscillator of Eq. 3, or the joint controller), `quadruped` (the env itself).
"""

from typing import Any

from quadcos import terrain as terrain_lib
from quadcos._util.overrides import apply_overrides
from quadcos.env import backends, config, episodes, layout, quadruped, randomization
from quadcos.env.config import (
    CONTROLLERS,
    OSCILLATOR_FORMS,
    action_size,
    default_config,
    max_progress,
    resolve,
    rhythm_scales,
    servo_gains,
    validate_config,
)
from quadcos.env.controller import JOINT_TARGET_BOUND
from quadcos.env.layout import MAX_SPEED
from quadcos.env.quadruped import _SPAWN_CLEARANCE, QuadrupedEnv

__all__ = [
    "CONTROLLERS",
    "JOINT_TARGET_BOUND",
    "MAX_SPEED",
    "OSCILLATOR_FORMS",
    "QuadrupedEnv",
    "action_size",
    "default_config",
    "make_env",
    "max_progress",
    "resolve",
    "rhythm_scales",
    "servo_gains",
    "validate_config",
]


def make_env(terrain: terrain_lib.Terrain | str | None = None, **overrides: Any) -> QuadrupedEnv:
    """Build the env: `make_env("slope5", controller="joint", **{"reward.yaw": 0.0})`.

    Overrides are env config keys (dotted for nested ones); an unknown key is a ValueError.
    `terrain` defaults to the config's "terrain" (flat).
    """
    env_config = apply_overrides(default_config(), overrides)
    return QuadrupedEnv(terrain if terrain is not None else env_config.terrain, env_config)
