"""A newcomer's first hour (issue 18): the cases of its table that the training CLI, the terrain
API, the Makefile and the notebooks answer, each asserting the fixed behaviour at smoke size.

Elsewhere: the README's blocks (tests/test_readme.py, case 10's command lines).
"""

import hashlib
import json
import logging
import pathlib
import re
import shutil
import subprocess
import sys
import time
from unittest import mock

import pytest

import quadcos
from quadcos import terrain, train, training
from quadcos.terrain import Section
from quadcos.training import host, loop
from tests.cli_runs import ROOT, run_cli, run_in_process


def tree_digest(directory: pathlib.Path) -> dict[str, str]:
    return {
        str(path.relative_to(directory)): hashlib.sha256(path.read_bytes()).hexdigest()
        for path in sorted(directory.rglob("*"))
        if path.is_file()
    }


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("quadcos.train: error: "), err
    return err


def fake_train(env, config, run_dir, **kwargs):
    """training.train as far as the CLI can see: the run directory gets files."""
    pathlib.Path(run_dir).mkdir(parents=True)
    (pathlib.Path(run_dir) / "config.json").write_text("{}")
    return mock.Mock(env_steps=config.num_timesteps)


# --- 2: a second `make train` --------------------------------------------------------------------


def test_a_second_run_into_a_taken_dir_gets_the_next_number(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = ["--preset=smoke", "--output_dir=runs/flat", "--numbered"]
    with mock.patch.object(training.loop, "train", side_effect=fake_train):
        outputs = []
        for _ in range(3):
            assert train.main(argv) == 0
            outputs.append(capsys.readouterr())
    assert [output.out for output in outputs] == ["runs/flat\n", "runs/flat-2\n", "runs/flat-3\n"]
    assert "runs/flat already holds a run; this run goes to runs/flat-3" in outputs[2].err


def test_make_train_numbers_its_runs_and_make_clean_keeps_them():
    def recipe(target: str) -> str:
        lines = subprocess.run(
            ["make", "-n", "-B", target], cwd=ROOT, capture_output=True, text=True, check=True
        ).stdout.splitlines()
        # (a make that runs inside another one adds "make[1]: Leaving directory" lines)
        return next(line for line in reversed(lines) if not line.startswith("make["))

    assert "--output_dir=runs/flat --numbered" in recipe("train")
    clean = subprocess.run(["make", "-n", "clean"], cwd=ROOT, capture_output=True, text=True).stdout
    assert "rm -rf .venv" in clean and "kept runs/" in clean
    assert not re.search(r"rm -rf[^\n]*\bruns\b[^\n]*$", clean.split("\n")[0])


# --- 3: stdout is the config JSON ----------------------------------------------------------------


def test_print_config_is_the_whole_of_stdout():
    result = run_cli("--preset=smoke", "--print_config")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["sac"]["num_envs"] == 4
    assert "Failed to import" not in result.stdout + result.stderr


# --- 4: --no_progress lines, on a terminal too ---------------------------------------------------


class _Terminal(list):
    def isatty(self) -> bool:
        return True

    def write(self, text: str) -> None:
        self.append(text)

    def flush(self) -> None:
        pass


def test_no_progress_prints_one_line_per_evaluation_even_on_a_terminal():
    terminal = _Terminal()
    progress = host.Progress(1024, enabled=True, bar=False, stream=terminal)
    row = {
        "step": 512,
        "env_steps_per_s": 900.0,
        "eval/episode_reward": 601.25,
        "eval/forward_speed": 0.655,
        "eval/fall_rate": 0.0,
    }
    progress.update(512, 900.0, [row])  # the bar: not drawn
    progress.log_row(row)
    progress.log_row({**row, "step": 1536})  # a last chunk past num_timesteps: its own end
    progress.close()
    assert terminal == [
        "step 512/1,024  900 env steps/s  eval reward 601.2  speed 0.655 m/s  fall rate 0"
        "  ETA 0:00:00\n",
        "step 1,536/1,536  900 env steps/s  eval reward 601.2  speed 0.655 m/s  fall rate 0"
        "  ETA 0:00:00\n",
    ]


def test_the_eta_is_the_time_budget_where_it_ends_the_run_first():
    terminal = _Terminal()
    row = {"step": 512, "env_steps_per_s": 1.0, "eval/episode_reward": 1.0}
    ends = time.monotonic() + 65.5  # 400 M env steps at 1/s would take years
    host.Progress(400_000_000, enabled=True, bar=False, stream=terminal, deadline=ends).log_row(row)
    host.Progress(400_000_000, enabled=True, bar=False, stream=terminal).log_row(row)
    assert terminal[0].endswith("ETA 0:01:05\n"), terminal[0]
    assert terminal[1].endswith("ETA 111110:58:08\n"), terminal[1]


# --- 5, 15: a corrupt checkpoint's fallback, the step counter's rounding -------------------------


@pytest.mark.slow
def test_resume_past_a_corrupt_checkpoint_says_so_in_one_line(smoke_run, tmp_path):
    run_dir = tmp_path / "run"
    shutil.copytree(smoke_run, run_dir)
    steps = sorted(int(path.name) for path in (run_dir / "checkpoints").iterdir())
    latest = run_dir / "checkpoints" / str(steps[-1])
    for path in (latest / "state" / "d").iterdir():  # the array data, cut in half
        path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    total = steps[-1] + 100  # not a whole number of chunks from the previous checkpoint
    result = run_in_process(
        f"--output_dir={run_dir}", "--resume", f"--num_timesteps={total}", "--no_progress"
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stdout == f"{run_dir}\n"
    lines = result.stderr.splitlines()
    assert "Traceback" not in result.stderr and "Event loop" not in result.stderr
    # The fallback: one warning naming the file and the cause, one line naming what is used.
    assert f"warning: checkpoint {latest} cannot be read" in lines[0]
    assert "likely truncated or damaged" in lines[0] and "previous one" in lines[0]
    assert lines[1].endswith(f"resuming from {run_dir / 'checkpoints' / str(steps[-2])}")
    final = steps[-2] + 256 + 3 * 128  # the prefill, then chunks of 4 envs x 32 steps
    assert f"training ends at env step {final:,}, not num_timesteps={total:,}" in lines[2]
    progress = lines[3:-1]
    assert progress and all(
        re.fullmatch(
            r"step [\d,]+/[\d,]+  [\d,]+ env steps/s  eval reward \S+  speed \S+ m/s"
            r"  fall rate \S+  roll \S+ rad  ETA \S+",
            line,
        )
        for line in progress
    ), lines
    assert lines[-1] == f"quadcos.train: env step {final:,}: policy in {run_dir / 'policy'}"


def test_the_cpu_presets_rounding_is_stated(caplog):
    config = train.build_config(train.PRESETS["cpu"], {}).sac
    with caplog.at_level(logging.INFO, logger="quadcos"):
        loop._log_final_step(config, config.num_timesteps, 4_096)
    assert "training ends at env step 202,496, not num_timesteps=200,000" in caplog.text


def test_when_the_actor_starts_is_stated_and_a_run_that_never_reached_it_is_warned(caplog):
    # ANYmal C's command preset: 2,000 critic-only updates at 2 per step of 4,096 envs.
    config = train.build_config(
        train.PRESETS["command"], {"sac.updates_per_step": 2, "sac.min_replay_size": 65_536}
    ).sac
    with caplog.at_level(logging.INFO, logger="quadcos"):
        loop._log_actor_start(config, 0, 65_536)
        loop._log_actor_start(config, 2_000, 65_536)  # (resumed past the warm-up: nothing said)
    assert caplog.text.count("the actor learns") == 1
    assert "the actor learns from env step 4,161,536 on" in caplog.text
    assert "the critics alone take 2,000 updates first" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="quadcos"):
        loop._log_the_end(config, 4_165_632, 2_002, out_of_time=True)
    assert "time budget of 480 s spent at env step 4,165,632" in caplog.text
    assert "never learned" not in caplog.text
    with caplog.at_level(logging.INFO, logger="quadcos"):  # the warm-up's last update: no actor's
        loop._log_the_end(config, 4_161_536, 2_000, out_of_time=False)
    assert "the actor never learned: the run ended at env step 4,161,536 after 2,000 of" in (
        caplog.text
    )
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="quadcos"):
        loop._log_the_end(config, 3_137_536, 1_536, out_of_time=False)
    assert "the actor never learned: the run ended at env step 3,137,536 after 1,536 of" in (
        caplog.text
    )


