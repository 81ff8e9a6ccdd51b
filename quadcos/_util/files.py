"""Atomic file and directory writes: readers never see a partial result."""

import os
import shutil
from pathlib import Path
from typing import Callable


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Writes `text` to a temporary file beside `path`, then renames it."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Writes `data` to a temporary file beside `path`, then renames it (whole or not at all,
    also with several writers)."""
    path = Path(path)
    temporary = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    with open(temporary, "wb") as file:
        file.write(data)
        file.flush()
        os.fsync(file.fileno())
    os.replace(temporary, path)


def atomic_replace_dir(path: str | os.PathLike[str], fill: Callable[[Path], None]) -> None:
    """Builds a directory with `fill(temporary_dir)`, then swaps it into `path`.

    Directories cannot be renamed over non-empty ones, so an existing `path` is
    first renamed aside and deleted after the swap.
    """
    path = Path(path)
    temporary = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    shutil.rmtree(temporary, ignore_errors=True)
    temporary.mkdir(parents=True)
    fill(temporary)
    previous = path.with_name(f".{path.name}.old-{os.getpid()}")
    if path.exists():
        os.replace(path, previous)
    os.replace(temporary, path)
    shutil.rmtree(previous, ignore_errors=True)
