"""Shared test set-up: XLA's CPU code generation without LLVM's optimisations, the JAX
persistent compilation cache (reruns compile 4–5× faster), and one smoke run of the CLI for the
tests that need a finished run."""

import os
import pathlib
import shlex
import shutil
import signal
import subprocess
import tempfile
import time

# The suite is compile-bound (tiny batches, few steps): LLVM at -O0 builds the MJX programs ~30 %
# faster and they run fast enough, and XLA:CPU's older (non-MLIR) fusion emitters compile a smoke
# run's programs in about two thirds of the CPU time of the new ones. Set before JAX's backend
# starts; the CLI subprocesses inherit it (quadcos.train only sets XLA_FLAGS where it is unset),
# so their programs share the cache.
os.environ.setdefault(
    "XLA_FLAGS", "--xla_backend_optimization_level=0 --xla_cpu_use_fusion_emitters=false"
)

import jax  # noqa: E402
import pytest

from tests.cli_runs import ROOT, cli_command, cli_env

_CACHE = pathlib.Path(
    os.environ.get(
        "QUADCOS_JAX_CACHE", pathlib.Path(__file__).resolve().parent.parent / ".jax_cache"
    )
)
jax.config.update("jax_compilation_cache_dir", str(_CACHE))
# Every program, however quick to compile, as the CLI caches them (quadcos._util.caches): the
# workers, CLI runs and notebook kernels then compile each small program once between them, not
# once each (one pair of fresh-clone runs: 14.2 CPU-minutes against 15.2 with a 0.5-s floor, within
# this machine's spread between runs of one suite).
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)


# The smoke run starts with the session, in the background (on the second core, or beside the
# xdist workers), so that no test waits for all of it: the controlling process starts it and
# the workers find it through this variable.
_SMOKE_RUN = "QUADCOS_TEST_SMOKE_RUN"
_SMOKE_ARGS = ("--preset=smoke", "--no_progress", "--seed=3")


# The order in which the two xdist workers take the test files (`--dist loadfile`): the longest
# files first, so that neither worker is left with a long file at the end, and the files whose
# runs load the smoke run's programs (test_faults, test_bench, test_cli, test_newcomer; their
# in-process CLI runs share one trainer per worker) after the session's smoke run has put those
# programs into the cache; test_evaluate
# before the notebooks, which reuse its rollouts. The other files follow in their usual order.
# (From a cold cache on two cores: test_bench about 100 s, test_env, test_evaluate, test_faults
# and test_notebooks 70-90 s each, test_gait_search about 70 s, test_robot about 45 s, the rest
# less; each varies by 10-20 % between runs of the same suite.)
FILE_ORDER = (
    "test_env.py",
    "test_evaluate.py",
    "test_robot.py",
    "test_faults.py",
    "test_notebooks.py",
    "test_bench.py",
    "test_gait_search.py",
    "test_parallel.py",
    "test_randomization.py",
    "test_courses.py",
    "test_training.py",
    "test_newcomer.py",
    "test_readme.py",
    "test_cli.py",
    "test_backends.py",
    "test_runs.py",
    "test_terrain.py",
)


def pytest_configure(config):
    # xdist otherwise hands out the files with the most tests first; keep the order above.
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def pytest_collection_modifyitems(session, config, items):
    rank = {name: index for index, name in enumerate(FILE_ORDER)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: keeps file order


def pytest_sessionstart(session):
    if hasattr(session.config, "workerinput") or _SMOKE_RUN in os.environ:
        return  # an xdist worker: its controller started the run
    directory = pathlib.Path(tempfile.mkdtemp(prefix="quadcos-smoke-"))
    os.environ[_SMOKE_RUN] = str(directory / "smoke")
    command = shlex.join(cli_command(*_SMOKE_ARGS, f"--output_dir={directory / 'smoke'}"))
    # The exit status lands in a file: a worker, not being the parent, cannot wait for it.
    session.config.smoke_process = subprocess.Popen(
        ["/bin/sh", "-c", f"{command} > {directory}/log 2>&1; echo $? > {directory}/exit"],
        env=cli_env(),
        cwd=ROOT,
        start_new_session=True,  # its own process group: the end of the session stops all of it
    )
    session.config.smoke_directory = directory


def pytest_sessionfinish(session):
    process = getattr(session.config, "smoke_process", None)
    if process is None:
        return
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    shutil.rmtree(session.config.smoke_directory, ignore_errors=True)


@pytest.fixture(scope="session")
def smoke_run() -> pathlib.Path:
    """The directory of a finished `--preset=smoke --seed=3` run (1024 env steps), shared by
    every test (and xdist worker) of the session: read it, copy it to change it."""
    run_dir = pathlib.Path(os.environ[_SMOKE_RUN])
    exit_file = run_dir.parent / "exit"
    deadline = time.monotonic() + 900
    while not exit_file.exists() or not exit_file.read_text().strip():
        assert time.monotonic() < deadline, "the smoke run did not finish in 15 minutes"
        time.sleep(0.5)
    if exit_file.read_text().strip() != "0":
        pytest.fail((run_dir.parent / "log").read_text()[-3000:])
    return run_dir
