"""SAC training of Brax envs on one device, built from Brax's SAC pieces.

`run` trains what a run config (`{"env", "sac"}`) describes, as `python -m quadcos.train` does;
`train` runs SAC on a given env (checkpoints, metrics, resume); `SACTrainer` holds the compiled
pieces, and `Trainers` keeps them for a later run of the same programs; `load_policy` reads back
a trained policy.
"""

from quadcos.training.checks import ConfigError, check_config
from quadcos.training.config import default_config
from quadcos.training.loop import NonFiniteLossError, TrainResult, train
from quadcos.training.policy import Policy, load_policy, save_policy
from quadcos.training.reuse import Trainers
from quadcos.training.sac import SACTrainer, TrainingState
from quadcos.training.session import run

__all__ = [
    "ConfigError",
    "NonFiniteLossError",
    "Policy",
    "SACTrainer",
    "TrainResult",
    "Trainers",
    "TrainingState",
    "check_config",
    "default_config",
    "load_policy",
    "run",
    "save_policy",
    "train",
]
