"""`python -m quadcos.bench`: throughput, compile time and time to walk on one device, as JSON.

    python -m quadcos.bench --out benchmarks/h100.json
    python -m quadcos.bench --preset cpu --out benchmarks/cpu.json --skip stock,walk,slope5
    python -m quadcos.bench --out benchmarks/h100.json --merge --only walk --walk_timeout_s 420
    python -m quadcos.bench --table benchmarks/h100.json      # the results as Markdown

Sections (each can be left out with --skip or chosen with --only):
  physics  raw MJX physics steps/s: `mjx.step` of the env's model, vmapped over the envs, one
           call = `substeps` physics steps (one env step's worth).
  env      env-steps/s of `jax.vmap(env.step)` (oscillator, estimator, reward inside) with the
           constant zero action (the action centre: the fixed trot).
  train    our trainer (`SACTrainer.train_chunk`) per row NUM_ENVSxBATCHxUPDATES.
  stock    stock `brax.training.agents.sac.train.train` on the same env and settings.
  walk     time until the deterministic policy, after the actor has started learning, survives
           20 s and moves >= 0.3 m/s in >= 99 % of evaluation episodes on flat.
  slope5   the same for crossing the slope5 course (the torso passes its end without a fall,
           within the time that 0.3 m/s takes).
Evaluation episodes are `quadcos.evaluate.rollout`s of the deterministic policy.

Every timed function is compiled by a first call on the very carry that is then timed (one trace,
checked), and timing ends with `block_until_ready`. Start-up-relative times (`compile_s`,
`time_to_*`) are "process start -> event" for a process that did only that section: the
process's start-up (imports, backend) plus the seconds since the section started building its env
from nothing. The JSON is rewritten after every measurement, so a crash keeps what came before;
a measurement that raises is recorded in `details.errors`, the rest still run, and the exit
status is 1.
Compile times are only meaningful without the JAX persistent compilation cache (the JSON records
`compilation_cache_dir`).
"""

import time

_IMPORT_TIME = time.perf_counter()

import argparse
import contextlib
import dataclasses
import datetime
import functools
import importlib.metadata
import json
import math
import os
import pathlib
import platform
import sys
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import ml_collections
import numpy as np
from brax.envs import base
from brax.training.agents.sac import networks as sac_networks
from mujoco import mjx

from quadcos import env as env_lib
from quadcos import evaluation, training
from quadcos.evaluation import rollout as rollout_lib
from quadcos.overrides import apply_overrides
from quadcos.train import PRESETS as TRAIN_PRESETS
from quadcos.training import files

SECTIONS = ("physics", "env", "train", "stock", "walk", "slope5")
WALK_SECONDS = 20.0  # s: an evaluation episode on flat
WALK_MIN_SPEED = 0.3  # m/s: mean forward speed over an episode (and over the slope5 course)
WALK_SUCCESS_RATE = 0.99  # fraction of evaluation episodes that must succeed
_VERSIONED_PACKAGES = ("jax", "jaxlib", "mujoco", "mujoco-mjx", "brax", "flax", "optax", "numpy")


@dataclasses.dataclass(frozen=True)
class TrainRow:
    """One training configuration: parallel envs, SAC batch size, updates per vectorised step."""

    num_envs: int
    batch_size: int
    updates_per_step: int

    @classmethod
    def parse(cls, text: str) -> "TrainRow":
        """'4096x8192x8' -> TrainRow(4096, 8192, 8)."""
        parts = text.strip().lower().split("x")
        try:
            values = [int(part) for part in parts]
        except ValueError:
            values = []
        if len(values) != 3 or min(values) < 1:
            raise ValueError(
                f"bad train row {text!r}; expected NUM_ENVSxBATCHxUPDATES, e.g. 4096x8192x8"
            )
        return cls(*values)

    def __str__(self) -> str:
        return f"{self.num_envs}x{self.batch_size}x{self.updates_per_step}"


