"""The host loop of a SAC run: train in compiled chunks, evaluate, checkpoint.

The device runs one compiled chunk at a time; between chunks the host checks
the losses, evaluates, writes metrics and checkpoints, and reacts to signals.

Run directory layout:
  config.json     the config, library versions, git revision, caller's info
  metrics.jsonl   one JSON object per evaluation (also metrics.csv, tensorboard/)
  checkpoints/    orbax checkpoints of the full TrainingState, named by env step
  policy/         the final policy (see `quadcos.training.policy`)
"""

import dataclasses
import importlib.metadata
import json
import logging
import math
import os
from pathlib import Path
import signal
import subprocess
import sys
import threading
import time
from typing import Any, TextIO

from brax import envs
import jax
import ml_collections

from quadcos.training import checkpoint
from quadcos.training import config as config_lib
from quadcos.training import files
from quadcos.training import metrics_log
from quadcos.training import policy as policy_lib
from quadcos.training import sac

logger = logging.getLogger(__name__)

_LOSSES = ("critic_loss", "actor_loss", "alpha_loss", "alpha")
# Config fields that size device arrays (or index them with int32).
_SHAPES = (
    "num_envs",
    "batch_size",
    "replay_size",
    "episode_length",
    "steps_per_chunk",
    "updates_per_step",
    "num_eval_envs",
    "eval_episode_length",
)
_VERSIONED_PACKAGES = (
    "jax",
    "jaxlib",
    "brax",
    "mujoco",
    "mujoco-mjx",
    "flax",
    "optax",
    "orbax-checkpoint",
    "numpy",
)


class NonFiniteLossError(FloatingPointError):
    """A SAC loss became NaN or infinite; the run cannot continue."""


class ConfigError(ValueError):
    """The config cannot run: inconsistent values, or more memory than the device has.

    `train` raises it before writing anything.
    """


@dataclasses.dataclass(frozen=True)
class TrainResult:
    """What `train` returns.

    Attributes:
      policy: the final deterministic policy.
      state: the final training state (on device).
      metrics: the last metrics row ({} when no evaluation ran).
      history: all metrics rows of the run, those before a resume included.
      env_steps: env steps taken so far, prefill included.
      run_dir: the run directory, or None.
      stopped_by_signal: name of the signal (SIGINT/SIGTERM) that stopped
        training early after writing a checkpoint, else None.
      chunk_traces: times the training chunk was traced in this call (1 unless
        something forces a recompile).
    """

    policy: policy_lib.Policy
    state: sac.TrainingState
    metrics: dict[str, Any]
    history: list[dict[str, Any]]
    env_steps: int
    run_dir: Path | None
    stopped_by_signal: str | None
    chunk_traces: int


