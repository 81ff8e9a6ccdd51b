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
import json
import logging
import math
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax
import ml_collections
from brax import envs

from quadcos._util import provenance
from quadcos.env import warp_preload
from quadcos.training import best_policy, checkpoint, host, metrics_log, parallel, run_files, sac
from quadcos.training import config as config_lib
from quadcos.training import policy as policy_lib
from quadcos.training.checks import check_config, check_memory, check_tracked
from quadcos.training.phases import ends_at_switch, trainer_until

logger = logging.getLogger(__name__)

_LOSSES = ("critic_loss", "actor_loss", "alpha_loss", "alpha")
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
      trainer: the trainer, with its compiled programs (for a later run of the same programs).
    """

    policy: policy_lib.Policy
    state: sac.TrainingState
    metrics: dict[str, Any]
    history: list[dict[str, Any]]
    env_steps: int
    run_dir: Path | None
    stopped_by_signal: str | None
    chunk_traces: int
    trainer: sac.SACTrainer


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
    started_at: float | None = None,
    startup: host.StartUp | None = None,
    trainer: sac.SACTrainer | None = None,
    state: sac.TrainingState | None = None,
    until: int | None = None,
) -> TrainResult:
    """Trains a SAC policy on `env`.

    Args:
      env: unbatched, unwrapped Brax env (wrapped here for training).
      config: trainer config (`quadcos.training.default_config()` when None).
      run_dir: directory for config, metrics, checkpoints and the final policy; None keeps
        everything in memory.
      eval_env: env for evaluation; `env` when None.
      resume: continue from the newest readable checkpoint in `run_dir` (a fresh run when there
        is none). `config.num_timesteps` may exceed that of the original run to extend it; other
        fields must keep the network, replay and env shapes.
      progress: report progress on stderr (a redrawn line on a terminal, one line per
        evaluation otherwise).
      progress_bar: False prints the one line per evaluation on a terminal too.
      extra_run_info: JSON-serialisable data stored in config.json under `run_info`.
      started_at: `time.monotonic()` at the run's start (quadcos.train: the process's start, so
        a from-scratch run's gait search and every compilation count); None: this call.
      startup: the start-up times so far (quadcos.train: imports, gait search, env), counted
        from `started_at`; this call adds the trainer, its initial state, the run directory, the
        programs traced, the prefill, the first chunk and the first evaluation (`run_chunks`),
        and writes them to `run_dir/startup.json`.
      trainer: the `SACTrainer` of `env`, `eval_env` and `config`, already built (by an
        earlier run of the same programs: `quadcos.training.reuse`); None builds one.
      state, until: a second phase's start, its first's state (`run_dir` continued as on
        `resume`); a first phase's end, an env step (`quadcos.training.phases`). None: as usual.

    Returns:
      The final policy, state and metrics.

    Raises:
      ConfigError: invalid config (a tracking rank without commands too), a training state
        larger than the device's memory, or (resuming) a checkpoint of other shapes; no files.
      ValueError: `resume` without `run_dir`.
      FileExistsError: `run_dir` holds a run and `resume` is False.
      NonFiniteLossError: a loss became non-finite; the newest checkpoint is the last before it.
    """
    config = config_lib.default_config() if config is None else config
    check_config(config)
    check_tracked(config, eval_env or env)
    if resume and run_dir is None:
        raise ValueError("resume=True needs a run_dir")
    startup = host.StartUp(started_at) if startup is None else startup
    if trainer is None:
        trainer = sac.SACTrainer(env, config, eval_env=eval_env)
    startup.mark("trainer_built")
    trainer = trainer_until(trainer, until)
    check_memory(trainer)
    spec = run_files.policy_spec(trainer)
    run_info = _run_info(config, extra_run_info)
    given = state is not None
    state = state if given else _initial_state(trainer, resume, startup)
    run = run_files.RunFiles(state=state)
    if run_dir is not None:
        run_dir = Path(run_dir)
        run = run_files.open_run_dir(run_dir, config, state, resume, run_info, spec, startup, given)
    startup.mark("run_dir_ready")
    writer = parallel.is_writer()  # of several processes (hosts), only process 0 writes files
    deadline = host.deadline(config.max_seconds, started_at)
    meter = host.Progress(config.num_timesteps, progress and writer, progress_bar, None, deadline)
    try:
        with host.SignalStop() as stop:
            state, history = _train_loop(
                trainer, run.state, run.store, run.log, stop,
                host.Clock(host.run_age(run.wall_time_offset, started_at)),
                meter, run.best, deadline, startup,
            )
    finally:
        run.close()

    env_steps = {"env_steps": int(state.env_steps)}  # read by evaluation.PolicySpec.env_steps
    policy = policy_lib.Policy.from_training_state(state, spec, run_info | env_steps)
    if run_dir is not None and writer:
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
        trainer=trainer,
    )


def _initial_state(
    trainer: sac.SACTrainer, resume: bool, startup: host.StartUp
) -> sac.TrainingState:
    """The trainer's initial state (a resumed run's template), a fresh run's programs compiled
    first (while Warp's modules do: `warp_preload.deferred`, quadcos.train)."""
    config = trainer.config
    if not resume and config.num_timesteps > 0 and trainer.layout.mesh is None:
        trainer.compile_ahead(trainer.state_shapes, prefill=config.min_replay_size > 0)
        startup.mark("programs_traced")
    warp_preload.wait()  # before the first Warp launch
    state = jax.block_until_ready(trainer.init())
    startup.mark("state_initialised")
    return state


@dataclasses.dataclass(frozen=True)
class Chunk:
    """One compiled chunk, as the host loop sees it.

    Attributes:
      metrics: the chunk's metrics (host values, averaged over the chunk; `SACTrainer.train_chunk`).
      previous_step, step: env steps before and after the chunk.
      seconds: wall time of the chunk, its transfer to the host included.
    """

    metrics: dict[str, Any]
    previous_step: int
    step: int
    seconds: float


def run_chunks(
    trainer: sac.SACTrainer,
    state: sac.TrainingState,
    *,
    on_start: Callable[[sac.TrainingState], Callable[[], None] | None],
    on_chunk: Callable[[sac.TrainingState, Chunk], bool],
    num_timesteps: int | None,
    startup: host.StartUp | None = None,
) -> sac.TrainingState:
    """The host loop of training (of `train`, and of the bench's time to walk).

    Calls `on_start` on a state that has not taken a step (the untrained policy), prefills the
    replay buffer if it holds less than `min_replay_size`, then runs compiled chunks until
    `num_timesteps` env steps (None: no limit) or until `on_chunk` returns True. What `on_start`
    returns (e.g. the untrained policy's evaluation, from a copy) is called once the first chunk
    is done: training does not wait for it. The programs compile at once (`compile_ahead`).
    `startup` (optional) is marked at each of these steps and saved after the first chunk.
    """
    startup = host.StartUp() if startup is None else startup
    step = int(state.env_steps)
    # Not when resuming a finished run (e.g. killed before its policy was saved): nothing to train.
    unfinished = num_timesteps is None or step < num_timesteps
    prefill = trainer.replay_size(state) < trainer.config.min_replay_size and unfinished
    if unfinished and trainer.compile_ahead(state, prefill=prefill):  # (none: compiled ahead)
        startup.mark("programs_traced")
    finish_start = on_start(state) if step == 0 else None
    if num_timesteps is not None:
        first_chunk_step = step + prefill * trainer.num_prefill_steps * trainer.config.num_envs
        if not ends_at_switch(trainer.config):  # (a first phase's: its second says)
            _log_final_step(trainer.config, num_timesteps, first_chunk_step)
        _log_actor_start(trainer.config, int(state.gradient_steps), first_chunk_step)
    if prefill:
        state = trainer.prefill(state)
        step += trainer.num_prefill_steps * trainer.config.num_envs
        startup.mark("prefill_dispatched")
    while num_timesteps is None or step < num_timesteps:
        start = time.monotonic()
        state, chunk_metrics = trainer.train_chunk(state)
        chunk_metrics = jax.device_get(chunk_metrics)
        seconds = time.monotonic() - start
        if "first_chunk" not in startup.seconds:
            startup.mark("first_chunk")
            if finish_start is not None:
                finish_start()
                finish_start = None
                startup.mark("first_evaluation")
            startup.save()
        chunk = Chunk(chunk_metrics, step, int(state.env_steps), seconds)
        step = chunk.step
        if on_chunk(state, chunk):
            break
    if finish_start is not None:  # no chunk ran (e.g. num_timesteps=0)
        finish_start()
    return state


def _log_final_step(
    config: ml_collections.ConfigDict, num_timesteps: int, first_chunk_step: int
) -> None:
    """Says where training will end when whole chunks overshoot `num_timesteps`."""
    chunk = config.num_envs * config.steps_per_chunk
    chunks = max(-(-(num_timesteps - first_chunk_step) // chunk), 0)
    final_step = first_chunk_step + chunks * chunk
    if final_step != num_timesteps:
        logger.info(
            "training ends at env step %s, not num_timesteps=%s: from env step %s on it takes"
            " whole chunks of %s env steps (num_envs %d x steps_per_chunk %d)",
            f"{final_step:,}",
            f"{num_timesteps:,}",
            f"{first_chunk_step:,}",
            f"{chunk:,}",
            config.num_envs,
            config.steps_per_chunk,
        )


def _log_actor_start(
    config: ml_collections.ConfigDict, gradient_steps: int, first_chunk_step: int
) -> None:
    """Says from which env step SAC's actor learns, where its critic-only warm-up is still ahead."""
    start = host.actor_start_step(config, gradient_steps, first_chunk_step)
    if start is not None:
        left = config.actor_warmup_steps - gradient_steps
        logger.info(
            "the actor learns from env step %s on: the critics alone take %s updates first"
            " (sac.actor_warmup_steps, %d per step of the %d envs)",
            f"{start:,}",
            f"{left:,}",
            config.updates_per_step,
            config.num_envs,
        )


def actor_has_learned(config: ml_collections.ConfigDict, gradient_steps: int) -> bool:
    """Whether any of `gradient_steps` updates taught the actor: the first after the critics'
    `actor_warmup_steps` alone does (quadcos.training.updates)."""
    return gradient_steps > config.actor_warmup_steps


def _log_the_end(
    config: ml_collections.ConfigDict, step: int, gradient_steps: int, out_of_time: bool
) -> None:
    """Says why training ended at `step` where its time budget ended it, and warns where it
    ended inside the critics' warm-up, before the actor learned."""
    if out_of_time:
        logger.info("time budget of %g s spent at env step %s", config.max_seconds, f"{step:,}")
    second_follows = ends_at_switch(config) and not out_of_time
    if not actor_has_learned(config, gradient_steps) and not second_follows:
        logger.warning(
            "the actor never learned: the run ended at env step %s after %s of the critics' %s"
            " warm-up updates (sac.actor_warmup_steps), so every policy it wrote holds the"
            " actor's initial weights (under the observation statistics of its data); give it"
            " more env steps or time, or fewer warm-up updates",
            f"{step:,}",
            f"{gradient_steps:,}",
            f"{config.actor_warmup_steps:,}",
        )


def _train_loop(
    trainer: sac.SACTrainer,
    state: sac.TrainingState,
    store: checkpoint.CheckpointStore | None,
    log: metrics_log.MetricsLog | None,
    stop: host.SignalStop,
    clock: host.Clock,
    progress: host.Progress,
    best: best_policy.BestPolicy | None = None,
    deadline: float | None = None,
    startup: host.StartUp | None = None,
) -> tuple[sac.TrainingState, list[dict[str, Any]]]:
    """Prefills if needed, then runs chunks until num_timesteps, the `deadline`
    (`time.monotonic()`) or a signal."""
    config = trainer.config
    history = list(log.rows) if log is not None else []
    window, warm_up = host.Window(), host.WarmUpWatch(config, deadline)

    # The last evaluation's wall time with its row and `policy_best` written (the first one's
    # includes compiling), and the last checkpoint's: what the time budget keeps room for.
    evaluation_s = save_s = 0.0

    def record(row: dict[str, Any], state: sac.TrainingState | policy_lib.PolicyPart) -> None:
        history.append(row)
        if log is not None:
            log.append(row)
        progress.log_row(row)
        if best is not None and best.offer(state, row, written_at_s=clock()):
            logger.info("best evaluation so far (%s): saved to %s", best.describe(), best.directory)

    def record_evaluation(
        row: dict[str, Any], state: sac.TrainingState | policy_lib.PolicyPart
    ) -> None:
        nonlocal evaluation_s
        started = time.monotonic()
        metrics = trainer.evaluate(state.normalizer_params, state.policy_params)
        record({**row, **_host_floats(metrics)}, state)
        evaluation_s = time.monotonic() - started

    def save(step: int, state: sac.TrainingState) -> None:
        nonlocal save_s
        started = time.monotonic()
        store.save(step, state, {"wall_time_s": clock()}, config.save_replay)
        save_s = time.monotonic() - started

    def on_start(state: sac.TrainingState) -> Callable[[], None]:
        # Evaluated once the first chunk is done, from a copy (the prefill is donated the state).
        row = {"step": 0, "wall_time_s": clock()}
        policy = policy_lib.PolicyPart.copy_of(state)
        return lambda: record_evaluation(row, policy)

    def on_chunk(state: sac.TrainingState, chunk: Chunk) -> bool:
        nonlocal window
        warm_up.after_chunk(chunk.step, lambda: int(state.gradient_steps))
        previous_step, step = chunk.previous_step, chunk.step
        window.add(chunk.metrics, step - previous_step, chunk.seconds)
        _raise_if_non_finite(chunk.metrics, step, store)

        # Read once: a signal arriving later is served after the next chunk.
        stopping = stop.signal_name is not None
        evaluating = _crossed(previous_step, step, config.eval_interval)
        saving = store is not None and _crossed(previous_step, step, config.checkpoint_interval)
        out_of_time = host.budget_spent(
            deadline,
            time.monotonic(),
            chunk_s=chunk.seconds,
            evaluation_s=evaluation_s,
            save_s=save_s,
            evaluating_now=evaluating,
            saving_now=saving,
        )
        finished = step >= config.num_timesteps or out_of_time
        if finished:
            _log_the_end(config, step, int(state.gradient_steps), out_of_time)
        if finished or evaluating:
            record_evaluation(_training_row(trainer, state, step, clock(), window), state)
            window = host.Window()
        if store is not None and (finished or stopping or saving):
            save(step, state)
        progress.update(step, (step - previous_step) / chunk.seconds, history)
        if stopping:
            logger.warning(
                "stopped by %s at env step %s after writing a checkpoint",
                stop.signal_name,
                f"{step:,}",
            )
        return stopping or out_of_time

    try:
        state = run_chunks(
            trainer,
            state,
            on_start=on_start,
            on_chunk=on_chunk,
            num_timesteps=config.num_timesteps,
            startup=startup,
        )
    finally:
        progress.close()
    return state, history


def _training_row(
    trainer: sac.SACTrainer,
    state: sac.TrainingState,
    step: int,
    wall_time_s: float,
    window: host.Window,
) -> dict[str, Any]:
    """A metrics row's training part: the chunks since the last row, and the state's counters."""
    return {
        "step": step,
        "wall_time_s": wall_time_s,
        "env_steps_per_s": window.steps_per_second(),
        **window.means(),
        "train/nan_resets": int(state.nan_resets),
        "train/gradient_steps": int(state.gradient_steps),
        "train/replay_size": trainer.replay_size(state),
    }


def _host_floats(metrics: dict[str, jax.Array]) -> dict[str, float]:
    """An evaluation's metrics on the host (waits for the evaluation)."""
    return {name: float(value) for name, value in jax.device_get(metrics).items()}


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


def _run_info(
    config: ml_collections.ConfigDict, extra_run_info: dict[str, Any] | None
) -> dict[str, Any]:
    return {
        "config": json.loads(json.dumps(config.to_dict())),
        "versions": provenance.versions(_VERSIONED_PACKAGES),
        "git_revision": provenance.git_revision(),
        "run_info": extra_run_info or {},
    }
