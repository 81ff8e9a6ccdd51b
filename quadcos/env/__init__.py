"""The env: the quadruped on a terrain under MJX, as a Brax `Env` (`QuadrupedEnv`, `make_env`).

Modules, lowest first: `backends` (the MJX implementation: JAX or Warp), `randomization` (a
robot's physics drawn per episode), `config` (the env's options, defaults and checks), `episodes`
(the one deterministic rollout loop), `layout` (where the robot's state sits, and its
controls), `quadruped` (the env itself).
"""

from quadcos.env import backends, config, episodes, layout, quadruped, randomization
from quadcos.env.config import (
    CONTROLLERS,
    OSCILLATOR_FORMS,
    action_size,
    default_config,
    max_progress,
    resolve,
    validate_config,
)
from quadcos.env.quadruped import (
    _SPAWN_CLEARANCE,
    JOINT_TARGET_BOUND,
    QuadrupedEnv,
    make_env,
)

__all__ = [
    "CONTROLLERS",
    "JOINT_TARGET_BOUND",
    "OSCILLATOR_FORMS",
    "QuadrupedEnv",
    "action_size",
    "default_config",
    "make_env",
    "max_progress",
    "resolve",
    "validate_config",
]
