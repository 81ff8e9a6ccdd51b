"""The tracked tree holds the code, the commands and small records — not run folders and logs
(runs, logs and traces are written by the commands, and .gitignore keeps them out)."""

import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
MAX_FILES = 700
MAX_BYTES = 10 * 2**20  # 10 MB


def _tracked() -> list[pathlib.Path]:
    try:
        listed = subprocess.run(
            ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, text=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [pathlib.Path(name) for name in listed.split("\0") if name]


def test_the_tracked_tree_is_small():
    files = _tracked()
    size = sum((ROOT / path).stat().st_size for path in files if (ROOT / path).is_file())
    assert len(files) <= MAX_FILES, f"{len(files)} tracked files (at most {MAX_FILES})"
    assert size <= MAX_BYTES, f"{size / 2**20:.1f} MB tracked (at most {MAX_BYTES / 2**20:.0f})"


def test_no_logs_patches_or_run_folders_are_tracked():
    files = _tracked()
    found = [
        str(path)
        for path in files
        if path.suffix in (".log", ".patch") or "runs" in path.parts[:-1]
    ]
    assert not found, found
