"""Where a result came from: the versions of the libraries that made it and the git revision."""

import importlib.metadata
import pathlib
import platform
import subprocess
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
