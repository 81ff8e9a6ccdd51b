"""A trainer's compiled programs reused by a later run of the same programs in one process.

Tracing, lowering and loading a trainer's programs costs a process seconds even when the
persistent compilation cache holds them. Runs whose env config and trainer config agree in every
field a program reads (another seed, a longer or resumed run, another searched gait: the programs
take it as data) can share one `SACTrainer`: `Trainers.get` hands out the one of the last run of
those programs, reseeded and with the run's gait (`with_gait`), and `Trainers.keep` stores the one
a run used (with the programs it compiled).
"""

import copy
import json
from typing import Any

import jax
import ml_collections

from quadcos._util.overrides import flatten
from quadcos.env.quadruped import QuadrupedEnv
from quadcos.training import config as config_lib
from quadcos.training import parallel, sac
from quadcos.training import state as state_lib


def program_key(env_config: ml_collections.ConfigDict, config: ml_collections.ConfigDict) -> str:
    """What a trainer's programs depend on: the env config (on one device but for the gait's
    fields, `QuadrupedEnv.gait_fields`: the same before a gait search and after it) and the
    trainer config but for `config.HOST_FIELDS`, as one JSON string."""
    env = flatten(env_config.to_dict())
    if _gait_is_data(config):
        env = {key: value for key, value in env.items() if key not in QuadrupedEnv.gait_fields}
    programs = config_lib.program_fields(config)
    return json.dumps({"env": env, "sac": programs}, sort_keys=True, default=str)


def _gait_is_data(config: ml_collections.ConfigDict) -> bool:
    """Whether the programs of a trainer with `config` take the gait as data: on one device of
    one process (on several, the initial state's program holds it as a constant)."""
    try:
        return parallel.make_layout(config.num_devices).mesh is None
    except ValueError:  # a device count the trainer refuses, saying why
        return False


def with_gait(
    env: Any, eval_env: Any, trainer: sac.SACTrainer, env_config: ml_collections.ConfigDict
) -> tuple[Any, Any, sac.SACTrainer]:
    """`env`, `eval_env` and `trainer` (shallow copies, sharing their models and compiled
    programs) with the gait of `env_config` (its `QuadrupedEnv.gait_fields`): the trainer passes
    that gait to its programs as data. Envs not quadcos's are returned as they are."""
    if not isinstance(env, QuadrupedEnv):
        return env, eval_env, trainer
    gaited = {id(e): e.with_gait_of(env_config) for e in (env, eval_env)}
    env, eval_env = gaited[id(env)], gaited[id(eval_env)]
    trainer = copy.copy(trainer)
    trainer._gait, trainer._eval_gait = state_lib.gait_of(env), state_lib.gait_of(eval_env)
    return env, eval_env, trainer


def for_run(trainer: sac.SACTrainer, config: ml_collections.ConfigDict) -> sac.SACTrainer:
    """`trainer` (a shallow copy, sharing its jitted and compiled programs) for a run with
    `config`, which may differ from the trainer's own only in `config.HOST_FIELDS`.

    Raises:
      ValueError: `config` differs in a field a program reads.
    """
    mine, theirs = config_lib.program_fields(trainer.config), config_lib.program_fields(config)
    if mine != theirs:
        changed = sorted(k for k in mine.keys() | theirs.keys() if mine.get(k) != theirs.get(k))
        raise ValueError(f"the trainer's programs read {', '.join(changed)}, which differ")
    reused = copy.copy(trainer)
    reused.config = config.copy_and_resolve_references()
    # The run's keys, as SACTrainer.__init__ draws them from the seed.
    reused._key_init, reused._eval_key = jax.random.split(jax.random.PRNGKey(config.seed))
    reused._eval_keys = jax.random.split(reused._eval_key, config.num_eval_envs)
    return reused


class Trainers:
    """The envs and trainer of the last run per `program_key`, kept by the caller of
    `quadcos.training.run` (or `quadcos.train.main`) for its later runs: tests, notebooks."""

    def __init__(self) -> None:
        self._built: dict[str, tuple[Any, Any, sac.SACTrainer]] = {}

    def get(
        self, key: str, config: ml_collections.ConfigDict
    ) -> tuple[Any, Any, sac.SACTrainer] | None:
        """(env, eval_env, trainer for a run with `config`: `for_run`) kept for `key`, or None;
        their gait is the kept run's (`with_gait` gives them the run's)."""
        if key not in self._built:
            return None
        env, eval_env, trainer = self._built[key]
        return env, eval_env, for_run(trainer, config)

    def keep(self, key: str, env: Any, eval_env: Any, trainer: Any) -> None:
        """Keeps a run's envs and trainer; a run that built no `SACTrainer` keeps nothing."""
        if isinstance(trainer, sac.SACTrainer):
            self._built[key] = (env, eval_env, trainer)
