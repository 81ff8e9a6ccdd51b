"""Orbax checkpoints of the full training state, with fallback on corruption."""

import contextlib
import dataclasses
import gc
import logging
import os
import shutil
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import jax

from quadcos.training import replay as replay_lib
from quadcos.training.sac import TrainingState

logger = logging.getLogger(__name__)


class ShapeMismatchError(ValueError):
    """A readable checkpoint holds arrays of other shapes than the state to restore into (a
    resume with other sizes: envs, replay, networks, observations)."""


@dataclasses.dataclass(frozen=True)
class Restored:
    """A checkpoint read back: the state, its env step and its metadata."""

    state: TrainingState
    step: int
    meta: dict[str, Any]


def _orbax() -> Any:
    """orbax.checkpoint, imported when a run first opens its checkpoints rather than at start-up
    (0.8 s of `quadcos.train`'s 9-s import on two CPU cores)."""
    import orbax.checkpoint as ocp

    return ocp


def _as_tree(state: TrainingState, include_replay: bool) -> dict[str, Any]:
    fields = (field.name for field in dataclasses.fields(state))
    return {name: getattr(state, name) for name in fields if include_replay or name != "replay"}


def _stored_leaves(tree: Any) -> list[Any]:
    """The leaves orbax stores: all but the empty ones (mjx.Data has zero-size
    fields, which orbax refuses to save); `_refill` puts them back."""
    return [leaf for leaf in jax.tree.leaves(tree) if leaf.size]


def _refill(template: Any, stored: list[Any]) -> Any:
    leaves, treedef = jax.tree.flatten(template)
    stored_iter = iter(stored)
    return jax.tree.unflatten(
        treedef, [next(stored_iter) if leaf.size else leaf for leaf in leaves]
    )


class CheckpointStore:
    """One orbax checkpoint per saved env step under `directory`.

    Orbax writes each checkpoint into a temporary directory and renames it when
    complete, so an interrupted save never looks like a checkpoint. A
    checkpoint that exists but cannot be read back is moved to
    `<directory>_corrupt/<step>` (so a later save of that step does not clash)
    and the previous one is used. One that is readable but of other shapes is
    left alone: `restore_latest` raises ShapeMismatchError.
    """

    def __init__(self, directory: str | os.PathLike[str], keep: int):
        """Opens (creating at the first save) `directory`, keeping the newest `keep`."""
        self.directory = Path(directory).absolute()
        self._keep = keep
        self._opened = None  # orbax's manager: made when first needed (a new run: its first save)

    @property
    def _manager(self) -> Any:
        if self._opened is None:
            ocp = _orbax()
            # Opening reads each checkpoint's metadata; a damaged one is reported on restore.
            with _failed_reads_quiet():
                self._opened = ocp.CheckpointManager(
                    self.directory,
                    options=ocp.CheckpointManagerOptions(
                        max_to_keep=self._keep, create=True, enable_async_checkpointing=False
                    ),
                    # Handlers named up front, so that item_metadata reads a checkpoint's shapes
                    # before anything was saved or restored through this manager.
                    item_handlers={
                        "state": ocp.StandardCheckpointHandler(),
                        "meta": ocp.JsonCheckpointHandler(),
                    },
                )
        return self._opened

    def steps(self) -> list[int]:
        """Env steps of the checkpoints on disk, oldest first."""
        if self._opened is None and not (self.directory.is_dir() and any(self.directory.iterdir())):
            return []  # a new run: nothing to read, orbax not needed yet
        return sorted(self._manager.all_steps())

    def path(self, step: int) -> Path:
        return self.directory / str(step)

    def save(
        self,
        step: int,
        state: TrainingState,
        meta: dict[str, Any],
        include_replay: bool,
    ) -> Path:
        """Writes `state` (without its replay buffer unless `include_replay`)."""
        meta = {**meta, "step": step, "include_replay": include_replay}
        ocp = _orbax()
        self._manager.save(
            step,
            args=ocp.args.Composite(
                state=ocp.args.StandardSave(_stored_leaves(_as_tree(state, include_replay))),
                meta=ocp.args.JsonSave(meta),
            ),
        )
        return self.path(step)

    def restore_latest(self, template: TrainingState) -> Restored | None:
        """Restores the newest readable checkpoint, or None when there is none.

        Args:
          template: a state with the right structure, shapes and dtypes (e.g. a
            fresh initial state); it supplies the replay buffer when the
            checkpoint was saved without one.

        Raises:
          ShapeMismatchError: the newest readable checkpoint does not fit `template`.
        """
        with _failed_reads_quiet():
            return self._restore_latest(template)

    def _restore_latest(self, template: TrainingState) -> Restored | None:
        ocp = _orbax()
        for step in reversed(self.steps()):
            try:
                meta = self._manager.restore(
                    step, args=ocp.args.Composite(meta=ocp.args.JsonRestore())
                ).meta
                template_tree = _as_tree(template, meta["include_replay"])
                abstract = [
                    ocp.utils.to_shape_dtype_struct(leaf) for leaf in _stored_leaves(template_tree)
                ]
                stored_shapes = [
                    tuple(leaf.shape) for leaf in self._manager.item_metadata(step)["state"]
                ]
                replay_slots = _saved_replay_layout(stored_shapes, template_tree, abstract)
                self._check_shapes(step, stored_shapes, abstract)
                stored = self._manager.restore(
                    step,
                    args=ocp.args.Composite(state=ocp.args.StandardRestore(abstract)),
                ).state
                restored = _refill(template_tree, list(stored))
                if replay_slots:
                    restored["replay"] = _relaid_replay(restored["replay"], template.replay)
            except ShapeMismatchError:
                raise
            except Exception as error:  # orbax/tensorstore raise many types
                path = self.path(step)
                _REPORTED_READS.paths.update({str(path), str(path.resolve())})
                moved_to = self._quarantine(step)
                gc.collect()  # the failed reads' tasks and callbacks go while the hooks are set
                logger.warning(
                    "checkpoint %s cannot be read, likely truncated or damaged (%s: %.200s);"
                    " moved to %s, falling back to the previous one",
                    self.path(step),
                    type(error).__name__,
                    str(error).splitlines()[0] if str(error) else "",
                    moved_to,
                )
                continue
            return Restored(state=template.replace(**restored), step=step, meta=meta)
        return None

    def _check_shapes(
        self, step: int, stored: list[tuple[int, ...]], abstract: list[Any]
    ) -> None:
        expected = [tuple(leaf.shape) for leaf in abstract]
        if stored == expected:
            return
        differ = [(index, a, b) for index, (a, b) in enumerate(zip(stored, expected)) if a != b]
        if differ:
            index, stored_shape, expected_shape = differ[0]
            detail = f"array {index}: {stored_shape} stored, {expected_shape} expected"
        else:
            detail = f"{len(stored)} arrays stored, {len(expected)} expected"
        raise ShapeMismatchError(
            f"checkpoint {self.path(step)} holds a training state of other shapes than this"
            f" config and env make ({detail}); resume with the run's own sizes (num_envs,"
            " replay_size, hidden_sizes, env observations)"
        )

    def _quarantine(self, step: int) -> Path:
        target = self.directory.with_name(self.directory.name + "_corrupt")
        target.mkdir(exist_ok=True)
        moved_to = target / f"{step}-{int(time.time())}"
        shutil.move(self.path(step), moved_to)
        self._manager.reload()
        return moved_to

    def close(self) -> None:
        if self._opened is not None:
            self._opened.close()

    def __enter__(self) -> "CheckpointStore":
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()


