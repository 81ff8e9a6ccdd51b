"""Shared test set-up: the JAX persistent compilation cache (reruns compile 4–5× faster), and
one smoke run of the CLI for the tests that need a finished run."""

import os
import pathlib

import jax
import pytest

from tests.cli_runs import run_cli

_CACHE = pathlib.Path(
    os.environ.get(
        "QUADCOS_JAX_CACHE", pathlib.Path(__file__).resolve().parent.parent / ".jax_cache"
    )
)
jax.config.update("jax_compilation_cache_dir", str(_CACHE))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory) -> pathlib.Path:
    """The directory of a finished `--preset=smoke --seed=3` run (1024 env steps). Tests may
    extend it with --resume but leave what it holds up to step 1024 as it is."""
    run_dir = tmp_path_factory.mktemp("runs") / "smoke"
    result = run_cli("--preset=smoke", f"--output_dir={run_dir}", "--no_progress", "--seed=3")
    assert result.returncode == 0, result.stderr[-3000:]
    return run_dir
