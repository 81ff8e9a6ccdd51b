"""SAC training of Brax envs on one device, built from Brax's SAC pieces.

`train` runs a whole run (checkpoints, metrics, resume); `SACTrainer` holds
the compiled pieces; `load_policy` reads back a trained policy.
"""

from quadcos.training.config import default_config
from quadcos.training.checks import ConfigError
from quadcos.training.loop import NonFiniteLossError
from quadcos.training.loop import TrainResult
from quadcos.training.checks import check_config
from quadcos.training.loop import train
from quadcos.training.policy import Policy
from quadcos.training.policy import load_policy
from quadcos.training.policy import save_policy
from quadcos.training.sac import SACTrainer
from quadcos.training.sac import TrainingState

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
