"""A from-scratch run's trainer compiled while its gait search runs (`during_search`).

The trainer's programs take the searched gait as data (`QuadrupedEnv.gait`) and are keyed in
the caches without it (`quadcos._util.caches`), so a trainer built on any gait traces and
compiles the very programs the run's own trainer loads once the search has found its gait.
`during_search` builds one on a placeholder gait in a thread and compiles its programs into the
caches while the search runs: on a GPU XLA compiles on the host while the search's robots step
on the device. It applies to a run on MJX-JAX on one GPU or TPU of one process with the
compilation cache on. Not on a CPU: there the search and the compilation share the cores, so
the first chunk comes no sooner (docs/benchmarks.md), and XLA's CPU runtime can hang for good
with programs run from both threads (a search round that never returns). Not on MJX-Warp: each
Warp FFI call carries a `call_id` counting its callable's traces in the process, so programs
traced on the placeholder are not the run's and would miss the cache (docs/decisions.md). Not
over several processes: two threads issuing programs that span them are not known to be safe.
Not on several devices: the initial state's program holds the gait as a constant.
"""

import contextlib
import logging
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import jax
import ml_collections

from quadcos import robot
from quadcos.env import backends
from quadcos.equations import oscillator
from quadcos.training import checks, parallel, policy, sac

PLACEHOLDER_CENTRE = "midpoint"  # valid for any period floor; its values reach no program
PLATFORMS = ("gpu", "cuda", "rocm", "tpu")  # where the compilation overlaps the search
logger = logging.getLogger(__name__)

# env config -> (training env, evaluation env), as the run builds them
BuildEnvs = Callable[[ml_collections.ConfigDict], tuple[Any, Any]]


def applies(config: ml_collections.ConfigDict) -> bool:
    """Whether the run `config` ({"env", "sac"}) compiles its trainer during its gait search:
    it searches, `sac.gait_search.compile_trainer` is on, its physics is MJX-JAX, it runs on one
    GPU or TPU (`PLATFORMS`) of one process and the persistent compilation cache is on (the
    thread's programs reach the run's trainer through it)."""
    return (
        config.env.action_centre == oscillator.SEARCH_CENTRE
        and bool(config.sac.gait_search.compile_trainer)
        and backends.local_device().platform in PLATFORMS
        and jax.process_count() == 1
        and parallel.make_layout(config.sac.num_devices).mesh is None
        and bool(jax.config.jax_compilation_cache_dir)
        and _impl(config.env) == "jax"
    )


@contextlib.contextmanager
def during_search(config: ml_collections.ConfigDict, build_envs: BuildEnvs) -> Iterator[None]:
    """Where `applies(config)`: compiles the run's trainer on a placeholder gait in a thread while
    the body (the gait search) runs, and on leaving waits for it, so that the run's trainer
    loads those programs rather than compiling them a second time. A compilation that fails is
    logged in one line and the run compiles its trainer itself. A body that raises stops the
    thread at its next step and waits for what it is compiling (XLA cannot be interrupted)."""
    if not applies(config):
        yield
        return
    env_config = ml_collections.ConfigDict(config.env.to_dict())
    env_config.action_centre = PLACEHOLDER_CENTRE
    cancelled = threading.Event()
    thread = threading.Thread(
        target=_compile,
        args=(env_config, config.sac.copy_and_resolve_references(), build_envs, cancelled),
        name="quadcos-compile-during-search",
        daemon=True,
    )
    thread.start()
    try:
        yield
    except BaseException:
        cancelled.set()
        raise
    finally:
        thread.join()


def _compile(
    env_config: ml_collections.ConfigDict,
    config: ml_collections.ConfigDict,
    build_envs: BuildEnvs,
    cancelled: threading.Event,
) -> None:
    """Builds the trainer of `config` on the envs of `env_config` and compiles the programs a
    fresh run compiles: init and the copy of the policy its step-0 evaluation takes (by calling
    them), the prefill (with a `min_replay_size`), the training chunk and the evaluation. Stops
    between these steps once `cancelled` is set; checks first that the trainer's state fits the
    device (`checks.check_memory`: the run's own check says so in its error)."""
    start = time.monotonic()
    try:
        env, eval_env = build_envs(env_config)
        trainer = sac.SACTrainer(env, config, eval_env=eval_env)
        checks.check_memory(trainer)
        if cancelled.is_set():
            return
        state = trainer.init()
        policy.PolicyPart.copy_of(state)
        if cancelled.is_set():
            return
        for compiled in trainer.compile_ahead(state, prefill=config.min_replay_size > 0):
            compiled.result()
    except Exception as error:  # noqa: BLE001 - the run compiles its own trainer instead
        logger.warning(
            "compiling the trainer during the gait search failed (%s: %s); the run compiles it"
            " after the search",
            type(error).__name__,
            error,
        )
        return
    logger.info("trainer compiled during the gait search (%.0f s)", time.monotonic() - start)


def _impl(env_config: ml_collections.ConfigDict) -> str:
    """The physics the run's envs will resolve to ("jax" or "warp"; no warning: the envs give
    it), or the configured name where it does not resolve (the envs' error says why)."""
    gpu_physics = robot.load(env_config.robot).preset.gpu_physics
    try:
        return backends.resolve_impl(env_config.impl, gpu_physics, warn=False)
    except ValueError:
        return env_config.impl