def test_a_budget_that_ends_inside_the_warm_up_is_warned_at_the_pace_given(caplog):
    # ANYmal C at 1.1 M env steps: the actor starts at 4,161,536, 65 s on at 47 k env steps/s
    # (two runs sharing a GPU), 154 s on at 20 k.
    config = train.build_config(
        train.PRESETS["command"],
        {"sac.updates_per_step": 2, "sac.min_replay_size": 65_536, "sac.max_seconds": 400},
    ).sac
    step, gradient_steps = 1_089_536, 2_000 - 1_500
    assert host.actor_start_step(config, gradient_steps, step) == 4_161_536
    assert host.actor_start_step(config, 2_000, step) is None  # (learning: nothing to say)
    with caplog.at_level(logging.INFO, logger="quadcos"):
        warned = [
            host.warn_if_the_actor_starts_too_late(
                config, gradient_steps, step, pace, time.monotonic() + left
            )
            for left, pace in ((100.0, 47_000.0), (100.0, 20_000.0), (50.0, 47_000.0))
        ]
        assert not host.warn_if_the_actor_starts_too_late(config, 2_000, step, 1.0, 0.0)
        assert not host.warn_if_the_actor_starts_too_late(config, gradient_steps, step, 1.0, None)
    assert warned == [False, True, True]
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 2, warnings
    assert warnings[0].startswith("at 20,000 env steps/s the actor learns from env step")
    assert "4,161,536, in about 154 s, past the time budget (sac.max_seconds 400)" in warnings[0]
    assert re.search(r"in about 65 s, past .* that ends in (49|50) s", warnings[1]), warnings[1]


