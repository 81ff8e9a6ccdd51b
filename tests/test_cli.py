"""`python -m quadcos.train`: a smoke run end to end, resume, and one-line errors for bad input."""

import json
import pathlib
import shutil

import numpy as np
import pytest

import quadcos
from quadcos import train
from quadcos._util import caches
from tests.cli_runs import run_in_process

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_smoke_run_writes_a_complete_run_directory(smoke_run):
    config = json.loads((smoke_run / "config.json").read_text())
    assert config["config"]["seed"] == 3
    assert config["run_info"]["env"]["terrain"] == "flat"
    assert {"jax", "brax", "mujoco"} <= set(config["versions"])
    # Its trainer's programs are kept traced beside the compilation cache, for the next run.
    kept = {path.name.split("-")[0] for path in caches.traced_directory().iterdir()}
    assert {"init", "prefill", "train_chunk", "evaluate"} <= kept
    rows = [json.loads(line) for line in (smoke_run / "metrics.jsonl").read_text().splitlines()]
    for key in (
        "step",
        "wall_time_s",
        "eval/episode_reward",
        "eval/forward_speed",
        "eval/fall_rate",
        "eval/episode_length",
        "eval/reward/orientation",
        "eval/slope_error",
        "eval/mean_max_abs_roll",
        "eval/mean_max_abs_pitch_error",
    ):
        assert key in rows[-1], key
    # the attitude's per-episode peaks: a robot on flat ground is never perfectly level
    assert 0 < rows[-1]["eval/mean_max_abs_roll"] < 3.15
    assert rows[-1]["step"] >= 1024
    assert "env_steps_per_s" in rows[-1]
    assert (smoke_run / "metrics.csv").is_file()
    assert any((smoke_run / "checkpoints").iterdir())
    # Where the seconds to the first training step went, in the order it happened.
    record = json.loads((smoke_run / "startup.json").read_text())
    startup = record["seconds"]
    assert list(startup) == [
        "imports",
        "envs_built",
        "trainer_built",
        "programs_traced",  # before the state: they compile while Warp's modules do
        "state_initialised",
        "run_dir_ready",
        "prefill_dispatched",
        "first_chunk",
        "first_evaluation",
    ]
    assert 0 < startup["imports"] and list(startup.values()) == sorted(startup.values())
    # ... and of each event's seconds, JAX's compiling: the smoke run compiles its programs.
    assert list(record["compile"]) == list(startup)
    compiled = record["compile"]["state_initialised"]
    assert compiled["trace_s"] > 0 and compiled["cache_hits"] + compiled["cache_misses"] >= 1
    # The chunk, the prefill and the evaluation were traced together (compiled in threads).
    assert record["compile"]["programs_traced"]["trace_s"] > 0
    policy = quadcos.load_policy(smoke_run)
    # The paper's 14-d state and the filtered command (env.action_filter_tau > 0).
    assert policy.spec.observation_size == 14 + 5
    action = np.asarray(policy.act(np.zeros(policy.spec.observation_size, np.float32)))
    assert action.shape == (5,) and np.all(np.abs(action) <= 1)


@pytest.mark.slow
def test_resume_extends_a_finished_run(smoke_run, tmp_path):
    run_dir = tmp_path / "smoke"
    shutil.copytree(smoke_run, run_dir)  # the shared run stays as it is
    before = [
        json.loads(line)["step"] for line in (run_dir / "metrics.jsonl").read_text().splitlines()
    ]
    argv = json.loads((run_dir / "config.json").read_text())["run_info"]["argv"]
    extended = 1536  # the smoke run's 1024 steps, a refill of 256 and two chunks of 128
    args = (f"--output_dir={run_dir}", "--resume", f"--num_timesteps={extended}", "--no_progress",
            "--config.sac.keep_checkpoints=2")
    result = run_in_process(*args)
    assert result.returncode == 0, result.stderr[-3000:]
    # A change beyond the run's length is said; the first command and the resume's are kept.
    assert "resuming with changed values: sac.keep_checkpoints 3 -> 2" in result.stderr
    assert "num_timesteps" not in result.stderr.split("changed values")[1].splitlines()[0]
    run_info = json.loads((run_dir / "config.json").read_text())["run_info"]
    assert run_info["argv"] == argv and run_info["resumed_argv"] == [list(args)]
    steps = [
        json.loads(line)["step"] for line in (run_dir / "metrics.jsonl").read_text().splitlines()
    ]
    assert steps[: len(before)] == before
    assert steps[-1] >= extended and steps == sorted(steps), (steps, result.stderr[-3000:])
    config = json.loads((run_dir / "config.json").read_text())
    assert config["config"]["num_envs"] == 4  # the run's own preset survived the resume
    # The resumed process's start-up is written too, without a step-0 evaluation.
    startup = json.loads((run_dir / "startup.json").read_text())["seconds"]
    assert "first_chunk" in startup and "first_evaluation" not in startup, startup


