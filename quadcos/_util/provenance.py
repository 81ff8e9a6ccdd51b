"""Where a result came from: the versions of the libraries that made it and the git revision."""

import importlib.metadata
import os
import pathlib
import platform
import subprocess
import time
from collections.abc import Iterable


def versions(packages: Iterable[str], *, python: bool = False) -> dict[str, str]:
    """{package: installed version} of the installed ones among `packages` (with "python" first
    when `python`)."""
    found = {"python": platform.python_version()} if python else {}
    for package in packages:
        try:
            found[package] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            pass
    return found


def git_revision() -> str | None:
    """HEAD of the repository holding this package, '+dirty' if modified; None outside one."""
    try:
        revision = _git("rev-parse", "HEAD")
        status = _git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    return revision + ("+dirty" if status else "")


def _git(*args: str) -> str:
    return subprocess.run(
        ["git", *args],
        cwd=pathlib.Path(__file__).parent,
        capture_output=True,
        text=True,
        timeout=10,
        check=True,
    ).stdout.strip()


def process_start() -> float:
    """`time.monotonic()` at this process's start (Linux: /proc/self/stat); now where unknown."""
    try:
        fields = pathlib.Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()
        start_s = int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22: starttime, boot ticks
        age = time.clock_gettime(time.CLOCK_BOOTTIME) - start_s
    except (OSError, ValueError, IndexError, AttributeError):
        return time.monotonic()
    return time.monotonic() - max(age, 0.0)
