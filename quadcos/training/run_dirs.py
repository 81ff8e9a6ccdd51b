"""The run directory of `python -m quadcos.train`: checked writable before anything is built,
numbered when taken (`--numbered`), recognised as finished on `--resume`."""

import logging
import os
import pathlib
import tempfile

from quadcos._util.cli import UsageError

logger = logging.getLogger("quadcos.train")


def check_output_dir(run_dir: pathlib.Path | None, resume: bool) -> None:
    if run_dir is None:
        raise UsageError("--output_dir is required")
    if run_dir.exists() and not run_dir.is_dir():
        raise UsageError(f"--output_dir {run_dir} is not a directory")
    if not resume and run_dir.exists() and any(run_dir.iterdir()):
        if (run_dir / "config.json").is_file():
            raise UsageError(
                f"--output_dir {run_dir} already holds a run; pass --resume to continue it, or"
                " --numbered (or another directory) for a new one"
            )
        raise UsageError(
            f"--output_dir {run_dir} holds files but no run (no config.json); choose an empty or"
            " new directory, or pass --numbered for the first free DIR-2, DIR-3, ..."
        )
    existing = next(
        path for path in (run_dir.absolute(), *run_dir.absolute().parents) if path.exists()
    )
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise UsageError(
            f"--output_dir {run_dir} cannot be created: {existing} is not a writable directory"
        )
    try:  # os.access does not see read-only or virtual file systems (/proc)
        with tempfile.NamedTemporaryFile(dir=existing, prefix=".quadcos-write-test-"):
            pass
    except OSError as error:
        raise UsageError(
            f"--output_dir {run_dir} cannot be written: a file in {existing} cannot be"
            f" created ({error.strerror or error})"
        ) from None


def numbered_dir(run_dir: pathlib.Path) -> pathlib.Path:
    """`run_dir` if it holds no files, else the first free `run_dir`-2, -3, ..."""
    candidate, number = run_dir, 1
    while candidate.exists() and (not candidate.is_dir() or any(candidate.iterdir())):
        number += 1
        candidate = run_dir.with_name(f"{run_dir.name}-{number}")
    if candidate != run_dir:
        logger.info("%s already holds a run; this run goes to %s", run_dir, candidate)
    return candidate


def finished_run_message(run_dir: pathlib.Path, num_timesteps: int) -> str | None:
    """What to tell a --resume of a run that has its policy and a checkpoint at or past
    `num_timesteps`; None when there is training left to do."""
    checkpoints = run_dir / "checkpoints"
    names = [path.name for path in checkpoints.iterdir()] if checkpoints.is_dir() else []
    steps = [int(name) for name in names if name.isdigit()]
    if not (run_dir / "policy").is_dir() or not steps or max(steps) < num_timesteps:
        return None
    return (
        f"{run_dir} is finished (env step {max(steps):,} of num_timesteps={num_timesteps:,});"
        f" nothing was changed. To train it further, raise the total: --output_dir={run_dir}"
        f" --resume --num_timesteps={2 * num_timesteps}"
    )
