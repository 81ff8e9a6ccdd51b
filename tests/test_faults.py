"""Training survives faults and bad input (issue 6).

kill -9 then --resume; truncated or emptied checkpoints; hostile command lines, terrain specs,
section lists and MJCF files (fuzzed); same seed, same run; runs too big for memory refused.
Elsewhere: the NaN guard (test_training.test_nan_guard), an occupied --output_dir
(test_cli.test_an_occupied_output_dir_is_refused).
"""

import contextlib
import io
import json
import logging
import os
import pathlib
import random
import shutil
import signal
import tempfile
import time
from unittest import mock

import hypothesis
import pytest
from hypothesis import strategies as st

from quadcos import terrain, train, training
from quadcos._util import overrides as overrides_lib
from quadcos.training import checkpoint
from tests.cli_runs import run_in_process, start_cli
from tests.toy_env import PointEnv

ORBAX_TMP = ".orbax-checkpoint-tmp"
# Keys whose values depend on timing, not on the computation.
TIMING_KEYS = ("wall_time_s", "env_steps_per_s")


def read_metrics(run_dir: pathlib.Path) -> list[dict]:
    """metrics.jsonl, failing on any line that is not a whole JSON object."""
    return [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]


def checkpoint_steps(run_dir: pathlib.Path) -> list[int]:
    return sorted(
        int(path.name) for path in (run_dir / "checkpoints").iterdir() if path.name.isdigit()
    )


def toy_config(policy_width: int = 8):
    """A tiny trainer config for the toy env (its init compiles in a second)."""
    config = training.default_config()
    config.num_envs = 4
    config.replay_size = 64
    config.min_replay_size = 8
    config.hidden_sizes.policy = (policy_width,)
    config.hidden_sizes.q = (8,)
    return config


@pytest.fixture(scope="module")
def toy_state():
    return training.SACTrainer(PointEnv(), toy_config()).init()


# --- kill -9 ----------------------------------------------------------------------------------

# 4 envs x 32 steps = 128 env steps a chunk; a checkpoint every 2 chunks, from step 512 on.
KILL_RUN = (
    "--preset=smoke",
    "--no_progress",
    "--seed=3",
    "--num_timesteps=2048",
    "--config.sac.eval_interval=256",
    "--config.sac.checkpoint_interval=256",
)


@pytest.mark.slow
def test_kill_9_at_a_random_moment_then_resume_completes_the_run(tmp_path, smoke_run):
    # After the session's smoke run: its programs are in the persistent compilation cache then,
    # and this run loads them instead of compiling them beside it.
    del smoke_run
    run_dir = tmp_path / "run"
    checkpoints = run_dir / "checkpoints"
    # After the first checkpoint: during the first, second or third checkpoint write that
    # follows, or at any moment of the next half second.
    moment = random.choice(["write 1", "write 2", "write 3", "any"])
    with (tmp_path / "stderr").open("w") as stderr:
        process = start_cli(*KILL_RUN, f"--output_dir={run_dir}", stderr=stderr)
        try:
            writes = set()
            deadline = time.monotonic() + 600
            while moment == "any" or len(writes) < int(moment[-1]):
                assert process.poll() is None, (tmp_path / "stderr").read_text()[-3000:]
                assert time.monotonic() < deadline
                names = os.listdir(checkpoints) if checkpoints.exists() else []
                if any(name.isdigit() for name in names):
                    if moment == "any":
                        time.sleep(random.uniform(0.0, 0.5))
                        break
                    writes |= {name for name in names if ORBAX_TMP in name}
                time.sleep(0.002)
            assert process.poll() is None, f"the run ended before the kill ({moment})"
            process.send_signal(signal.SIGKILL)
        finally:
            process.kill()
            process.wait()

    rows_before = read_metrics(run_dir)
    last_good = checkpoint_steps(run_dir)[-1]
    lost = rows_before[-1]["step"] - last_good
    assert 0 <= lost <= 256, (moment, rows_before[-1]["step"], last_good)

    result = run_in_process(f"--output_dir={run_dir}", "--resume", "--no_progress")
    assert result.returncode == 0, (moment, result.stderr[-3000:])
    rows = read_metrics(run_dir)
    steps = [row["step"] for row in rows]
    assert steps == sorted(set(steps)) and steps[-1] >= 2048, (moment, steps)
    kept = [row for row in rows_before if row["step"] <= last_good]
    assert rows[: len(kept)] == kept
    assert checkpoint_steps(run_dir)[-1] == steps[-1]
    assert (run_dir / "policy").is_dir()


