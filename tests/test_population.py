"""`python -m quadcos.train --population=N`: N runs of one command, the best on held-out courses
kept (quadcos.training.population)."""

import json
import math
import os
import signal
import sys
import threading
import time

import pytest

from quadcos.training import population
from tests.cli_runs import cli_env, run_in_process


def test_a_member_runs_the_command_with_its_own_seed_and_folder(tmp_path):
    argv = ["--preset=smoke", "--seed", "3", "--config.sac.seed=9", "--population=2",
            "--output_dir", "out", "--numbered",
            "--population_terrain=flat", "--population_envs", "8", "--max_seconds=5"]
    assert population.member_argv(argv, 4, tmp_path / "member_1") == [
        "--preset=smoke", "--max_seconds=5", "--seed=4", f"--output_dir={tmp_path / 'member_1'}"
    ]


def test_a_member_is_never_a_population_itself(tmp_path, monkeypatch):
    monkeypatch.setenv(population.MEMBER_ENV, "0")
    result = run_in_process("--preset=smoke", f"--output_dir={tmp_path / 'run'}", "--population=2")
    assert result.returncode == 2 and "a member is one run" in result.stderr


def test_members_rank_by_worst_course_on_a_test_set_else_by_success():
    steady = {"worst_course_success_rate": 0.9, "mean_course_success_rate": 0.95}
    lucky = {"worst_course_success_rate": 0.5, "mean_course_success_rate": 0.99}
    assert population.score(steady) > population.score(lucky)
    assert population.score({"success_rate": 1.0, "mean_episode_reward": 5.0}) > population.score(
        {"success_rate": 1.0, "mean_episode_reward": 4.0}
    )
    broken = {"worst_course_success_rate": math.nan, "mean_course_success_rate": 1.0}
    assert population.score(broken) < population.score(lucky)
    assert population.selection_terrain("random:max_deg=12") == "testset:4242"
    assert population.selection_terrain("slope5") == "slope5"
    assert population.selection_seconds("testset:4242") == 40.0
    assert population.selection_seconds("slope5") == 20.0


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--population=1"], "at least 2 members, not 1"),
        (["--population=2", "--population_seconds=0"], "must be positive"),
        (["--population=2", "--population_terrain=nowhere"], "nowhere"),
        (["--population=2", "--coordinator=localhost:1234"], "not with --resume or --coordinator"),
        (["--population=4"], "2 are visible (0, 1)"),
        (["--popul=2"], "unrecognised argument '--popul=2'"),  # no abbreviations: members drop it
    ],
)
def test_a_bad_population_is_refused_in_one_line_before_anything_is_written(
    tmp_path, monkeypatch, flags, message
):
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "0,1")
    out = tmp_path / "run"
    result = run_in_process("--preset=smoke", f"--output_dir={out}", *flags)
    assert result.returncode == 2, result.stderr
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_progress_says_where_each_member_stands(tmp_path):
    member = {"index": 0, "run_dir": str(tmp_path / "member_0")}
    assert population._where(member, tmp_path) == "starting"  # noqa: SLF001
    log = tmp_path / "member_0.log"
    line = "gait search round 2/6 (65 s): best 988 at 0.41 m/s"
    log.write_text(f"quadcos.train: {line}\n")
    assert population._where(member, tmp_path) == line  # noqa: SLF001
    log.write_text(f"quadcos.train: {line}\n" + "*" * 32 + "\nE1128 slow_operation_alarm\n")
    assert population._where(member, tmp_path) == line  # noqa: SLF001 (XLA's lines skipped)
    log.write_text("quadcos.train: " + "x" * 100 + "\n")
    assert population._where(member, tmp_path) == "x" * 77 + "..."  # noqa: SLF001
    (tmp_path / "member_0").mkdir()
    (tmp_path / "member_0" / "metrics.jsonl").write_text('{"step": 1024}\n')
    assert population._where(member, tmp_path) == "env step 1,024"  # noqa: SLF001


