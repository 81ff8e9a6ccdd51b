"""`python -m quadcos.train` in a subprocess that shares the tests' compilation cache, or in
this process."""

import contextlib
import io
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


# The envs and trainers of this process's in-process CLI runs (a `quadcos.training.Trainers`,
# made by the first run): one smoke trainer per worker.
_TRAINERS = None


def run_in_process(*args: str) -> subprocess.CompletedProcess:
    """`python -m quadcos.train` in this process: its exit status, stdout and stderr. A later
    run of the same programs in this process reuses the envs and trainer of an earlier one
    (kept in `_TRAINERS`), which saves the tracing, lowering and loading a subprocess pays.

    The first call clears JAX's in-memory caches: how JAX names a program's inner functions
    depends on what the process traced before, so after other tests' programs the trainer's
    would differ from the CLI subprocesses' in text and miss their persistent-cache entries."""
    global _TRAINERS
    from quadcos import train, training  # heavy: only the tests that run the CLI need them

    if _TRAINERS is None:
        jax.clear_caches()
        _TRAINERS = training.Trainers()
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        status = train.main(list(args), _TRAINERS)
    return subprocess.CompletedProcess(
        ["quadcos.train", *args], status, stdout.getvalue(), stderr.getvalue()
    )