def test_a_run_killed_after_its_last_checkpoint_resumes_to_just_its_policy(toy_state, tmp_path):
    config = toy_config()
    config.num_timesteps = 1000
    with checkpoint.CheckpointStore(tmp_path / "checkpoints", keep=3) as store:
        finished = toy_state.replace(env_steps=toy_state.env_steps + 1000)
        store.save(1000, finished, {"wall_time_s": 1.0}, include_replay=False)

    result = training.train(PointEnv(), config, tmp_path, resume=True, progress=False)
    assert result.env_steps == 1000 and result.history == []  # no prefill, no training
    assert (tmp_path / "policy").is_dir() and checkpoint_steps(tmp_path) == [1000]


# --- Corrupt checkpoints ----------------------------------------------------------------------


def _truncate(path: pathlib.Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _files(directory: pathlib.Path) -> list[pathlib.Path]:
    return [path for path in directory.rglob("*") if path.is_file()]


DAMAGE = {
    "truncated array data": lambda latest: [
        _truncate(path) for path in _files(latest / "state") if path.parent.name == "d"
    ],
    "truncated files": lambda latest: [_truncate(path) for path in _files(latest)],
    "deleted state files": lambda latest: [path.unlink() for path in _files(latest / "state")],
    "emptied directory": lambda latest: [
        shutil.rmtree(path) if path.is_dir() else path.unlink() for path in latest.iterdir()
    ],
}


# Orbax leaves reads behind after the failed one; their callbacks fire on a closed event loop and
# used to print hundreds of tracebacks: restore_latest silences them.
@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.parametrize("damage", DAMAGE)
def test_a_damaged_latest_checkpoint_is_named_and_the_previous_one_used(
    toy_state, tmp_path, caplog, damage
):
    with checkpoint.CheckpointStore(tmp_path / "checkpoints", keep=3) as store:
        store.save(100, toy_state, {"wall_time_s": 1.0}, include_replay=True)
        store.save(200, toy_state, {"wall_time_s": 2.0}, include_replay=True)
    latest = tmp_path / "checkpoints" / "200"
    DAMAGE[damage](latest)

    with (
        caplog.at_level(logging.WARNING),
        checkpoint.CheckpointStore(tmp_path / "checkpoints", keep=3) as store,
    ):
        restored = store.restore_latest(toy_state)
        assert store.steps() == [100]
    assert restored.step == 100 and restored.meta["wall_time_s"] == 1.0
    assert f"checkpoint {latest} cannot be read" in caplog.text
    assert [path.name.split("-")[0] for path in (tmp_path / "checkpoints_corrupt").iterdir()] == [
        "200"
    ]
    # tensorstore's other reads of it fail after orbax gave up; asyncio logs each whenever its
    # task or future is collected: dropped for a checkpoint already reported, kept for the rest.
    for kind in ("Task", "Future"):
        never_retrieved = f"{kind} exception was never retrieved\nfuture: <{kind} exception=%r>"
        logging.getLogger("asyncio").error(never_retrieved, f"reading {latest}/state")
        logging.getLogger("asyncio").error(never_retrieved, f"{kind} reading elsewhere")
    assert f"reading {latest}" not in caplog.text
    assert "Task reading elsewhere" in caplog.text and "Future reading elsewhere" in caplog.text


def test_resuming_with_other_sizes_is_refused_and_changes_nothing(toy_state, tmp_path):
    with checkpoint.CheckpointStore(tmp_path / "checkpoints", keep=3) as store:
        store.save(100, toy_state, {"wall_time_s": 1.0}, include_replay=False)
    (tmp_path / "metrics.jsonl").write_text('{"step": 0}\n')

    latest = tmp_path / "checkpoints" / "100"
    with pytest.raises(training.ConfigError, match=f"checkpoint {latest} holds a training state"):
        training.train(PointEnv(), toy_config(policy_width=16), tmp_path, resume=True)
    assert (tmp_path / "metrics.jsonl").read_text() == '{"step": 0}\n'
    assert checkpoint_steps(tmp_path) == [100]
    assert sorted(path.name for path in tmp_path.iterdir()) == ["checkpoints", "metrics.jsonl"]


# --- Hostile input ----------------------------------------------------------------------------


def run_main(argv: list[str]) -> tuple[int, str]:
    """`python -m quadcos.train` in this process: (exit status, stderr)."""
    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
        status = train.main(argv)
    return status, stderr.getvalue()


def assert_one_line_error(status: int, stderr: str) -> None:
    assert status == 2, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("quadcos.train: error: "), stderr


KEYS = overrides_lib.flat_keys(train.default_config())
VALUES = [
    "None",
    "0",
    "-1",
    "1e999",
    "-1e999",
    "nan",
    "10**30",
    str(10**30),
    str(2**63),
    "()",
    "(0,)",
    "(-3, 64)",
    "('a',)",
    "[]",
    "{}",
    "True",
    "''",
    "warp",
    "sections:5@1",
    "\n",
]
SPEC_PIECES = ["sections:", "5", "-5", "1.4", "1e308", "nan", "x", "@", ",", ";", "=", "lead_in"]
FLAG_NAMES = [
    "--terrain",
    "--num_envs",
    "--num_timesteps",
    "--seed",
    "--reward",
    "--controller",
    "--preset",
    "--resume",
    "--save_replay",
    "--config.sac.replay_size",
    "--config",
    "--config.",
    "-x",
]

terrain_specs = st.one_of(
    st.text(max_size=20),
    st.lists(st.sampled_from(SPEC_PIECES), max_size=10).map("".join),
)
values = st.one_of(
    st.sampled_from(VALUES), st.text(max_size=12), st.integers().map(str), st.floats().map(repr)
)
arguments = st.one_of(
    st.builds(
        "--config.{}={}".format, st.one_of(st.sampled_from(KEYS), st.text(max_size=12)), values
    ),
    st.builds("{}={}".format, st.sampled_from(FLAG_NAMES), values),
    st.sampled_from(FLAG_NAMES),
    terrain_specs.map("--terrain={}".format),
    terrain_specs.map("--config.env.terrain={}".format),
    # Not an option: argparse would answer --h... with the help text.
    st.text(max_size=12).filter(lambda text: not text.startswith("-")),
)


@hypothesis.settings(max_examples=150, deadline=None)
@hypothesis.given(st.lists(arguments, min_size=1, max_size=4))
# Each of these used to end in a traceback.
@hypothesis.example(["--config.sac.batch_size=0"])
@hypothesis.example(["--config.env.terrain=None"])
@hypothesis.example(["--config.sac.seed=None"])
@hypothesis.example(["--seed=100000000000000000000000"])
@hypothesis.example(["--config.sac.init_std=abc"])
@hypothesis.example(["--config.sac.hidden_sizes.policy=('a',)"])
@hypothesis.example(["--config.env.control_dt=1e999"])
@hypothesis.example(["--config.env.impl=warp"])
@hypothesis.example(["--config.sac.replay_size=1000000000000"])
@hypothesis.example(["--config.sac.best_policy_max_fall_rate=2"])
def test_fuzzed_command_lines_fail_in_one_line_and_write_nothing(argv):
    with tempfile.TemporaryDirectory() as directory:
        run_dir = pathlib.Path(directory) / "out"
        status, stderr = run_main([*argv, f"--output_dir={run_dir}", "--print_config"])
        assert not run_dir.exists()
    if status != 0:
        assert_one_line_error(status, stderr)


scalars = st.one_of(st.floats(), st.integers(), st.text(max_size=3), st.none(), st.booleans())


@hypothesis.settings(max_examples=100, deadline=None)
@hypothesis.given(
    st.lists(
        st.one_of(
            st.builds(terrain.Section, scalars, scalars),
            st.tuples(scalars, scalars),
            st.lists(st.floats(), max_size=3),
            st.none(),
            st.text(max_size=3),
        ),
        max_size=4,
    )
)
@hypothesis.example([terrain.Section(5.0, 10**400)])
def test_fuzzed_section_lists_give_a_terrain_or_a_one_line_value_error(segments):
    try:
        ground = terrain.sections(segments)
    except ValueError as error:
        assert len(str(error).splitlines()) == 1, str(error)
        return
    assert terrain.parse(ground.spec).spec == ground.spec


MJCF_CONTENTS = [
    b"",
    b"\x00\xff garbage",
    b"<mujoco/>",
    b"<mujoco><worldbody><body name='torso'><freejoint/></body></worldbody></mujoco>",
    b"<mujoco><include file='/nonexistent.xml'/></mujoco>",
    b"<mujoco>\n<worldbody>\n<geom type='box'/>\n",  # unclosed, multi-line parser message
]


@hypothesis.settings(max_examples=15, deadline=None)
@hypothesis.given(st.one_of(st.sampled_from(MJCF_CONTENTS), st.binary(max_size=64)))
def test_hostile_mjcf_files_fail_in_one_line_and_write_nothing(content):
    with tempfile.TemporaryDirectory() as directory:
        mjcf = pathlib.Path(directory) / "robot.xml"
        mjcf.write_bytes(content)
        for path in (mjcf, pathlib.Path(directory), pathlib.Path(directory) / "no\nsuch.xml"):
            run_dir = pathlib.Path(directory) / "out"
            with mock.patch.object(training.loop, "train", side_effect=AssertionError("trained")):
                status, stderr = run_main(
                    ["--preset=smoke", f"--config.env.robot={path}", f"--output_dir={run_dir}"]
                )
            assert_one_line_error(status, stderr)
            assert "MJCF" in stderr and not run_dir.exists()


def test_an_output_dir_that_cannot_be_a_directory_is_refused(tmp_path):
    (tmp_path / "file").write_text("not a directory")
    for run_dir in (tmp_path / "file", tmp_path / "file" / "run"):
        with mock.patch.object(training.loop, "train", side_effect=AssertionError("trained")):
            status, stderr = run_main(["--preset=smoke", f"--output_dir={run_dir}"])
        assert_one_line_error(status, stderr)
        assert str(tmp_path / "file") in stderr
    assert (tmp_path / "file").read_text() == "not a directory"


# --- Determinism ------------------------------------------------------------------------------


def without_timing(rows: list[dict]) -> list[dict]:
    return [{key: value for key, value in row.items() if key not in TIMING_KEYS} for row in rows]


@pytest.mark.slow
def test_same_seed_same_metrics_other_seed_other_rewards(smoke_run, tmp_path):
    """The session's `--seed=3` smoke run against the same command again and with --seed=4, both
    in this process (with the programs of the worker's first smoke-sized run)."""
    runs = {}
    for seed in (3, 4):
        runs[seed] = tmp_path / str(seed)
        argv = ("--preset=smoke", "--no_progress", f"--seed={seed}", f"--output_dir={runs[seed]}")
        result = run_in_process(*argv)
        assert result.returncode == 0, result.stderr[-3000:]
    first = [row for row in without_timing(read_metrics(smoke_run)) if row["step"] <= 1024]
    assert [row["step"] for row in first] == [0, 512, 1024]
    assert without_timing(read_metrics(runs[3])) == first
    other = without_timing(read_metrics(runs[4]))
    assert [row["step"] for row in other] == [0, 512, 1024]
    rewards = [row["eval/episode_reward"] for row in first]
    assert [row["eval/episode_reward"] for row in other] != rewards


# --- Bounded memory ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "flags, named",
    [
        # < 2**31 (the ring buffer's int32 indices), yet ~370 GB: more than a GPU or CI has.
        (["--config.sac.replay_size=2000000000"], "replay buffer of 2000000000 transitions"),
        (
            [
                "--num_envs=100000000",
                "--config.sac.replay_size=100000000",
                "--num_timesteps=1000000000",
            ],
            "100000000 training and 2 evaluation envs",
        ),
    ],
)
def test_a_run_too_big_for_the_device_memory_is_refused_up_front(tmp_path, flags, named):
    run_dir = tmp_path / "out"
    status, stderr = run_main(["--preset=smoke", *flags, f"--output_dir={run_dir}"])
    assert_one_line_error(status, stderr)
    assert "the run needs about" in stderr and " GB" in stderr and named in stderr, stderr
    assert not run_dir.exists()