def test_sigterm_stops_every_member_and_waits_for_them(tmp_path):
    members = [{"index": index, "gpu": None, "run_dir": str(tmp_path / f"member_{index}")}
               for index in range(2)]
    sleeper = [sys.executable, "-c", "import time; time.sleep(60)"]
    timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGTERM))
    handler, start = signal.getsignal(signal.SIGTERM), time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        population._train_all(members, [sleeper, sleeper], tmp_path, poll_s=0.2)
    timer.join()
    assert time.monotonic() - start < 30
    assert [member["train_exit"] for member in members] == [-signal.SIGTERM] * 2
    assert signal.getsignal(signal.SIGTERM) is handler  # the previous handler back


def test_a_second_signal_still_waits_for_the_members(tmp_path):
    members = [{"index": index, "gpu": None, "run_dir": str(tmp_path / f"member_{index}")}
               for index in range(2)]
    # a member that takes 1.5 s to stop after its SIGTERM (a chunk, a checkpoint)
    slow_to_stop = [sys.executable, "-c", "import signal, sys, time; signal.signal("
                    "signal.SIGTERM, lambda *_: (time.sleep(1.5), sys.exit(3))); time.sleep(60)"]
    timers = [threading.Timer(delay, os.kill, (os.getpid(), signal.SIGTERM)) for delay in (1, 1.5)]
    for timer in timers:
        timer.start()
    with pytest.raises(KeyboardInterrupt):
        population._train_all(members, [slow_to_stop] * 2, tmp_path, poll_s=0.2)
    for timer in timers:
        timer.join()
    assert [member["train_exit"] for member in members] == [3, 3]  # both waited for


def test_a_stopped_population_says_so_and_exits_130(tmp_path, monkeypatch):
    def interrupted(members, *_):
        for member in members:
            member["train_exit"] = -signal.SIGTERM
        raise KeyboardInterrupt

    monkeypatch.setattr(population, "_train_all", interrupted)
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "0,1")
    status = population.run(["--preset=smoke"], 2, tmp_path, 0, "flat", compare=None)
    record = json.loads((tmp_path / "population.json").read_text())
    assert status == 130 and record["interrupted"] and record["chosen"] is None
    assert [member["gpu"] for member in record["members"]] == ["0", "1"]
    assert not (tmp_path / "policy_best").exists()


@pytest.mark.slow
def test_a_population_of_two_keeps_the_better_members_policy(tmp_path, smoke_run, monkeypatch):
    del smoke_run  # its programs in the cache: the members load them
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "")  # no GPU: both on the CPU
    # The population in this process (no import of its own), its members in subprocesses with
    # the CLI runs' environment (the checkout importable, the tests' cache); each member half a
    # smoke run (its programs, one evaluation interval).
    for name, value in cli_env().items():
        monkeypatch.setenv(name, value)
    out = tmp_path / "population"
    result = run_in_process(
        "--preset=smoke", "--seed=3", "--no_progress", "--population=2", "--population_envs=2",
        "--population_seconds=1", "--config.sac.num_timesteps=512",
        f"--output_dir={out}",
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stdout.strip() == str(out)
    record = json.loads((out / "population.json").read_text())
    members = record["members"]
    assert [member["seed"] for member in members] == [3, 4]
    assert all(member["train_exit"] == 0 and "selection" in member for member in members)
    for member in members:  # each member trained with its own seed in its own folder
        config = json.loads((out / f"member_{member['index']}" / "config.json").read_text())
        assert config["config"]["seed"] == member["seed"]
    best = max(members, key=lambda member: population.score(member["selection"]))
    assert record["chosen"] == best["index"] and record["terrain"] == "flat"
    compared = best["compared"]  # a smoke run keeps no policy_best: its last policy
    chosen = out / f"member_{best['index']}" / compared / "policy.json"
    assert compared == "policy"
    assert (out / compared / "policy.json").read_text() == chosen.read_text()
    assert "population: member" in result.stderr
