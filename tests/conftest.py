"""Shared test set-up: XLA's CPU code generation without LLVM's optimisations, the JAX
persistent compilation cache, and one smoke run of the CLI for the tests that need a finished
run, trained once per session by the first worker that asks for it."""

import fcntl
import json
import os
import pathlib

# The suite is compile-bound (tiny batches, few steps): XLA:CPU at -O0 with its older (non-MLIR)
# fusion emitters, without the HLO passes that optimise while loops (simplifier, invariant code
# motion, constant sinking), and with each program's machine code made in one piece rather than
# split for threads (the two workers already keep both cores busy), compiles the MJX programs
# faster, and they run fast enough.
# Set before JAX's
# backend starts; the CLI subprocesses inherit it (quadcos.train only sets XLA_FLAGS where it is
# unset), so their programs share the cache.
os.environ.setdefault(
    "XLA_FLAGS",
    "--xla_backend_optimization_level=0 --xla_cpu_use_fusion_emitters=false"
    " --xla_cpu_parallel_codegen_split_count=1 --xla_disable_hlo_passes="
    "simplify-while-loops,while-loop-invariant-code-motion,while-loop-constant-sinking",
)

import jax  # noqa: E402
import pytest  # noqa: E402

from tests.cli_runs import run_in_process  # noqa: E402

_CACHE = pathlib.Path(
    os.environ.get(
        "QUADCOS_JAX_CACHE", pathlib.Path(__file__).resolve().parent.parent / ".jax_cache"
    )
)
jax.config.update("jax_compilation_cache_dir", str(_CACHE))
# Every program, however quick to compile, as the CLI caches them (quadcos._util.caches): the
# workers, CLI runs and notebook kernels then compile each small program once between them.
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)

SMOKE_ARGS = ("--preset=smoke", "--no_progress", "--seed=3")


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory) -> pathlib.Path:
    """The directory of a finished `--preset=smoke --seed=3` run (1024 env steps), shared by
    every test (and xdist worker) of the session: read it, copy it to change it.

    The first worker to ask trains it in its own process (`run_in_process`), so that its later
    in-process CLI runs of the smoke programs reuse that trainer; the others wait for it and
    read it (their own runs then load its programs from the persistent cache)."""
    shared = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        shared = shared.parent  # the session's directory, above each worker's own
    run_dir, outcome = shared / "smoke", shared / "smoke.json"
    with open(shared / "smoke.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not outcome.exists():
            result = run_in_process(*SMOKE_ARGS, f"--output_dir={run_dir}")
            outcome.write_text(json.dumps({"status": result.returncode, "log": result.stderr}))
    finished = json.loads(outcome.read_text())
    if finished["status"] != 0:
        pytest.fail(finished["log"][-3000:])
    return run_dir