@dataclasses.dataclass(frozen=True)
class Settings:
    """What one bench run measures, and at which sizes.

    Attributes:
      env_counts: parallel envs of the physics and env measurements.
      train_rows: rows of the train and stock sections.
      stock_rows: the rows also measured with stock Brax (a subset of `train_rows`).
      steps: timed calls (env steps) per physics / env measurement.
      train_seconds: timed training seconds per row (after the compiling first chunk / epoch).
      stock_epoch_steps: vectorised env steps per stock Brax epoch (the unit it reports in).
      stock_timeout_s: a stock row stops at its first report after this many seconds.
      training_preset: the `quadcos.train` preset whose `sac.*` / `env.*` values are used.
      walk_timeout_s: the walk and slope5 sections give up after this many seconds.
      walk_eval_interval: env steps between evaluations of the walk and slope5 sections.
      walk_eval_episodes: evaluation episodes per evaluation.
      sections: the sections to run, in order.
    """

    env_counts: tuple[int, ...]
    train_rows: tuple[TrainRow, ...]
    stock_rows: tuple[TrainRow, ...]
    steps: int
    train_seconds: float
    stock_epoch_steps: int
    stock_timeout_s: float
    training_preset: str
    walk_timeout_s: float
    walk_eval_interval: int
    walk_eval_episodes: int
    sections: tuple[str, ...]


_GPU_ROWS = "4096x8192x1,4096x8192x8,16384x16384x4"
BENCH_PRESETS: dict[str, dict[str, Any]] = {
    # The sizes, for one GPU.
    "gpu": {
        "env_counts": "1024,4096,16384,65536",
        "train_rows": _GPU_ROWS,
        "stock_rows": _GPU_ROWS,
        "steps": 50,
        "train_seconds": 15.0,
        "stock_epoch_steps": 50,
        "stock_timeout_s": 300.0,
        "training_preset": "gpu",
        "walk_timeout_s": 420.0,
        "walk_eval_interval": 1_000_000,
        "walk_eval_episodes": 1_024,
    },
    # Small sizes for a CPU (benchmarks/cpu.json); on two cores mostly compilation.
    "cpu": {
        "env_counts": "16,64",
        "train_rows": "32x256x4",
        "stock_rows": "32x256x4",
        "steps": 20,
        "train_seconds": 5.0,
        "stock_epoch_steps": 20,
        "stock_timeout_s": 300.0,
        "training_preset": "cpu",
        "walk_timeout_s": 300.0,
        "walk_eval_interval": 25_000,
        "walk_eval_episodes": 64,
    },
}


# --- Process start-up --------------------------------------------------------------------------


