"""Training throughput side by side: our trainer (`SACTrainer.train_chunk`) and stock Brax SAC
(`brax.training.agents.sac.train`, which needs `jax.device_put_replicated` back on JAX >= 0.10)."""

import contextlib
import functools
import math
import time
from collections.abc import Iterator, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import ml_collections
import numpy as np
from brax.envs import base
from brax.training.agents.sac import networks as sac_networks
from jax.experimental import multihost_utils

from quadcos import training
from quadcos.benchmarking.settings import TrainRow, make_bench_env, trainer_config
from quadcos.training import config as config_lib


def measure_trainer(
    row: TrainRow,
    preset: str,
    train_seconds: float,
    startup_s: float,
    terrain: str = "flat",
    impl: str = "auto",
    num_devices: int = 1,
    robot: str = "quadcos",
    randomize: bool = False,
    profile_dir: str | None = None,
    env: dict[str, Any] | None = None,
    sac: dict[str, Any] | None = None,
    profile_python: bool = False,
) -> dict[str, float]:
    """Our trainer's training throughput for one row (over `num_devices`), and its time to the
    first training step.

    Builds the env and trainer from nothing, runs `init` and `prefill`, then chunks of
    `steps_per_chunk` vectorised env steps (each with `updates_per_step` SAC updates); the first
    chunk compiles, the ones after it are timed until `train_seconds` have passed (>= 2).
    `profile_dir`: then two more chunks run under `jax.profiler.trace` into it (untimed), the
    host's Python calls recorded only where `profile_python` (they slow the host). `env`,
    `sac`: env and trainer config overrides.

    Returns:
      env_steps_per_s, first_chunk_s (compile + one chunk), start_to_first_step_s (startup_s +
      section start -> first chunk done), timed_chunks.
    """
    section_start = time.perf_counter()
    config = trainer_config(preset, row, num_devices, **(sac or {}))
    trainer = training.SACTrainer(
        make_bench_env(terrain, preset, impl, robot=robot, randomize=randomize, **(env or {})),
        config,
    )
    state = trainer.prefill(trainer.init())
    jax.block_until_ready(state)
    start = time.perf_counter()
    state, metrics = trainer.train_chunk(state)
    jax.block_until_ready((state, metrics))
    done = time.perf_counter()
    first_chunk_s = done - start
    start_to_first_step_s = startup_s + done - section_start

    chunks, seconds, planned = 0, 0.0, None
    while chunks < 2 or (seconds < train_seconds if planned is None else chunks < planned):
        start = time.perf_counter()
        state, metrics = trainer.train_chunk(state)
        jax.block_until_ready((state, metrics))
        seconds += time.perf_counter() - start
        chunks += 1
        if planned is None and jax.process_count() > 1:
            planned = _agreed_chunks(train_seconds, seconds)
    if profile_dir is not None:
        options = jax.profiler.ProfileOptions()
        options.python_tracer_level = int(profile_python)
        with jax.profiler.trace(profile_dir, create_perfetto_trace=True, profiler_options=options):
            for _ in range(2):
                state, metrics = trainer.train_chunk(state)
                jax.block_until_ready((state, metrics))
    if trainer.chunk_traces > 1:  # 0: loaded as traced before (quadcos._util.caches.Program)
        raise RuntimeError(f"train_chunk was traced {trainer.chunk_traces} times")
    env_steps = chunks * config.steps_per_chunk * config.num_envs
    return {
        "env_steps_per_s": env_steps / seconds,
        "first_chunk_s": first_chunk_s,
        "start_to_first_step_s": start_to_first_step_s,
        "timed_chunks": chunks,
    }


def _agreed_chunks(train_seconds: float, first_chunk_s: float) -> int:
    """The timed chunks of a row run by several processes: as many as `train_seconds` take at
    process 0's first timed chunk (`first_chunk_s`), at least 2, the same in every process (each
    chunk's collectives need all of them)."""
    count = max(2, math.ceil(train_seconds / first_chunk_s))
    return int(multihost_utils.broadcast_one_to_all(np.int32(count)))


class _EnoughEpochs(Exception):
    """Raised from stock Brax's progress callback to end its training early."""