# --- 6: --resume of a finished run ---------------------------------------------------------------


@pytest.mark.slow
def test_resume_of_a_finished_run_says_how_to_extend_it_and_changes_nothing(smoke_run, capsys):
    before = tree_digest(smoke_run)
    total = json.loads((smoke_run / "config.json").read_text())["config"]["num_timesteps"]
    assert train.main([f"--output_dir={smoke_run}", "--resume"]) == 0
    captured = capsys.readouterr()
    assert captured.out == ""
    assert len(captured.err.splitlines()) == 1
    assert f"{smoke_run} is finished" in captured.err
    assert f"--resume --num_timesteps={2 * total}" in captured.err
    assert tree_digest(smoke_run) == before


# --- 7: unreadable policy and config files -------------------------------------------------------


@pytest.mark.parametrize("name", ["params.msgpack", "policy.json"])
def test_a_truncated_policy_file_is_named_with_its_likely_cause(tmp_path, name):
    policy = tmp_path / "policy"
    shutil.copytree(ROOT / "experiments" / "policies" / "flat", policy)
    (policy / name).write_bytes((policy / name).read_bytes()[:100])
    with pytest.raises(ValueError) as error:
        quadcos.load_policy(policy)
    message = str(error.value)
    assert len(message.splitlines()) == 1
    assert f"policy file {policy / name} cannot be read, likely truncated" in message


def test_a_truncated_run_config_is_named_on_resume(tmp_path, capsys):
    (tmp_path / "config.json").write_text('{"config": {"num_en')
    assert train.main([f"--output_dir={tmp_path}", "--resume"]) == 2
    assert f"{tmp_path / 'config.json'} cannot be read, likely truncated" in one_error_line(capsys)


