"""`python -m quadcos.train` in a subprocess that shares the tests' compilation cache."""

import os
import pathlib
import subprocess
import sys

import jax

ROOT = pathlib.Path(__file__).resolve().parent.parent


def cache_env() -> dict[str, str]:
    """Environment variables that give a child process (a CLI run, a notebook kernel) the tests'
    persistent compilation cache and its thresholds (tests/conftest.py), so that it reuses what
    the tests compiled and they reuse what it compiled (none where no cache is set)."""
    directory = jax.config.jax_compilation_cache_dir
    if not directory:
        return {}
    return {
        "JAX_COMPILATION_CACHE_DIR": str(directory),
        "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS": str(
            jax.config.jax_persistent_cache_min_compile_time_secs
        ),
        "JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES": str(
            jax.config.jax_persistent_cache_min_entry_size_bytes
        ),
    }


def cli_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "quadcos.train", *args]


def cli_env() -> dict[str, str]:
    """The environment of a CLI run: this one, the checkout importable first (then what
    PYTHONPATH already held), the tests' cache."""
    path = os.pathsep.join(filter(None, (str(ROOT), os.environ.get("PYTHONPATH"))))
    return {**os.environ, "PYTHONPATH": path, **cache_env()}


def start_cli(*args: str, **popen_kwargs) -> subprocess.Popen:
    return subprocess.Popen(cli_command(*args), env=cli_env(), cwd=ROOT, **popen_kwargs)


def run_cli(*args: str) -> subprocess.CompletedProcess:
    process = start_cli(*args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    stdout, stderr = process.communicate(timeout=900)
    return subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)