def measure_stock_brax(
    env: base.Env,
    config: ml_collections.ConfigDict,
    train_seconds: float,
    epoch_steps: int,
    timeout_s: float,
    section_start: float,
    startup_s: float,
) -> dict[str, float]:
    """Stock `brax.training.agents.sac.train.train` on `env` with `config`'s settings.

    Training runs in epochs of `epoch_steps` vectorised env steps (brax times each and reports
    `training/sps`, evaluation excluded); it is ended from the progress callback once the epochs
    after the first (which compiles) add up to `train_seconds` (>= 2 of them), or at the first
    report after `timeout_s`. Evaluation uses `_NullEnv`, and its time is subtracted from the time
    to the first training step. Stock Brax has one learning rate: `config.learning_rate.actor`.

    Returns:
      env_steps_per_s, start_to_first_step_s (startup_s + section_start -> first epoch done,
      evaluation excluded), timed_epochs, timed_out (1.0 when stopped by `timeout_s`).
    """
    from brax.training.agents.sac import train as sac_train

    start = time.perf_counter()
    reports: list[tuple[float, int, dict[str, float]]] = []
    stopped = {"timed_out": False}

    def progress(step: int, metrics: dict[str, Any]) -> None:
        metrics = {name: float(value) for name, value in metrics.items()}
        reports.append((time.perf_counter(), int(step), metrics))
        timed = [metrics for _, step, metrics in reports if step > 0][1:]
        timed_seconds = sum(epoch_env_steps / epoch["training/sps"] for epoch in timed)
        if len(timed) >= 2 and timed_seconds >= train_seconds:
            raise _EnoughEpochs
        if time.perf_counter() - start > timeout_s:
            stopped["timed_out"] = True
            raise _EnoughEpochs

    epoch_env_steps = epoch_steps * config.num_envs
    prefill_env_steps = config_lib.prefill_steps(config) * config.num_envs
    max_epochs = 10_000  # an upper bound; the callback ends training
    network_factory = functools.partial(
        sac_networks.make_sac_networks, hidden_layer_sizes=tuple(config.hidden_sizes.policy)
    )
    with device_put_replicated_patch():
        try:
            sac_train.train(
                environment=env,
                num_timesteps=prefill_env_steps + max_epochs * epoch_env_steps,
                episode_length=config.episode_length,
                num_envs=config.num_envs,
                num_eval_envs=1,
                learning_rate=config.learning_rate.actor,
                discounting=config.discount,
                seed=config.seed,
                batch_size=config.batch_size,
                num_evals=max_epochs + 1,
                normalize_observations=config.normalize_observations,
                max_devices_per_host=1,
                reward_scaling=config.reward_scaling,
                tau=config.tau,
                min_replay_size=config.min_replay_size,
                max_replay_size=config.replay_size,
                grad_updates_per_step=config.updates_per_step,
                deterministic_eval=True,
                network_factory=network_factory,
                progress_fn=progress,
                eval_env=_NullEnv(env.observation_size, env.action_size),
            )
        except _EnoughEpochs:
            pass
    training_reports = [report for report in reports if report[1] > 0]
    timed = [metrics for _, _, metrics in training_reports[1:]]
    if not timed:
        raise RuntimeError(f"stock Brax reported {len(training_reports)} epochs, none timed")
    first_epoch_done = training_reports[0][0]
    eval_seconds = sum(
        metrics.get("eval/epoch_eval_time", 0.0)
        for when, _, metrics in reports
        if when <= first_epoch_done
    )
    seconds = sum(epoch_env_steps / epoch["training/sps"] for epoch in timed)
    return {
        "env_steps_per_s": len(timed) * epoch_env_steps / seconds,
        "start_to_first_step_s": startup_s + first_epoch_done - section_start - eval_seconds,
        "timed_epochs": len(timed),
        "timed_out": float(stopped["timed_out"]),
    }


def _device_put_replicated(tree: Any, devices: Sequence[jax.Device]) -> Any:
    """What `jax.device_put_replicated` did: each leaf stacked len(devices) times along a new
    leading axis, slice i on devices[i] (as `jax.pmap` expects its replicated inputs)."""
    mesh = jax.sharding.Mesh(list(devices), ("replicas",))
    sharding = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("replicas"))
    return jax.tree.map(
        lambda leaf: jax.device_put(jnp.stack([jnp.asarray(leaf)] * len(devices)), sharding),
        tree,
    )


@contextlib.contextmanager
def device_put_replicated_patch() -> Iterator[None]:
    """Provides `jax.device_put_replicated` (removed in JAX 0.10, still called by brax 0.14's
    `sac.train`) inside the block; restores the attribute as it was afterwards (absent, or the
    original object), also when the block raises."""
    missing = object()
    original = jax.__dict__.get("device_put_replicated", missing)
    jax.device_put_replicated = _device_put_replicated
    try:
        yield
    finally:
        if original is missing:
            del jax.device_put_replicated
        else:
            jax.device_put_replicated = original


class _NullEnv(base.Env):
    """Stock Brax's evaluation env in the stock section: constant zeros of the training env's
    sizes. Evaluation is not part of what is measured, and evaluating the real env every epoch
    would cost more device time than the epoch itself."""

    def __init__(self, observation_size: int, action_size: int):
        self._observation_size = observation_size
        self._action_size = action_size

    def reset(self, rng: jax.Array) -> base.State:
        zero = jnp.zeros(())
        return base.State(
            pipeline_state=zero,
            obs=jnp.zeros(self._observation_size),
            reward=zero,
            done=zero,
            metrics={},
            info={},
        )

    def step(self, state: base.State, action: jax.Array) -> base.State:
        return state

    @property
    def observation_size(self) -> int:
        return self._observation_size

    @property
    def action_size(self) -> int:
        return self._action_size

    @property
    def backend(self) -> str:
        return "jax"
