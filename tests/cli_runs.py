"""`python -m quadcos.train` in a subprocess that shares the tests' compilation cache."""

import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent


def start_cli(*args: str, **popen_kwargs) -> subprocess.Popen:
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT),
        "JAX_COMPILATION_CACHE_DIR": str(ROOT / ".jax_cache"),
    }
    return subprocess.Popen(
        [sys.executable, "-m", "quadcos.train", *args], env=env, cwd=ROOT, **popen_kwargs
    )


def run_cli(*args: str) -> subprocess.CompletedProcess:
    process = start_cli(*args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    stdout, stderr = process.communicate(timeout=900)
    return subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)
