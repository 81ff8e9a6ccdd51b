"""A run directory as a run opens it: its checkpoints (the newest restored on resume), its
config.json, metrics log and best policy."""

import dataclasses
import json
import logging
from pathlib import Path
from typing import Any

import ml_collections

from quadcos._util import files
from quadcos.training import best_policy, checkpoint, host, metrics_log, parallel, sac
from quadcos.training import policy as policy_lib
from quadcos.training.checks import ConfigError

logger = logging.getLogger(__name__)


@dataclasses.dataclass
class RunFiles:
    """A run's state to start from and the files it writes to (None: in memory)."""

    state: sac.TrainingState
    store: checkpoint.CheckpointStore | None = None
    log: metrics_log.MetricsLog | None = None
    wall_time_offset: float | None = None  # the restored checkpoint's wall time, s
    best: best_policy.BestPolicy | None = None

    def close(self) -> None:
        if self.log is not None:
            self.log.close()
        if self.store is not None:
            self.store.close()


def open_run_dir(
    run_dir: Path,
    config: ml_collections.ConfigDict,
    state: sac.TrainingState,
    resume: bool,
    run_info: dict[str, Any],
    spec: policy_lib.PolicySpec,
    startup: host.StartUp,
    given: bool = False,
) -> RunFiles:
    """Opens `run_dir`'s checkpoints (restoring the newest when resuming; where `state` is
    `given`, a run's second phase, going on from it as from a restored one) and, in the writing
    process, writes config.json and opens the metrics log and `policy_best`."""
    run_dir.mkdir(parents=True, exist_ok=True)
    store = checkpoint.CheckpointStore(run_dir / "checkpoints", keep=config.keep_checkpoints)
    run = RunFiles(state=state, store=store)
    keep_rows_up_to = None
    # Over several processes (hosts) only process 0 writes config, metrics and policy; the
    # checkpoints are orbax's, written together (each process its shards of the envs).
    writer = parallel.is_writer()
    if given:  # the same process's run, its clock going on from its start
        keep_rows_up_to = int(state.env_steps)
    elif resume:
        try:
            restored = store.restore_latest(state)
        except checkpoint.ShapeMismatchError as error:
            store.close()
            raise ConfigError(str(error)) from None
        if restored is None:
            logger.warning("no checkpoint in %s; starting a new run", store.directory)
        else:
            run.state = restored.state
            run.wall_time_offset = restored.meta["wall_time_s"]
            keep_rows_up_to = restored.step
            logger.info("resuming from %s", store.path(restored.step))
    elif store.steps() or (writer and (run_dir / "metrics.jsonl").exists()):
        store.close()
        raise FileExistsError(
            f"{run_dir} already holds a run; pass resume=True or use another directory"
        )
    if writer:
        files.atomic_write_text(run_dir / "config.json", json.dumps(run_info, indent=2) + "\n")
        if not given:  # (a second phase's start-up is not the run's)
            startup.path = run_dir / host.StartUp.FILE
        run.log = metrics_log.MetricsLog(run_dir, keep_rows_up_to)
        if config.keep_best_policy:
            run.best = best_policy.BestPolicy(
                run_dir / "policy_best",
                spec,
                run_info,
                run.log.rows,
                config.best_policy_max_fall_rate,
                config.best_policy_by,
                tuple(config.best_policy_tracking_targets),
                config.best_policy_max_attitude,
            )
    return run


def policy_spec(trainer: sac.SACTrainer) -> policy_lib.PolicySpec:
    """The shapes of the trainer's policy network, as a saved policy records them."""
    return policy_lib.PolicySpec(
        observation_size=trainer.observation_size,
        action_size=trainer.action_size,
        hidden_sizes=tuple(int(size) for size in trainer.config.hidden_sizes.policy),
        normalize_observations=bool(trainer.config.normalize_observations),
    )