def _saved_replay_layout(
    stored: list[tuple[int, ...]], template_tree: dict[str, Any], abstract: list[Any]
) -> list[int]:
    """Where a stored replay buffer was saved on another number of devices (its positions
    have another shape), reads those positions as saved (`abstract` is changed in place) and
    returns their indices; else []."""
    if "replay" not in template_tree:
        return []
    paths = [
        path for path, leaf in jax.tree_util.tree_flatten_with_path(template_tree)[0] if leaf.size
    ]
    slots = [
        index
        for index, path in enumerate(paths)
        if path[0].key == "replay"
        and path[-1].name in ("insert_position", "size")
        and index < len(stored)
        and stored[index] != abstract[index].shape
        and len(stored[index]) <= 1
    ]
    for index in slots:
        abstract[index] = jax.ShapeDtypeStruct(stored[index], abstract[index].dtype)
    return slots


def _relaid_replay(stored: replay_lib.ReplayState, template: replay_lib.ReplayState) -> Any:
    """A replay buffer saved on another number of devices, laid out as `template`'s rings."""
    shards = 1 if template.size.ndim == 0 else template.size.shape[0]
    relaid = replay_lib.reshard(jax.device_get(stored), shards)
    return jax.tree.map(
        lambda new, like: jax.device_put(new.astype(like.dtype), like.sharding), relaid, template
    )


class _ReportedReads(logging.Filter):
    """Drops asyncio's "Task (or Future) exception was never retrieved" for reads of a checkpoint
    that `restore_latest` already reported: tensorstore's other reads of it fail after orbax gave
    up, and asyncio logs each when its task or future is collected, which may be long after the
    restore."""

    def __init__(self) -> None:
        super().__init__()
        self.paths: set[str] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        if not str(record.msg).startswith(_UNRETRIEVED):
            return True
        error = record.exc_info[1] if record.exc_info else None
        text = f"{record.getMessage()} {error}"
        return not any(f"{path}{os.sep}" in text for path in self.paths)


_UNRETRIEVED = ("Task exception was never retrieved", "Future exception was never retrieved")
_REPORTED_READS = _ReportedReads()
logging.getLogger("asyncio").addFilter(_REPORTED_READS)


@contextlib.contextmanager
def _failed_reads_quiet() -> Iterator[None]:
    """Silences what a failed orbax read leaves behind; `restore_latest` reports the failure.

    When one array of a checkpoint cannot be read, orbax closes its event loop while tensorstore
    still completes the other reads; each completion then raises "Event loop is closed" as an
    unraisable exception (hundreds of tracebacks for a training state). Orbax also logs damaged
    metadata files at ERROR through absl. Other unraisable exceptions reach the previous hook.
    """
    previous_hook = sys.unraisablehook

    def hook(unraisable: Any) -> None:
        if not (
            isinstance(unraisable.exc_value, RuntimeError)
            and str(unraisable.exc_value) == "Event loop is closed"
        ):
            previous_hook(unraisable)

    absl_logger = logging.getLogger("absl")
    previous_level = absl_logger.level
    sys.unraisablehook = hook
    absl_logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        sys.unraisablehook = previous_hook
        absl_logger.setLevel(previous_level)