def _process_age_s() -> float:
    """Seconds since this process started (Linux /proc; 0 elsewhere)."""
    try:
        fields = pathlib.Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()
        started = int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22: starttime, in ticks
        uptime = float(pathlib.Path("/proc/uptime").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 0.0
    return max(uptime - started, 0.0)


# perf_counter() reading of the process start (python's own start-up included).
PROCESS_START = _IMPORT_TIME - _process_age_s()


def _since_start() -> float:
    return time.perf_counter() - PROCESS_START


def _log(message: str) -> None:
    print(f"[{_since_start():8.1f} s] {message}", flush=True)


# --- Stock Brax on JAX >= 0.10 -----------------------------------------------------------------


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


# --- Timing ------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Timing:
    """One timed function: `first_call_s` (compile + one call), then `calls` calls in `seconds`."""

    first_call_s: float
    calls: int
    seconds: float


def _strongly_typed(tree: Any) -> Any:
    """Drops weak types, so that a function's outputs have its inputs' types (no retrace)."""
    return jax.tree.map(lambda x: jax.lax.convert_element_type(x, jnp.asarray(x).dtype), tree)


def time_calls(step: Callable[[Any], Any], carry: Any, calls: int) -> Timing:
    """Compiles `step` (carry -> carry, donated) with a first call on `carry`, then times `calls`
    chained calls on the carry it returns.

    Raises:
      RuntimeError: `step` was traced more than once (the carry's types changed).
    """
    traces = 0

    def counted(carry: Any) -> Any:
        nonlocal traces
        traces += 1
        return step(carry)

    jitted = jax.jit(counted, donate_argnums=0)
    start = time.perf_counter()
    carry = jax.block_until_ready(jitted(carry))
    first_call_s = time.perf_counter() - start
    start = time.perf_counter()
    for _ in range(calls):
        carry = jitted(carry)
    jax.block_until_ready(carry)
    seconds = time.perf_counter() - start
    if traces != 1:
        raise RuntimeError(f"the timed function was traced {traces} times; its carry changes type")
    return Timing(first_call_s=first_call_s, calls=calls, seconds=seconds)


def make_batch_reset(env: base.Env) -> Callable[[int], base.State]:
    """num_envs -> `jax.vmap(env.reset)` of that many robots (strongly typed), compiled once per
    size, so that the physics and env measurements of one size share it."""
    reset_all = jax.jit(lambda keys: _strongly_typed(jax.vmap(env.reset)(keys)))
    return lambda num_envs: reset_all(jax.random.split(jax.random.PRNGKey(0), num_envs))


def measure_physics(env: env_lib.QuadrupedEnv, states: base.State, calls: int) -> Timing:
    """Raw `mjx.step` of `env.model` over the batch `states.pipeline_state`; one call =
    `env.substeps` physics steps (an env step's worth)."""
    step_all = jax.vmap(mjx.step, in_axes=(None, 0))

    def env_step_of_physics(data: mjx.Data) -> mjx.Data:
        data, _ = jax.lax.scan(
            lambda data, _: (step_all(env.model, data), None), data, None, length=env.substeps
        )
        return data

    return time_calls(env_step_of_physics, states.pipeline_state, calls)


def measure_env(env: env_lib.QuadrupedEnv, states: base.State, calls: int) -> Timing:
    """`jax.vmap(env.step)` over the batch `states` under the zero action (the action centre:
    the fixed trot)."""
    action = jnp.zeros((states.obs.shape[0], env.action_size))
    step_all = jax.vmap(env.step)
    return time_calls(lambda state: step_all(state, action), states, calls)


# --- Trainers ----------------------------------------------------------------------------------


def _preset_overrides(preset: str, prefix: str) -> dict[str, Any]:
    return {
        key[len(prefix) :]: value
        for key, value in TRAIN_PRESETS[preset].items()
        if key.startswith(prefix)
    }


def make_bench_env(terrain: str, preset: str) -> env_lib.QuadrupedEnv:
    """The env as `python -m quadcos.train --preset=PRESET --terrain=TERRAIN` builds it."""
    return env_lib.make_env(terrain, **_preset_overrides(preset, "env."))


def trainer_config(preset: str, row: TrainRow | None = None) -> ml_collections.ConfigDict:
    """`quadcos.training.default_config()` with the preset's `sac.*` values, then `row`'s sizes."""
    overrides = _preset_overrides(preset, "sac.")
    if row is not None:
        overrides |= {
            "num_envs": row.num_envs,
            "batch_size": row.batch_size,
            "updates_per_step": row.updates_per_step,
        }
    config = apply_overrides(training.default_config(), overrides)
    # A row's envs must fit in the replay buffer and outnumber nothing else.
    config.replay_size = max(config.replay_size, config.num_envs)
    training.check_config(config)
    return config


def measure_trainer(
    row: TrainRow, preset: str, train_seconds: float, startup_s: float
) -> dict[str, float]:
    """Our trainer's training throughput for one row, and its time to the first training step.

    Builds the env and trainer from nothing, runs `init` and `prefill`, then chunks of
    `steps_per_chunk` vectorised env steps (each with `updates_per_step` SAC updates); the first
    chunk compiles, the ones after it are timed until `train_seconds` have passed (>= 2).

    Returns:
      env_steps_per_s, first_chunk_s (compile + one chunk), start_to_first_step_s (startup_s +
      section start -> first chunk done), timed_chunks.
    """
    section_start = time.perf_counter()
    config = trainer_config(preset, row)
    trainer = training.SACTrainer(make_bench_env("flat", preset), config)
    state = trainer.prefill(trainer.init())
    jax.block_until_ready(state)
    start = time.perf_counter()
    state, metrics = trainer.train_chunk(state)
    jax.block_until_ready((state, metrics))
    done = time.perf_counter()
    first_chunk_s = done - start
    start_to_first_step_s = startup_s + done - section_start

    chunks, seconds = 0, 0.0
    while chunks < 2 or seconds < train_seconds:
        start = time.perf_counter()
        state, metrics = trainer.train_chunk(state)
        jax.block_until_ready((state, metrics))
        seconds += time.perf_counter() - start
        chunks += 1
    if trainer.chunk_traces != 1:
        raise RuntimeError(f"train_chunk was traced {trainer.chunk_traces} times")
    env_steps = chunks * config.steps_per_chunk * config.num_envs
    return {
        "env_steps_per_s": env_steps / seconds,
        "first_chunk_s": first_chunk_s,
        "start_to_first_step_s": start_to_first_step_s,
        "timed_chunks": chunks,
    }


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
    prefill_env_steps = -(-config.min_replay_size // config.num_envs) * config.num_envs
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


# --- Time to walk ------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Goal:
    """What an evaluation episode must achieve.

    Attributes:
      num_steps: env steps per episode (its time limit).
      duration_s: the time limit in seconds.
      finish_x: None: survive the whole episode and move >= `min_speed` forward (walking); else:
        the torso passes this x (m) before any fall (crossing a course).
      min_speed: m/s, for walking.
    """

    num_steps: int
    duration_s: float
    finish_x: float | None = None
    min_speed: float = WALK_MIN_SPEED


def terrain_goal(env: env_lib.QuadrupedEnv) -> Goal:
    """Flat: 20-s episodes, no fall and >= 0.3 m/s. A course (`course_end_x` set): episodes as
    long as crossing at 0.3 m/s takes; the torso must pass the course's end before any fall."""
    finish_x = env.terrain.course_end_x
    if finish_x is None:
        duration_s = WALK_SECONDS
    else:
        duration_s = (finish_x - env.terrain.spawn_x) / WALK_MIN_SPEED
    num_steps = math.ceil(duration_s / env.dt - 1e-9)
    return Goal(num_steps=num_steps, duration_s=num_steps * env.dt, finish_x=finish_x)


def episode_success(stats: evaluation.EpisodeStats, goal: Goal) -> np.ndarray:
    """(num_episodes,) bool from host `quadcos.evaluate` episode statistics of episodes run for
    `goal.num_steps` steps: crossed the course (no fall first), or walked the whole time limit
    at >= `goal.min_speed`."""
    if goal.finish_x is not None:
        return np.asarray(stats.finished)
    speed = (np.asarray(stats.x) - np.asarray(stats.start_x)) / goal.duration_s
    whole_episode = np.asarray(stats.steps) >= goal.num_steps
    return ~np.asarray(stats.fell) & whole_episode & (speed >= goal.min_speed)


def rollout_evaluator(
    trainer: training.SACTrainer, goal: Goal, num_episodes: int
) -> Callable[[training.TrainingState], dict[str, float]]:
    """training state -> success_rate, fall_rate, mean_speed (m/s) of `num_episodes`
    deterministic episodes (`quadcos.evaluate.rollout`, the same initial states every time) of
    the trainer's policy (tanh of the Gaussian mean) in the trainer's unwrapped env."""
    env = trainer.eval_env.env  # the VmapWrapper's env
    make_policy = sac_networks.make_inference_fn(trainer.networks)
    key_unused = jax.random.PRNGKey(0)  # a deterministic policy ignores its key

    def act(params: Any, obs: jax.Array) -> jax.Array:
        return make_policy(params, deterministic=True)(obs, key_unused)[0]

    source = evaluation.ActionSource(
        name="bench",
        kind="sac",
        act=act,
        params=None,
        env_overrides={},
        training_terrain=env.terrain.spec,
    )

    def evaluate(state: training.TrainingState) -> dict[str, float]:
        stats = rollout_lib.rollout(
            env,
            source,
            num_envs=num_episodes,
            num_steps=goal.num_steps,
            seed=1,
            act_params=(state.normalizer_params, state.policy_params),
        ).stats
        seconds = np.maximum(np.asarray(stats.steps), 1) * env.dt
        return {
            "success_rate": float(episode_success(stats, goal).mean()),
            "fall_rate": float(np.mean(stats.fell)),
            "mean_speed": float(np.mean((stats.x - stats.start_x) / seconds)),
        }

    return evaluate


def time_to_success(
    trainer: training.SACTrainer,
    evaluation: Callable[[training.TrainingState], dict[str, float]],
    *,
    timeout_s: float,
    eval_interval: int,
    section_start: float,
    startup_s: float = 0.0,
    label: str = "",
) -> dict[str, Any]:
    """Trains with `trainer` until `evaluation(state)["success_rate"]` >= 99 %.

    Evaluations run every `eval_interval` env steps once the actor learns (after
    `config.actor_warmup_steps` gradient steps: before, the policy is the untrained one, e.g. the
    trot at the action centre, whose evaluation is recorded as the first one).

    Returns:
      seconds (startup_s + section_start -> the successful evaluation done; None if not reached
      within `timeout_s` of section_start), reason (None, or why not), initial_success_rate, and
      the evaluations (env_steps, gradient_steps, seconds and what `evaluation` returned).
    """
    config = trainer.config
    evaluations: list[dict[str, Any]] = []

    def evaluate_now(state: training.TrainingState) -> float:
        row = {
            "env_steps": int(state.env_steps),
            "gradient_steps": int(state.gradient_steps),
            **evaluation(state),
            "seconds": startup_s + time.perf_counter() - section_start,
        }
        evaluations.append(row)
        _log(
            f"{label}{row['env_steps']} env steps: "
            + ", ".join(f"{name} {value:.3g}" for name, value in row.items() if name != "env_steps")
        )
        return row["success_rate"]

    state = trainer.init()
    initial_success_rate = evaluate_now(state)
    state = trainer.prefill(state)
    next_eval = int(state.env_steps)
    result: dict[str, Any] = {"seconds": None, "reason": None}
    while True:
        state, _ = trainer.train_chunk(state)
        env_steps = int(state.env_steps)
        actor_learning = int(state.gradient_steps) > config.actor_warmup_steps
        if actor_learning and env_steps >= next_eval:
            next_eval = env_steps + eval_interval
            if evaluate_now(state) >= WALK_SUCCESS_RATE:
                result["seconds"] = evaluations[-1]["seconds"]
                break
        if time.perf_counter() - section_start > timeout_s:
            best = max((row["success_rate"] for row in evaluations[1:]), default=None)
            result["reason"] = (
                f"not reached in {timeout_s:g} s ({env_steps} env steps); best success rate"
                f" after the actor's warm-up: {best}"
            )
            break
    return {**result, "initial_success_rate": initial_success_rate, "evaluations": evaluations}


# --- Results -----------------------------------------------------------------------------------


def _versions() -> dict[str, str]:
    versions = {"python": platform.python_version()}
    for package in _VERSIONED_PACKAGES:
        try:
            versions[package] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            pass
    return versions


def _cpu_model() -> str:
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def empty_results(settings: Settings, argv: Sequence[str], substeps: int) -> dict[str, Any]:
    """The results skeleton: every key of the issue's schema, numbers still None/empty."""
    device = jax.devices()[0]
    return {
        "device": device.device_kind,
        "platform": device.platform,
        "host": {"cpu": _cpu_model(), "cores": os.cpu_count()},
        "substeps_per_env_step": substeps,
        "physics_steps_per_s": {},
        "env_steps_per_s": {},
        "train": [],
        "compile_s": {"quadcos": None, "stock_brax": None},
        "time_to_walk_flat_s": None,
        "time_to_cross_slope5_s": None,
        "details": {},
        "command": " ".join(["python -m quadcos.bench", *argv]),
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "versions": _versions(),
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
        "compilation_cache_dir": jax.config.jax_compilation_cache_dir,
        "settings": {
            **dataclasses.asdict(settings),
            "train_rows": [str(row) for row in settings.train_rows],
            "stock_rows": [str(row) for row in settings.stock_rows],
        },
    }


def merge_results(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    """`old` updated with what `new` measured: dict entries and train rows are merged key by key
    (a None in `new` keeps `old`'s value); the commands, dates and settings of both runs are kept
    (as lists), and so are the errors of both (`details.errors`).

    Raises:
      ValueError: the two come from different devices.
    """
    if old.get("device") != new["device"]:
        raise ValueError(f"cannot merge results of {new['device']!r} into {old.get('device')!r}")
    merged = {**old}
    for key, value in new.items():
        if key == "train":
            rows = {_row_key(row): dict(row) for row in old.get("train", [])}
            for row in value:
                if _row_key(row) in rows:
                    measured = {name: entry for name, entry in row.items() if entry is not None}
                    rows[_row_key(row)].update(measured)
                else:
                    rows[_row_key(row)] = dict(row)
            merged["train"] = list(rows.values())
        elif key in ("physics_steps_per_s", "env_steps_per_s", "details", "compile_s"):
            merged[key] = {**old.get(key, {}), **{k: v for k, v in value.items() if v is not None}}
            if key == "details" and "errors" in old.get(key, {}):
                merged[key]["errors"] = {**old[key]["errors"], **value.get("errors", {})}
        elif key in ("command", "date", "settings"):
            merged[key] = _as_list(old.get(key)) + [value] if old.get(key) != value else old[key]
        elif value is not None or key not in old:
            merged[key] = value
    return merged


def _row_key(row: dict[str, Any]) -> tuple[int, int, int]:
    return row["num_envs"], row["batch_size"], row["updates_per_step"]


def _as_list(value: Any) -> list[Any]:
    if value is None:
        return []
    return list(value) if isinstance(value, list) else [value]


def _train_row(results: dict[str, Any], row: TrainRow) -> dict[str, Any]:
    """The results' entry for `row`, created (with every field None) if missing."""
    for entry in results["train"]:
        if _row_key(entry) == (row.num_envs, row.batch_size, row.updates_per_step):
            return entry
    entry = {
        "num_envs": row.num_envs,
        "batch_size": row.batch_size,
        "updates_per_step": row.updates_per_step,
        "quadcos_env_steps_per_s": None,
        "stock_brax_env_steps_per_s": None,
    }
    results["train"].append(entry)
    return entry


def _rate(value: float | None, unit: str = "") -> str:
    if value is None:
        return "—"
    for scale, prefix in ((1e9, " G"), (1e6, " M"), (1e3, " k")):
        if abs(value) >= scale:
            return f"{value / scale:.3g}{prefix}{unit}"
    return f"{value:.3g}{' ' + unit if unit else ''}"


def _seconds(value: float | None) -> str:
    return "—" if value is None else f"{value:.1f} s"


def _outcome(results: dict[str, Any], key: str, section: str) -> str:
    """A time-to-walk entry: the seconds, why there are none, or "—" when not measured."""
    if results[key] is not None:
        return _seconds(results[key])
    detail = results["details"].get(section)
    return detail["reason"] if detail and detail.get("reason") else "—"


def markdown_table(results: dict[str, Any]) -> str:
    """The results as Markdown tables: simulation throughput, training throughput (ours and
    stock Brax), start-up to the first training step, and time to walk."""
    header = (
        f"Device: {results['device']} ({results['platform']}); "
        f"{results['substeps_per_env_step']} physics steps per env step."
    )
    lines = [
        header,
        "",
        "| envs | raw MJX physics steps/s | env steps/s (`make_env`) |",
        "|---:|---:|---:|",
    ]
    counts = sorted(
        {*results["physics_steps_per_s"], *results["env_steps_per_s"]}, key=lambda count: int(count)
    )
    for count in counts:
        physics = _rate(results["physics_steps_per_s"].get(count))
        env = _rate(results["env_steps_per_s"].get(count))
        lines.append(f"| {int(count):,} | {physics} | {env} |")
    lines += [
        "",
        "| envs | batch | updates/step | quadcos env-steps/s | stock Brax env-steps/s | ours / stock |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for row in sorted(results["train"], key=_row_key):
        ours, stock = row["quadcos_env_steps_per_s"], row["stock_brax_env_steps_per_s"]
        ratio = f"{ours / stock:.2f}" if ours and stock else "—"
        sizes = f"{row['num_envs']:,} | {row['batch_size']:,} | {row['updates_per_step']}"
        lines.append(f"| {sizes} | {_rate(ours)} | {_rate(stock)} | {ratio} |")
    compile_s = results["compile_s"]
    ours, stock = _seconds(compile_s.get("quadcos")), _seconds(compile_s.get("stock_brax"))
    walk = _outcome(results, "time_to_walk_flat_s", "walk")
    cross = _outcome(results, "time_to_cross_slope5_s", "slope5")
    lines += [
        "",
        "| from process start | quadcos | stock Brax |",
        "|---|---:|---:|",
        f"| to the first training step (compile) | {ours} | {stock} |",
        f"| to walking on flat | {walk} | — |",
        f"| to crossing slope5 | {cross} | — |",
    ]
    return "\n".join(lines) + "\n"


# --- Command line ------------------------------------------------------------------------------


def _ints(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(part) for part in text.split(",") if part.strip())
    except ValueError:
        values = ()
    if not values or min(values) < 1:
        raise ValueError(f"expected positive integers separated by commas, got {text!r}")
    return values


def _rows(text: str) -> tuple[TrainRow, ...]:
    return tuple(TrainRow.parse(part) for part in text.split(",") if part.strip())


def _sections(text: str) -> set[str]:
    names = {part.strip() for part in text.split(",") if part.strip()}
    if unknown := names - set(SECTIONS):
        raise ValueError(f"unknown section(s) {sorted(unknown)}; known: {', '.join(SECTIONS)}")
    return names


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m quadcos.bench",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--out", help="results JSON (rewritten after every measurement)")
    parser.add_argument(
        "--merge",
        action="store_true",
        help="merge into --out's existing results instead of replacing them",
    )
    parser.add_argument("--table", metavar="FILE.json", help="print FILE's results as Markdown")
    parser.add_argument("--preset", choices=tuple(BENCH_PRESETS), default="gpu")
    parser.add_argument("--env_counts", help="physics / env sizes, e.g. 1024,4096")
    parser.add_argument("--train_rows", help="NUM_ENVSxBATCHxUPDATES,... e.g. 4096x8192x8")
    parser.add_argument("--stock_rows", help="rows also run with stock Brax (default: preset's)")
    parser.add_argument("--steps", type=int, help="timed calls per physics / env measurement")
    parser.add_argument("--train_seconds", type=float, help="timed seconds per training row")
    parser.add_argument("--stock_epoch_steps", type=int, help="vectorised steps per stock epoch")
    parser.add_argument("--stock_timeout_s", type=float, help="cap per stock row, compile included")
    parser.add_argument("--training_preset", choices=tuple(TRAIN_PRESETS))
    parser.add_argument("--walk_timeout_s", type=float, help="cap of the walk / slope5 sections")
    parser.add_argument("--walk_eval_interval", type=int, help="env steps between evaluations")
    parser.add_argument("--walk_eval_episodes", type=int, help="episodes per evaluation")
    parser.add_argument("--skip", default="", help=f"sections to leave out: {','.join(SECTIONS)}")
    parser.add_argument("--only", default="", help="the sections to run (the others are skipped)")
    return parser


def settings_from_args(args: argparse.Namespace) -> Settings:
    """The preset's sizes with the flags' values on top. Raises ValueError for bad values."""
    preset = {**BENCH_PRESETS[args.preset]}
    for name in preset:
        if getattr(args, name, None) is not None:
            preset[name] = getattr(args, name)
    if args.skip and args.only:
        raise ValueError("--skip and --only exclude each other")
    chosen = _sections(args.only) if args.only else set(SECTIONS) - _sections(args.skip)
    train_rows = _rows(preset["train_rows"])
    # Rows given on the command line are also the stock rows, unless --stock_rows says otherwise.
    stock_text = args.stock_rows or args.train_rows or preset["stock_rows"]
    stock_rows = _rows(stock_text)
    for name in ("steps", "stock_epoch_steps", "walk_eval_interval", "walk_eval_episodes"):
        if preset[name] < 1:
            raise ValueError(f"--{name} must be >= 1, got {preset[name]}")
    for name in ("train_seconds", "stock_timeout_s", "walk_timeout_s"):
        if not preset[name] >= 0:
            raise ValueError(f"--{name} must be >= 0, got {preset[name]}")
    return Settings(
        env_counts=_ints(preset["env_counts"]),
        train_rows=train_rows,
        stock_rows=stock_rows,
        steps=preset["steps"],
        train_seconds=preset["train_seconds"],
        stock_epoch_steps=preset["stock_epoch_steps"],
        stock_timeout_s=preset["stock_timeout_s"],
        training_preset=preset["training_preset"],
        walk_timeout_s=preset["walk_timeout_s"],
        walk_eval_interval=preset["walk_eval_interval"],
        walk_eval_episodes=preset["walk_eval_episodes"],
        sections=tuple(name for name in SECTIONS if name in chosen),
    )


def run(
    settings: Settings,
    out: pathlib.Path,
    results: dict[str, Any],
    startup_s: float,
    previous: dict[str, Any] | None = None,
) -> int:
    """Runs the chosen sections into `results`, writing them to `out` (merged into `previous`'s
    results when given) after every measurement.

    A measurement that raises (e.g. out of device memory) is recorded in `details.errors` and
    the others still run. Returns the number of failed measurements.
    """
    details = results["details"]
    details["startup_s"] = startup_s
    errors: dict[str, str] = {}

    def save() -> None:
        if errors:
            details["errors"] = errors
        out.parent.mkdir(parents=True, exist_ok=True)
        merged = results if previous is None else merge_results(previous, results)
        files.atomic_write_text(out, json.dumps(merged, indent=2) + "\n")

    def attempt(label: str, measure: Callable[[], str]) -> None:
        try:
            _log(f"{label}: {measure()}")
        except Exception as error:  # noqa: BLE001 - recorded; the other measurements still run
            errors[label] = f"{type(error).__name__}: {error}"[:2_000]
            _log(f"{label}: FAILED {errors[label][:300]}")
        save()

    save()
    sections = settings.sections
    if "physics" in sections or "env" in sections:
        env = make_bench_env("flat", settings.training_preset)
        reset_batch = make_batch_reset(env)

        def simulation(section: str, count: int) -> str:
            measure, table, unit_steps = {
                "physics": (measure_physics, "physics_steps_per_s", env.substeps),
                "env": (measure_env, "env_steps_per_s", 1),
            }[section]
            timing = measure(env, reset_batch(count), settings.steps)
            rate = count * unit_steps * timing.calls / timing.seconds
            results[table][str(count)] = rate
            details.setdefault(f"{section}_first_call_s", {})[str(count)] = timing.first_call_s
            return f"{_rate(rate)} steps/s (first call {timing.first_call_s:.1f} s)"

        for count in settings.env_counts:
            for section in ("physics", "env"):
                if section in sections:
                    attempt(
                        f"{section} {count} envs", functools.partial(simulation, section, count)
                    )
        del env, reset_batch

    def ours(row: TrainRow) -> str:
        measured = measure_trainer(row, settings.training_preset, settings.train_seconds, startup_s)
        entry = _train_row(results, row)
        entry["quadcos_env_steps_per_s"] = measured["env_steps_per_s"]
        entry["quadcos_first_chunk_s"] = measured["first_chunk_s"]
        entry["quadcos_start_to_first_step_s"] = measured["start_to_first_step_s"]
        if results["compile_s"]["quadcos"] is None:
            results["compile_s"]["quadcos"] = measured["start_to_first_step_s"]
            details["compile_s_row"] = str(row)
        return (
            f"{_rate(measured['env_steps_per_s'])} env-steps/s, first chunk"
            f" {measured['first_chunk_s']:.1f} s, start -> first step"
            f" {measured['start_to_first_step_s']:.1f} s"
        )

    def stock(row: TrainRow) -> str:
        section_start = time.perf_counter()
        measured = measure_stock_brax(
            make_bench_env("flat", settings.training_preset),
            trainer_config(settings.training_preset, row),
            settings.train_seconds,
            settings.stock_epoch_steps,
            settings.stock_timeout_s,
            section_start,
            startup_s,
        )
        entry = _train_row(results, row)
        entry["stock_brax_env_steps_per_s"] = measured["env_steps_per_s"]
        entry["stock_brax_start_to_first_step_s"] = measured["start_to_first_step_s"]
        entry["stock_brax_timed_out"] = bool(measured["timed_out"])
        if results["compile_s"]["stock_brax"] is None:
            results["compile_s"]["stock_brax"] = measured["start_to_first_step_s"]
            details["stock_compile_s_row"] = str(row)
        return (
            f"{_rate(measured['env_steps_per_s'])} env-steps/s, start -> first step"
            f" {measured['start_to_first_step_s']:.1f} s"
        )

    def walk(section: str) -> str:
        terrain, key = {
            "walk": ("flat", "time_to_walk_flat_s"),
            "slope5": ("slope5", "time_to_cross_slope5_s"),
        }[section]
        section_start = time.perf_counter()
        env = make_bench_env(terrain, settings.training_preset)
        trainer = training.SACTrainer(env, trainer_config(settings.training_preset))
        goal = terrain_goal(env)
        outcome = time_to_success(
            trainer,
            rollout_evaluator(trainer, goal, settings.walk_eval_episodes),
            timeout_s=settings.walk_timeout_s,
            eval_interval=settings.walk_eval_interval,
            section_start=section_start,
            startup_s=startup_s,
            label=f"{section}: ",
        )
        results[key] = outcome["seconds"]
        details[section] = {**outcome, "goal": dataclasses.asdict(goal)}
        details[section]["episodes"] = settings.walk_eval_episodes
        return f"{_seconds(outcome['seconds'])} {outcome['reason'] or ''}"

    if "train" in sections:
        for row in settings.train_rows:
            attempt(f"train {row}", functools.partial(ours, row))
    if "stock" in sections:
        for row in settings.stock_rows:
            attempt(f"stock {row}", functools.partial(stock, row))
    for section in ("walk", "slope5"):
        if section in sections:
            attempt(section, functools.partial(walk, section))
    return len(errors)


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    # The same XLA flags as `python -m quadcos.train`, set before the backend starts.
    os.environ.setdefault("XLA_FLAGS", "--xla_gpu_triton_gemm_any=true")
    parser = _parser()
    args = parser.parse_args(argv)
    if args.table:
        print(markdown_table(json.loads(pathlib.Path(args.table).read_text())), end="")
        return 0
    if not args.out:
        parser.error("--out is required (or --table to print results)")
    try:
        settings = settings_from_args(args)
        for row in settings.train_rows + settings.stock_rows:
            trainer_config(settings.training_preset, row)
    except ValueError as error:
        parser.error(str(error))
    out = pathlib.Path(args.out)
    previous = json.loads(out.read_text()) if args.merge and out.exists() else None

    jax.devices()  # starts the backend: part of the start-up
    startup_s = _since_start()
    substeps = make_bench_env("flat", settings.training_preset).substeps
    results = empty_results(settings, argv, substeps)
    if previous is not None:
        try:
            merge_results(previous, results)  # fails for another device, before measuring
        except ValueError as error:
            parser.error(str(error))
    _log(f"{results['device']}: sections {', '.join(settings.sections)} -> {out}")
    failures = run(settings, out, results, startup_s, previous)
    _log(
        f"done: {out}"
        + (f"; {failures} measurement(s) failed, see details.errors" if failures else "")
    )
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