# --- 8 and the output directory: named keys and ranges, writability -----------------------------


@pytest.mark.parametrize(
    "flag, message",
    [
        ("--config.sac.learning_rate=nan", "config.sac.learning_rate.actor must be > 0, got nan"),
        ("--config.sac.learning_rate.critic=-1", "config.sac.learning_rate.critic must be > 0"),
        ("--config.sac.discount=inf", "config.sac.discount must be in [0, 1]"),
        ("--config.env.control_dt=nan", "control_dt and physics_dt must be finite and > 0"),
        ("--config.env.reward.yaw=nan", "config key 'env.reward.yaw': it must be finite"),
    ],
)
def test_a_bad_config_value_names_its_key_and_range(tmp_path, capsys, flag, message):
    assert train.main(["--preset=smoke", flag, f"--output_dir={tmp_path / 'out'}"]) == 2
    assert message in one_error_line(capsys)
    assert not (tmp_path / "out").exists()


def test_an_unwritable_output_dir_is_refused_before_training(capsys):
    with mock.patch.object(training.loop, "train", side_effect=AssertionError("trained")):
        assert train.main(["--preset=smoke", "--output_dir=/proc/quadcos-run"]) == 2
    assert "--output_dir /proc/quadcos-run cannot be written" in one_error_line(capsys)


# --- 10: terrains from the user's module and from a heightfield file -----------------------------


def test_terrain_specs_from_a_module_and_a_file_name_their_errors(tmp_path, monkeypatch):
    monkeypatch.setattr(terrain.registry, "_REGISTRY", dict(terrain.registry._REGISTRY))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "newcomer_courses.py").write_text(
        "from quadcos import terrain\n"
        "terrain.register('ramp', terrain.sections([terrain.Section(3.0, 1.0)]))\n"
        "not_a_terrain = 3\n"
    )
    (tmp_path / "cut.npy").write_bytes(b"\x93NUMPY")
    monkeypatch.delitem(sys.modules, "newcomer_courses", raising=False)
    assert terrain.parse("newcomer_courses:ramp").spec == "newcomer_courses:ramp"
    for spec, message in [
        ("newcomer_courses:nope", "has no attribute 'nope' and registered no terrain"),
        ("newcomer_courses:not_a_terrain", "is int, not a Terrain"),
        ("no_such_module:hills", "cannot import module 'no_such_module'"),
        ("heightfield:cut.npy", "cut.npy cannot be read as a NumPy .npy array, likely missing"),
        ("heightfield:cut.npy;x_range=1,2", "expected"),
    ]:
        with pytest.raises((ValueError, TypeError), match=re.escape(message)):
            terrain.parse(spec)
    sys.modules.pop("newcomer_courses", None)


# --- 12: one section order -----------------------------------------------------------------------


def test_sections_are_angle_first_in_python_as_on_the_command_line():
    course = terrain.sections([Section(angle_deg=5.0, length_m=1.4), Section(9.0, 1.2)])
    assert course.spec == "sections:5@1.4,9@1.2"
    assert terrain.parse(course.spec).heights.tolist() == course.heights.tolist()
    with pytest.raises(ValueError, match="plain tuples are refused"):
        terrain.sections([(1.4, 5.0)])


# --- 13: notebooks -------------------------------------------------------------------------------


def test_make_notebooks_installs_jupyter_and_the_notebooks_say_how_to_open_them():
    import tomllib

    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]
    assert any(requirement.startswith("jupyterlab") for requirement in extras["notebooks"])
    recipe = subprocess.run(
        ["make", "-n", "-B", "notebooks"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout
    assert '.[notebooks' in recipe and "jupyter lab notebooks" in recipe
    for notebook in (ROOT / "notebooks").glob("*.ipynb"):
        intro = "".join(json.loads(notebook.read_text())["cells"][0]["source"])
        assert "make notebooks" in intro and "stand-in" not in intro, notebook.name