@pytest.mark.parametrize(
    "args, message",
    [
        (["--bogus=1"], "unrecognised argument '--bogus=1'"),
        (["--num_envs=many"], "invalid int value"),
        (["--terrain=s5"], "unknown terrain 's5'"),
        (["--terrain=sections:5@"], "bad section"),
        (["--config.sac.nope=3"], "unknown config key 'sac.nope'"),
        (["--config.sac.batch_size=big"], "sac.batch_size"),
        (["--config.env.control_dt=abc"], "'env.control_dt': it takes a float, not a str"),
        (["--seed=2", "--config.sac.seed=1"], "--seed and --config.sac.seed set the same value"),
        (["--population=1", "--print_config"], "runs at least 2 members"),
        (["--population_envs=8"], "--population_envs: for --population only"),
        (["--reward=yx"], "invalid choice"),
        (["--preset=huge"], "invalid choice"),
        (
            ["--config.env.randomization.eval_conditions=robustness"],
            "eval_conditions needs config.env.randomization.enabled",
        ),
        (["--config.env.randomization.eval_conditions=ice"], "unknown condition 'ice'"),
        (
            ["--config.sac.actor_warmup_steps=9", "--config.sac.at_actor_start=sac.num_envs=8"],
            "'sac.num_envs' cannot change while a run trains",
        ),
        (
            ["--config.sac.actor_warmup_steps=9", "--config.sac.at_actor_start=sac.tau=2.0"],
            "config.sac.tau",
        ),
        (
            [
                "--config.sac.actor_warmup_steps=0",
                "--config.sac.at_actor_start=env.reward.forward=9",
            ],
            "at_actor_start needs config.sac.actor_warmup_steps > 0",
        ),
        ([], "--output_dir is required"),
        (["--gait_from=no_such_run"], "--gait_from: no_such_run: no such run or policy directory"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, args, message):
    run_dir = tmp_path / "out"
    argv = args + ([f"--output_dir={run_dir}"] if args else [])
    assert train.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1, err
    assert not run_dir.exists()


def test_an_occupied_output_dir_is_refused(tmp_path, capsys):
    (tmp_path / "config.json").write_text("{}")
    assert train.main(["--preset=smoke", f"--output_dir={tmp_path}"]) == 2
    assert "already holds a run; pass --resume" in capsys.readouterr().err
    assert (tmp_path / "config.json").read_text() == "{}"
    stray = tmp_path / "stray"
    stray.mkdir()
    (stray / "notes.txt").write_text("mine")
    assert train.main(["--preset=smoke", f"--output_dir={stray}"]) == 2
    assert "holds files but no run (no config.json)" in capsys.readouterr().err
    assert [path.name for path in stray.iterdir()] == ["notes.txt"]


def test_resume_of_nothing_is_refused(tmp_path, capsys):
    assert train.main([f"--output_dir={tmp_path / 'none'}", "--resume"]) == 2
    assert "no run to resume" in capsys.readouterr().err


def test_help_documents_every_flag(capsys):
    with pytest.raises(SystemExit):
        train.main(["--help"])
    text = capsys.readouterr().out
    for flag in (
        "--terrain",
        "--num_envs",
        "--num_timesteps",
        "--seed",
        "--output_dir",
        "--gait_from",
        "--resume",
        "--reward",
        "--controller",
        "--preset",
        "--config.KEY=VALUE",
    ):
        assert flag in text, flag


def test_print_config_resolves_presets_and_overrides(capsys):
    assert (
        train.main(
            ["--preset=gpu", "--config.sac.batch_size=1024", "--terrain=s4", "--print_config"]
        )
        == 0
    )
    config = json.loads(capsys.readouterr().out)
    assert config["sac"]["batch_size"] == 1024 and config["sac"]["num_envs"] == 4096
    assert config["env"]["terrain"] == "s4"


def test_gait_from_starts_from_a_run_or_policy_directorys_gait(tmp_path, capsys):
    """`--gait_from=DIR` sets the gait fields (action centre, feed-forward) of DIR's run, so the
    command preset searches none; from a policy directory as from a run directory, refused where
    a value given beside it or no gait found would be lost."""
    policy = ROOT / "experiments/policies/unitree_go1_command"
    saved = json.loads((policy / "policy.json").read_text())["config"]
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "config.json").write_text(json.dumps(saved))
    gait = saved["run_info"]["env"]
    for source in (policy, run_dir):
        assert train.main(["--preset=command", f"--gait_from={source}", "--print_config"]) == 0
        env = json.loads(capsys.readouterr().out)["env"]
        assert env["action_centre"] == gait["action_centre"] != "search"
        assert env["commands"]["speed_map"] == gait["commands"]["speed_map"]
        assert env["commands"]["reference_speed"] == gait["commands"]["reference_speed"]
    given = [f"--gait_from={run_dir}", "--config.env.commands.half_track=0.4", "--print_config"]
    assert train.main(given) == 2
    assert "--gait_from and --config.env.commands.half_track" in capsys.readouterr().err
    saved["run_info"]["env"]["action_centre"] = "search"  # a run stopped before its search ended
    (run_dir / "config.json").write_text(json.dumps(saved))
    assert train.main([f"--gait_from={run_dir}", "--print_config"]) == 2
    assert "its run never found a gait" in capsys.readouterr().err


def test_booleans_read_in_any_case(capsys):
    for text, value in (("true", True), ("False", False), ("TRUE", True)):
        assert train.main([f"--config.sac.keep_best_policy={text}", "--print_config"]) == 0
        assert json.loads(capsys.readouterr().out)["sac"]["keep_best_policy"] is value


# --- one overrides parser for every command line ------------------------------------------------


@pytest.mark.parametrize("text, value", [("true", True), ("False", False), ("1e-3", 1e-3)])
def test_env_values_read_the_same_in_evaluate_as_in_train(text, value):
    from quadcos import evaluate
    from quadcos.deploy import engines

    _, trained = train.resolve([f"--config.env.observe_slope={text}"])
    _, evaluated = engines.parse_command(
        evaluate._parser(), ["--policy=fixed:trot", f"--env.observe_slope={text}"]
    )
    assert trained == {"env.observe_slope": value} and evaluated == {"observe_slope": value}
    assert type(evaluated["observe_slope"]) is type(value)


@pytest.mark.parametrize("command", ["evaluate", "sim2sim", "play"])
def test_every_policy_command_refuses_an_unknown_env_key(command, tmp_path, capsys):
    import importlib

    module = importlib.import_module(f"quadcos.{command}")
    argv = ["--policy=fixed:trot", "--env.observe_slop=true", f"--out={tmp_path / 'r.json'}"]
    assert module.main(argv[:2] if command == "play" else argv) == 2
    err = capsys.readouterr().err.strip()
    assert "unknown config key 'observe_slop'; did you mean observe_slope" in err
    assert len(err.splitlines()) == 1 and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["evaluate", "sim2sim", "bench"])
@pytest.mark.parametrize(
    "flag, message",
    [
        ("--terrain=math:pi", "math.pi is float, not a Terrain"),  # MODULE:NAME gives no Terrain
        ("--robot=menagerie:unitree_go1", "could not fetch Menagerie robot 'unitree_go1'"),
    ],
)
def test_a_terrain_or_robot_that_cannot_be_had_is_one_line(
    command, flag, message, tmp_path, capsys, monkeypatch
):
    import importlib

    # no Menagerie here, and a mirror that does not hold it (refused at once, not retried)
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    monkeypatch.setenv("MENAGERIE_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("MENAGERIE_BASE_URL", f"file://{tmp_path}/mirror/")
    module = importlib.import_module(f"quadcos.{command}")
    out = tmp_path / "out" / "r.json"
    out.parent.mkdir()
    first = ["--only=physics"] if command == "bench" else ["--policy=fixed:trot"]
    assert module.main([*first, flag, f"--out={out}"]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1, err
    assert list(out.parent.iterdir()) == []
