"""SAC training of Brax envs on one device, built from Brax's SAC pieces.

`train` runs a whole run (checkpoints, metrics, resume); `SACTrainer` holds
the compiled pieces; `load_policy` reads back a trained policy.
"""

from quadcos.training.checks import ConfigError, check_config
from quadcos.training.config import default_config
from quadcos.training.loop import NonFiniteLossError, TrainResult, train
from quadcos.training.policy import Policy, load_policy, save_policy
from quadcos.training.sac import SACTrainer, TrainingState

__all__ = [
    "ConfigError",
    "NonFiniteLossError",
    "Policy",
    "SACTrainer",
    "TrainResult",
    "TrainingState",
    "check_config",
    "default_config",
    "load_policy",
    "save_policy",
    "train",
]