def train(
    env: envs.Env,
    config: ml_collections.ConfigDict | None = None,
    run_dir: str | os.PathLike[str] | None = None,
    *,
    eval_env: envs.Env | None = None,
    resume: bool = False,
    progress: bool = True,
    progress_bar: bool = True,
    extra_run_info: dict[str, Any] | None = None,
) -> TrainResult:
    """Trains a SAC policy on `env`.

    Args:
      env: unbatched, unwrapped Brax env (wrapped here for training).
      config: trainer config (`quadcos.training.default_config()` when None).
      run_dir: directory for config, metrics, checkpoints and the final policy;
        None keeps everything in memory.
      eval_env: env for evaluation; `env` when None.
      resume: continue from the newest readable checkpoint in `run_dir` (a
        fresh run when there is none). `config.num_timesteps` may exceed that
        of the original run to extend it; other fields must keep the network,
        replay and env shapes.
      progress: report progress on stderr (a redrawn line on a terminal, one
        line per evaluation otherwise).
      progress_bar: False prints the one line per evaluation on a terminal too.
      extra_run_info: JSON-serialisable data stored in config.json under
        `run_info` (e.g. the env config).

    Returns:
      The final policy, state and metrics.

    Raises:
      ConfigError: invalid config, a training state (replay buffer, envs) larger than the
        device's memory, or (resuming) a checkpoint of other shapes; nothing was written.
      ValueError: `resume` without `run_dir`.
      FileExistsError: `run_dir` holds a run and `resume` is False.
      NonFiniteLossError: a loss became non-finite; the newest checkpoint is the
        last one before that chunk.
    """
    config = config_lib.default_config() if config is None else config
    check_config(config)
    if resume and run_dir is None:
        raise ValueError("resume=True needs a run_dir")
    trainer = sac.SACTrainer(env, config, eval_env=eval_env)
    _check_memory(trainer)
    spec = policy_lib.PolicySpec(
        observation_size=trainer.observation_size,
        action_size=trainer.action_size,
        hidden_sizes=tuple(int(size) for size in config.hidden_sizes.policy),
        normalize_observations=bool(config.normalize_observations),
    )
    run_info = _run_info(config, extra_run_info)
    state = trainer.init()
    wall_time_offset = 0.0
    store = None
    log = None
    if run_dir is not None:
        run_dir = Path(run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        store = checkpoint.CheckpointStore(run_dir / "checkpoints", keep=config.keep_checkpoints)
        keep_rows_up_to = None
        if resume:
            try:
                restored = store.restore_latest(state)
            except checkpoint.ShapeMismatchError as error:
                store.close()
                raise ConfigError(str(error)) from None
            if restored is None:
                logger.warning("no checkpoint in %s; starting a new run", store.directory)
            else:
                state = restored.state
                wall_time_offset = restored.meta["wall_time_s"]
                keep_rows_up_to = restored.step
                logger.info("resuming from %s", store.path(restored.step))
        elif store.steps() or (run_dir / "metrics.jsonl").exists():
            raise FileExistsError(
                f"{run_dir} already holds a run; pass resume=True or use another directory"
            )
        files.atomic_write_text(run_dir / "config.json", json.dumps(run_info, indent=2) + "\n")
        log = metrics_log.MetricsLog(run_dir, keep_rows_up_to)

    try:
        with _SignalStop() as stop:
            state, history = _train_loop(
                trainer,
                state,
                store,
                log,
                stop,
                _Clock(wall_time_offset),
                _Progress(config.num_timesteps, enabled=progress, bar=progress_bar),
            )
    finally:
        if log is not None:
            log.close()
        if store is not None:
            store.close()

    policy = policy_lib.Policy.from_training_state(state, spec, run_info)
    if run_dir is not None:
        policy_lib.save_policy(run_dir / "policy", policy)
    return TrainResult(
        policy=policy,
        state=state,
        metrics=history[-1] if history else {},
        history=history,
        env_steps=int(state.env_steps),
        run_dir=run_dir,
        stopped_by_signal=stop.signal_name,
        chunk_traces=trainer.chunk_traces,
    )


def _train_loop(
    trainer: sac.SACTrainer,
    state: sac.TrainingState,
    store: checkpoint.CheckpointStore | None,
    log: metrics_log.MetricsLog | None,
    stop: "_SignalStop",
    clock: "_Clock",
    progress: "_Progress",
) -> tuple[sac.TrainingState, list[dict[str, Any]]]:
    """Prefills if needed, then runs chunks until num_timesteps or a signal."""
    config = trainer.config
    history = list(log.rows) if log is not None else []

    def record(row: dict[str, Any]) -> None:
        history.append(row)
        if log is not None:
            log.append(row)
        progress.log_row(row)

    def evaluate(state: sac.TrainingState) -> dict[str, float]:
        metrics = trainer.evaluate(state.normalizer_params, state.policy_params)
        return {name: float(value) for name, value in jax.device_get(metrics).items()}

    step = int(state.env_steps)
    if step == 0:
        record({"step": 0, "wall_time_s": clock(), **evaluate(state)})
    # Not when resuming a finished run (e.g. killed before its policy was saved): nothing to train.
    prefill = int(state.replay.size) < config.min_replay_size and step < config.num_timesteps
    _log_final_step(config, step + prefill * trainer.num_prefill_steps * config.num_envs)
    if prefill:
        state = trainer.prefill(state)
        step = int(state.env_steps)

    window = _Window()
    try:
        while step < config.num_timesteps:
            start = time.monotonic()
            state, chunk_metrics = trainer.train_chunk(state)
            chunk_metrics = jax.device_get(chunk_metrics)
            chunk_seconds = time.monotonic() - start
            previous_step, step = step, int(state.env_steps)
            window.add(chunk_metrics, step - previous_step, chunk_seconds)
            _raise_if_non_finite(chunk_metrics, step, store)

            # Read once: a signal arriving later is served after the next chunk.
            stopping = stop.signal_name is not None
            finished = step >= config.num_timesteps
            if finished or _crossed(previous_step, step, config.eval_interval):
                record(
                    {
                        "step": step,
                        "wall_time_s": clock(),
                        "env_steps_per_s": window.steps_per_second(),
                        **window.means(),
                        "train/nan_resets": int(state.nan_resets),
                        "train/gradient_steps": int(state.gradient_steps),
                        "train/replay_size": int(state.replay.size),
                        **evaluate(state),
                    }
                )
                window = _Window()
            if store is not None and (
                finished or stopping or _crossed(previous_step, step, config.checkpoint_interval)
            ):
                store.save(step, state, {"wall_time_s": clock()}, config.save_replay)
            progress.update(step, (step - previous_step) / chunk_seconds, history)
            if stopping:
                logger.warning(
                    "stopped by %s at env step %d after writing a checkpoint",
                    stop.signal_name,
                    step,
                )
                break
    finally:
        progress.close()
    return state, history


def _log_final_step(config: ml_collections.ConfigDict, first_chunk_step: int) -> None:
    """Says where training will end when whole chunks overshoot `num_timesteps`."""
    chunk = config.num_envs * config.steps_per_chunk
    chunks = max(-(-(config.num_timesteps - first_chunk_step) // chunk), 0)
    final_step = first_chunk_step + chunks * chunk
    if final_step != config.num_timesteps:
        logger.info(
            "training ends at env step %s, not num_timesteps=%s: from env step %s on it takes"
            " whole chunks of %s env steps (num_envs %d x steps_per_chunk %d)",
            f"{final_step:,}",
            f"{config.num_timesteps:,}",
            f"{first_chunk_step:,}",
            f"{chunk:,}",
            config.num_envs,
            config.steps_per_chunk,
        )


def _crossed(previous_step: int, step: int, interval: int) -> bool:
    return step // interval > previous_step // interval


def _raise_if_non_finite(
    chunk_metrics: dict[str, Any],
    step: int,
    store: checkpoint.CheckpointStore | None,
) -> None:
    bad = {
        name: float(chunk_metrics[name])
        for name in _LOSSES
        if not math.isfinite(float(chunk_metrics[name]))
    }
    if not bad:
        return
    if store is not None and store.steps():
        kept = f"the last good checkpoint is {store.path(store.steps()[-1])}"
    else:
        kept = "no checkpoint was written"
    raise NonFiniteLossError(
        f"non-finite SAC loss in the chunk ending at env step {step}: {bad};"
        f" training stopped, {kept}"
    )


def check_config(config: ml_collections.ConfigDict) -> None:
    """Raises ConfigError naming the first inconsistent or unknown field of a trainer config."""
    try:
        _check_config(config)
        for name in _SHAPES:
            if config[name] >= 2**31:
                raise ValueError(f"config.{name} must be < 2**31, got {config[name]}")
        for kind in ("policy", "q"):
            sizes = config.hidden_sizes[kind]
            if not all(isinstance(size, int) and 1 <= size < 2**31 for size in sizes):
                raise ValueError(
                    f"config.hidden_sizes.{kind} must be layer widths >= 1, got {sizes}"
                )
        if not -(2**63) <= config.seed < 2**63:
            raise ValueError(f"config.seed must fit in 64 bits, got {config.seed}")
        if not (0 <= config.discount <= 1 and 0 < config.tau <= 1):
            raise ValueError(
                f"config.discount must be in [0, 1] and config.tau in (0, 1], got"
                f" {config.discount} and {config.tau}"
            )
        rates = {f"learning_rate.{name}": rate for name, rate in config.learning_rate.items()}
        for name, value in (("init_alpha", config.init_alpha), *rates.items()):
            if not value > 0:
                raise ValueError(f"config.{name} must be > 0, got {value}")
    except ValueError as error:
        raise ConfigError(str(error)) from None


def _check_memory(trainer: sac.SACTrainer) -> None:
    """Raises ConfigError when the training state would not fit in the device's memory.

    The estimate counts what stays allocated: the training state (replay buffer and training
    envs included) and the evaluation envs' states; not the temporaries of a step.
    """
    config = trainer.config
    state = jax.eval_shape(trainer.init)
    replay_bytes = _nbytes(state.replay)
    env_bytes = _nbytes(state.env_state) * (1 + config.num_eval_envs / config.num_envs)
    total = _nbytes(state) - _nbytes(state.env_state) + env_bytes
    device = jax.devices()[0]
    capacity = _memory_bytes(device)
    if total > capacity:
        raise ConfigError(
            f"the run needs about {total / 1e9:.3g} GB (replay buffer of {config.replay_size}"
            f" transitions: {replay_bytes / 1e9:.3g} GB; {config.num_envs} training and"
            f" {config.num_eval_envs} evaluation envs: {env_bytes / 1e9:.3g} GB) but the"
            f" {device.platform} device has {capacity / 1e9:.3g} GB;"
            " lower config.replay_size or config.num_envs"
        )


def _nbytes(tree: Any) -> int:
    return sum(math.prod(leaf.shape) * leaf.dtype.itemsize for leaf in jax.tree.leaves(tree))


def _memory_bytes(device: jax.Device) -> int:
    """Memory of an accelerator (its allocator's limit), or of the host for the CPU."""
    stats = device.memory_stats() if device.platform != "cpu" else None
    if stats and "bytes_limit" in stats:
        return stats["bytes_limit"]
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def _check_config(config: ml_collections.ConfigDict) -> None:
    """Raises ValueError naming the first inconsistent or unknown field."""
    expected = _flat_keys(config_lib.default_config())
    given = _flat_keys(config)
    if unknown := sorted(given - expected):
        raise ValueError(f"unknown config keys: {unknown}")
    if missing := sorted(expected - given):
        raise ValueError(f"missing config keys: {missing}")
    positive = (
        "num_envs",
        "num_timesteps",
        "episode_length",
        "batch_size",
        "updates_per_step",
        "replay_size",
        "steps_per_chunk",
        "eval_interval",
        "num_eval_envs",
        "eval_episode_length",
        "checkpoint_interval",
        "keep_checkpoints",
    )
    for name in positive:
        if config[name] < 1:
            raise ValueError(f"config.{name} must be >= 1, got {config[name]}")
    if config.actor_warmup_steps < 0:
        raise ValueError(f"config.actor_warmup_steps must be >= 0, got {config.actor_warmup_steps}")
    if config.replay_size < config.num_envs:
        raise ValueError(
            f"config.replay_size ({config.replay_size}) must hold one step of all"
            f" envs (num_envs = {config.num_envs})"
        )
    if not 0 <= config.min_replay_size <= config.replay_size:
        raise ValueError(
            f"config.min_replay_size ({config.min_replay_size}) must be in"
            f" [0, replay_size = {config.replay_size}]"
        )
    if config.prefill_actions not in sac.PREFILL_ACTIONS:
        raise ValueError(
            f"config.prefill_actions must be one of {sac.PREFILL_ACTIONS}, got {config.prefill_actions!r}"
        )
    if config.init_std is not None and not config.init_std > sac.MIN_STD:
        raise ValueError(f"config.init_std must be > {sac.MIN_STD}, got {config.init_std}")
    prefill_steps = -(-config.min_replay_size // config.num_envs) * config.num_envs
    if prefill_steps >= config.num_timesteps:
        raise ValueError(
            f"no training would happen: the prefill of min_replay_size"
            f" ({config.min_replay_size}) takes {prefill_steps} env steps >="
            f" num_timesteps ({config.num_timesteps})"
        )


def _flat_keys(config: ml_collections.ConfigDict, prefix: str = "") -> set[str]:
    keys = set()
    for name, value in config.items():
        if isinstance(value, ml_collections.ConfigDict):
            keys |= _flat_keys(value, f"{prefix}{name}.")
        else:
            keys.add(prefix + name)
    return keys


def _run_info(
    config: ml_collections.ConfigDict, extra_run_info: dict[str, Any] | None
) -> dict[str, Any]:
    versions = {}
    for package in _VERSIONED_PACKAGES:
        try:
            versions[package] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            pass
    return {
        "config": json.loads(json.dumps(config.to_dict())),
        "versions": versions,
        "git_revision": _git_revision(),
        "run_info": extra_run_info or {},
    }


def _git_revision() -> str | None:
    """HEAD of the repository holding this package, '+dirty' if modified."""
    try:
        revision = _git("rev-parse", "HEAD")
        status = _git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    return revision + ("+dirty" if status else "")


def _git(*args: str) -> str:
    return subprocess.run(
        ["git", *args],
        cwd=Path(__file__).parent,
        capture_output=True,
        text=True,
        timeout=10,
        check=True,
    ).stdout.strip()


class _Window:
    """Chunk metrics and training time since the last metrics row."""

    def __init__(self):
        self._sums: dict[str, float] = {}
        self._chunks = 0
        self._steps = 0
        self._seconds = 0.0

    def add(self, chunk_metrics: dict[str, Any], steps: int, seconds: float):
        for name, value in chunk_metrics.items():
            self._sums[name] = self._sums.get(name, 0.0) + float(value)
        self._chunks += 1
        self._steps += steps
        self._seconds += seconds

    def means(self) -> dict[str, float]:
        return {f"train/{name}": total / self._chunks for name, total in self._sums.items()}

    def steps_per_second(self) -> float:
        return self._steps / self._seconds if self._seconds > 0 else 0.0


class _Clock:
    """Wall time of the run in seconds, continued across resumes."""

    def __init__(self, offset: float):
        self._start = time.monotonic() - offset

    def __call__(self) -> float:
        return time.monotonic() - self._start


class _SignalStop:
    """Turns SIGINT/SIGTERM into a request to stop after the current chunk.

    A second SIGINT raises KeyboardInterrupt at once. Handlers can only be
    installed from the main thread; elsewhere signals keep their handlers.
    """

    def __init__(self):
        self.signal_name: str | None = None
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> "_SignalStop":
        if threading.current_thread() is threading.main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc_info) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)

    def _handle(self, signum: int, frame: Any) -> None:
        del frame
        if self.signal_name is not None and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self.signal_name = signal.Signals(signum).name
        logger.warning(
            "%s received: stopping after the current chunk (SIGINT again aborts)",
            self.signal_name,
        )


class _Progress:
    """One redrawn status line on a terminal, one line per row otherwise."""

    _REDRAW_SECONDS = 0.2

    def __init__(
        self, total_steps: int, enabled: bool, bar: bool = True, stream: TextIO | None = None
    ):
        self._total = total_steps
        self._stream = sys.stderr if stream is None else stream
        self._enabled = enabled
        self._tty = enabled and bar and self._stream.isatty()
        self._last_redraw = -math.inf

    def update(self, step: int, steps_per_second: float, history: list[dict[str, Any]]) -> None:
        now = time.monotonic()
        if not self._tty or now - self._last_redraw < self._REDRAW_SECONDS:
            return
        self._last_redraw = now
        fraction = min(step / self._total, 1.0)
        bar = "#" * int(24 * fraction)
        self._stream.write(
            f"\r[{bar:<24}] {step:,}/{self._total:,} env steps"
            f"  {steps_per_second:,.0f}/s"
            f"  eval reward {_last_reward(history)}"
            f"  ETA {_eta(step, self._total, steps_per_second)}\033[K"
        )
        self._stream.flush()

    def log_row(self, row: dict[str, Any]) -> None:
        if not self._enabled or self._tty:
            return
        steps_per_second = row.get("env_steps_per_s", 0.0)
        # Env metrics that a generic Brax env may not log.
        extras = "".join(
            f"  {label} {row[key]:.3g}{unit}"
            for key, label, unit in (
                ("eval/forward_speed", "speed", " m/s"),
                ("eval/fall_rate", "fall rate", ""),
            )
            if key in row
        )
        self._stream.write(
            f"step {row['step']:,}/{self._total:,}"
            f"  {steps_per_second:,.0f} env steps/s"
            f"  eval reward {_last_reward([row])}{extras}"
            f"  ETA {_eta(row['step'], self._total, steps_per_second)}\n"
        )
        self._stream.flush()

    def close(self) -> None:
        if self._tty:
            self._stream.write("\n")
            self._stream.flush()


def _last_reward(history: list[dict[str, Any]]) -> str:
    if not history:
        return "-"
    return f"{history[-1]['eval/episode_reward']:.4g}"


def _eta(step: int, total: int, steps_per_second: float) -> str:
    if steps_per_second <= 0:
        return "-"
    seconds = int(max(total - step, 0) / steps_per_second)
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"
