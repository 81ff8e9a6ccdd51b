"""A from-scratch run's trainer compiled while its gait search runs (`trainer_first`).

The trainer's programs take the searched gait as data (`QuadrupedEnv.gait`), so a run that
searches can build its own envs and trainer before the search, on a placeholder gait, trace the
trainer's programs and start compiling them (`SACTrainer.compile_ahead`: XLA compiles in threads,
on the host, while the search's robots step on the device), then go on with the gait the search
found: `reuse.with_gait` hands it shallow copies that share the compiled programs. One trainer
object throughout, so on MJX-Warp too, whose FFI calls are named per trace (`call_id`): programs
traced by another trainer would not be the run's. It applies to a fresh run on one GPU or TPU of
one process (on several devices the initial state's program holds the gait as a constant), with
`sac.gait_search.compile_trainer` on. Not on a CPU: there the search and XLA share the cores, so
the first chunk comes no sooner (docs/benchmarks.md), and XLA's CPU runtime has hung with a
search round running beside a compilation (docs/decisions.md). The programs are traced before
the search starts; on a GPU Warp's modules compile meanwhile (`warp_preload.deferred`), and the
search waits for them.
"""

import logging
import time
from collections.abc import Callable
from typing import Any

import jax
import ml_collections

from quadcos.env import backends
from quadcos.equations import oscillator
from quadcos.training import checks, parallel, sac

PLACEHOLDER_CENTRE = "midpoint"  # valid for any period floor; its values reach no program
PLATFORMS = ("gpu", "cuda", "rocm", "tpu")  # where the compilation overlaps the search
logger = logging.getLogger(__name__)

# env config -> (training env, evaluation env), as the run builds them
BuildEnvs = Callable[[ml_collections.ConfigDict], tuple[Any, Any]]


def applies(config: ml_collections.ConfigDict, resume: bool = False) -> bool:
    """Whether the run `config` ({"env", "sac"}) builds its trainer before its gait search: it
    searches, `sac.gait_search.compile_trainer` is on, it trains from nothing (not `resume`), on
    one GPU or TPU (`PLATFORMS`) of one process."""
    return (
        config.env.action_centre == oscillator.SEARCH_CENTRE
        and bool(config.sac.gait_search.compile_trainer)
        and not resume
        and backends.local_device().platform in PLATFORMS
        and jax.process_count() == 1
        and parallel.make_layout(config.sac.num_devices).mesh is None
    )


def trainer_first(
    config: ml_collections.ConfigDict, build_envs: BuildEnvs
) -> tuple[Any, Any, sac.SACTrainer]:
    """The run's envs (`build_envs` of its env config with a placeholder gait) and trainer, its
    programs traced and compiling in threads: for `reuse.with_gait` once the search has found
    the gait.

    Raises:
      ConfigError: as `loop.train` would, before the search runs: an invalid trainer config, a
        tracking rank without commands, a state larger than the device's memory.
    """
    start = time.monotonic()
    env_config = ml_collections.ConfigDict(config.env.to_dict())
    env_config.action_centre = PLACEHOLDER_CENTRE
    checks.check_config(config.sac)
    env, eval_env = build_envs(env_config)
    checks.check_tracked(config.sac, eval_env)
    trainer = sac.SACTrainer(env, config.sac, eval_env=eval_env)
    checks.check_memory(trainer)
    trainer.compile_ahead(trainer.state_shapes, prefill=config.sac.min_replay_size > 0)
    logger.info(
        "trainer traced before the gait search (%.1f s); its programs compile during it",
        time.monotonic() - start,
    )
    return env, eval_env, trainer
