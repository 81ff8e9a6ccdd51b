"""The interfaces of velocity commands (issue 58): C MuJoCo follows them, the ONNX export takes the
command as an input, play's keys steer, bad specs are refused, and every evaluation JSON says how
much training is behind its policy. All on a tiny randomly initialised commanded policy."""

import dataclasses
import json
import math
import pathlib
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import quadcos
from quadcos import env as env_lib
from quadcos import evaluate, evaluation, play, sim2sim
from quadcos.deploy import engines, host_commands, host_robot, twins
from quadcos.deploy import export as export_lib
from quadcos.deploy.onnx_policy import OnnxPolicy
from quadcos.env import commands as env_commands
from quadcos.evaluation import sources
from quadcos.training import Policy, load_policy, save_policy
from quadcos.training.networks import make_networks
from quadcos.training.policy import PolicySpec

ROOT = pathlib.Path(__file__).resolve().parent.parent
FLAT = ROOT / "experiments" / "policies" / "flat"
HIDDEN = (16, 16)


def _commanded_policy(directory: pathlib.Path, turn_mode: str = "none", **saved) -> pathlib.Path:
    """A policy directory with random weights, trained (so its config says) on the flat policy's
    env with random commands and `turn_mode`; `saved`: more keys of its policy.json config."""
    config = json.loads((FLAT / "policy.json").read_text())["config"]
    env = config["run_info"]["env"]
    env["commands"] = env_commands.default_config().to_dict() | {"spec": "random"}
    env["turn_mode"] = turn_mode
    options, terrain = sources.trained_env(config)
    host = host_robot.HostRobot(terrain, evaluation.env_config(trained=options))
    observation_size, action_size = host.reset(0).size, host.action_size
    networks = make_networks(observation_size, action_size, HIDDEN, HIDDEN, True)
    key_policy, key_mean, key_std = jax.random.split(jax.random.PRNGKey(0), 3)
    params = {
        "normalizer": {
            "mean": np.asarray(jax.random.normal(key_mean, (observation_size,))),
            "std": np.asarray(1.0 + jax.random.uniform(key_std, (observation_size,))),
        },
        "policy": networks.policy_network.init(key_policy),
    }
    spec = PolicySpec(observation_size, action_size, HIDDEN, True)
    return save_policy(directory, Policy(spec, params, config | saved))


@pytest.fixture(scope="module")
def commanded(tmp_path_factory) -> pathlib.Path:
    return _commanded_policy(tmp_path_factory.mktemp("commanded") / "policy", env_steps=1234)


# --- C MuJoCo follows the commands ----------------------------------------------------------------


def test_host_robot_observes_the_schedule_it_follows(commanded):
    pilot = host_robot.Pilot.load(str(commanded))
    host = host_robot.HostRobot("flat", pilot.config, commands="0.3,0.1@0.1;0.6,-0.2@1")
    obs = host.reset(0)
    assert obs.size == pilot.spec.observation_size
    np.testing.assert_allclose(obs[-2:], [0.3, 0.1])
    seen = [host.step(pilot.actor()(obs)).obs[-2:] for _ in range(8)]
    np.testing.assert_allclose(seen[-1], [0.6, -0.2])  # past 0.1 s: the second segment
    assert host.commands.heading != 0.0  # ψ* integrates ω*


def test_the_host_robot_warns_of_a_command_beyond_the_trained_ranges(commanded, caplog):
    pilot = host_robot.Pilot.load(str(commanded))  # its config leaves the ranges to the robot
    with caplog.at_level("WARNING", logger="quadcos.env.commands"):
        host_robot.HostRobot("flat", pilot.config, commands="0.3,0@1")
        assert not caplog.records
        host_robot.HostRobot("flat", pilot.config, commands="0.3,0@1;9,0@1")
    assert "segment 2 (v* 9 m/s" in caplog.text and "outside the ranges" in caplog.text


def test_random_commands_are_drawn_in_range_and_resampled():
    config = env_commands.default_config()
    config.update(spec="random", speed_min=0.2, speed_max=0.8, yaw_rate_max=0.4)
    config.resample_seconds = 1.0
    follower = host_commands.HostCommands(config)
    follower.start(3)
    first = follower.velocity.copy()
    assert 0.2 <= first[0] <= 0.8 and abs(first[1]) <= 0.4
    follower.track(0.0, 0.0, 0.0, 0.5, 0.5, 0.1)
    np.testing.assert_array_equal(follower.velocity, first)  # within the period: held
    follower.track(0.0, 0.0, 0.5, 1.0, 0.5, 0.1)
    assert not np.array_equal(follower.velocity, first)  # crossed 1 s: drawn anew
    follower.start(3)
    np.testing.assert_array_equal(follower.velocity, first)  # the reset seed decides


def test_the_host_stands_in_its_share_of_random_draws_and_draws_as_before_without_it():
    config = env_commands.default_config()
    config.update(spec="random", speed_min=0.2, speed_max=0.8, yaw_rate_max=0.4)
    firsts = {}
    for share in (0.0, 0.5):
        config.zero_command_probability = share
        follower = host_commands.HostCommands(config)
        firsts[share] = []
        for seed in range(400):
            follower.start(seed)
            firsts[share].append(follower.velocity.copy())
    walking, standing = np.array(firsts[0.0]), np.array(firsts[0.5])
    still = np.all(standing == 0, axis=1)
    assert abs(still.mean() - 0.5) < 0.1 and walking[:, 0].min() >= 0.2
    # the same speed and yaw-rate draws where it walks (its standing draw comes after them)
    np.testing.assert_array_equal(standing[~still], walking[~still])


def test_commands_for_a_policy_without_them_are_refused():
    with pytest.raises(ValueError, match="not trained with velocity commands"):
        host_robot.HostRobot("flat", evaluation.env_config({}), commands="0.5,0@5")


@pytest.mark.parametrize("mode", ["hip_amplitude_difference", "abduction_stride"])
def test_turn_twins_equal_the_oscillators(mode):
    from quadcos.equations import oscillator

    rhythm, turn = np.random.default_rng(1).normal(size=8), 0.7
    host = getattr(twins, mode)(rhythm, turn, 0.3)
    np.testing.assert_allclose(host, getattr(oscillator, mode)(rhythm, turn, 0.3), atol=1e-6)


@pytest.mark.parametrize("tracking", ["heading", "yaw_rate"])
def test_host_tracking_equals_the_envs(tracking):
    config = env_commands.default_config()
    config.update(spec="0.6,0.3@5", speed_max=1.0, yaw_rate_max=0.5, tracking=tracking)
    config.observed_speed_tau, config.speed_gain_rate, config.heading_gain = 0.3, 1.5, 2.0
    config.yaw_rate_tau = 0.2 if tracking == "yaw_rate" else 0.0
    config.speed_tau = 0.25 if tracking == "yaw_rate" else 0.0
    plan = env_commands.Plan(env_commands.validate(config), config)
    command = plan.start(jax.random.PRNGKey(0))
    follower = host_commands.HostCommands(config)
    follower.start(0)
    yaws = [0.0, 0.02, 0.05, 0.04, 0.3, 0.35]
    for step, (before, yaw) in enumerate(zip(yaws[:-1], yaws[1:])):
        times = (0.05 * step, 0.05 * (step + 1))
        yaw_now, yaw_before = jnp.float32(yaw), jnp.float32(before)
        moved = 0.02 + 0.01 * step
        env_tracking, command = plan.step(
            command, yaw_now, yaw_before, 0.05, *times, jnp.float32(moved)
        )
        host_tracking = follower.track(yaw, before, *times, 0.05, moved)
        assert follower.speed == pytest.approx(float(command.speed), abs=1e-6)
        assert follower.gain == pytest.approx(float(command.gain), abs=1e-6)
        assert follower.correction == pytest.approx(float(command.correction), abs=1e-5)
        assert follower.yaw_rate == pytest.approx(float(command.yaw_rate), abs=1e-5)
        assert follower.tracked_speed == pytest.approx(float(command.tracked_speed), abs=1e-5)
        assert follower.speed > 0 and follower.gain != 1.0
        assert set(host_tracking) == set(env_tracking)
        for key, value in host_tracking.items():
            assert value == pytest.approx(float(env_tracking[key]), abs=1e-5), (step, key)
    assert (follower.yaw_rate != 0) == (tracking == "yaw_rate")  # low-passed only with τ > 0
    assert ("tracked_progress" in host_tracking) == (tracking == "yaw_rate")
    follower.start(1)  # a new episode starts from rest, as the env's reset
    assert (follower.speed, follower.gain, follower.correction, follower.yaw_rate) == (0, 1, 0, 0)
    assert follower.tracked_speed == 0


def test_advance_heading_twin_equals_the_envs():
    rng = np.random.default_rng(2)
    for heading, yaw_rate, yaw in rng.uniform(-3.1, 3.1, (20, 3)):
        original = env_commands.advance_heading(heading, yaw_rate, yaw, 0.05, 0.5)
        host = twins.advance_heading(heading, yaw_rate, yaw, 0.05, 0.5)
        assert host == pytest.approx(float(original), abs=1e-5)


def test_mujoco_evaluation_reports_tracking_and_training_steps(commanded):
    result = engines.evaluate(
        str(commanded), engine="mujoco", episodes=2, seconds=0.5, commands="0.5,0@5"
    )
    summary = result.summary
    assert summary["setup"]["commands"] == "0.5,0@5"
    assert summary["setup"]["policy_env_steps"] == 1234
    for key in ("speed_tracking_rms", "yaw_rate_tracking_rms", "cost_of_transport"):
        assert summary[key] is not None and math.isfinite(summary[key]) and summary[key] >= 0
    episode = result.episodes[0]
    assert episode["speed_tracking_rms"] > 0


def test_policy_env_steps_of_fixed_parameters_is_null():
    summary = engines.evaluate("fixed:trot", engine="mujoco", episodes=1, seconds=0.1).summary
    assert "policy_env_steps" in summary["setup"] and summary["setup"]["policy_env_steps"] is None


def test_policy_env_steps_of_a_best_policy_is_its_step(tmp_path):
    best = _commanded_policy(tmp_path / "policy_best", best_of_run={"step": 0})
    assert evaluation.PolicySpec.parse(str(best)).env_steps == 0  # the search's gait


def test_a_gait_spec_is_its_directorys_zero_action(commanded):
    directory = evaluation.PolicySpec.parse(str(commanded))
    gait = evaluation.PolicySpec.parse(f"gait:{commanded}")
    assert (gait.kind, gait.env_steps, gait.policy) == ("gait", 0, None)
    assert gait.env_options == directory.env_options
    sizes = (gait.observation_size, gait.action_size)
    assert sizes == (directory.observation_size, directory.action_size)
    obs = jnp.ones((3, gait.observation_size))
    source, trained = gait.action_source(), directory.action_source()
    actions = np.asarray(source.act(source.params, obs))
    assert actions.shape == (3, gait.action_size) and not actions.any()
    assert np.asarray(trained.act(trained.params, obs)).any()  # the policy's own are not zero
    assert (source.kind, source.env_steps) == ("gait", 0)


def test_a_gait_runs_in_c_mujoco_as_step_zero(commanded):
    spec = f"gait:{commanded}"
    summary = engines.evaluate(
        spec, engine="mujoco", episodes=1, seconds=0.2, commands="0.5,0@5"
    ).summary
    assert summary["setup"]["policy_kind"] == "gait"
    assert summary["setup"]["policy_env_steps"] == 0
    pilot = host_robot.Pilot.load(spec)
    action = pilot.actor()(np.ones(pilot.spec.observation_size))
    assert action.shape == (pilot.spec.action_size,) and not action.any()


@pytest.mark.parametrize(
    ("text", "error", "says"),
    [
        ("gait:fixed:trot", ValueError, "'gait:fixed:trot': gait: takes a run or policy"),
        ("gait: ", ValueError, "'gait: ': gait: takes a run or policy directory"),
        ("gait:/no/such/policy", FileNotFoundError, "no policy at /no/such/policy"),
    ],
)
def test_a_bad_gait_spec_is_refused(text, error, says):
    with pytest.raises(error, match=says):
        evaluation.PolicySpec.parse(text)


def test_the_gait_of_a_joint_controller_is_refused(commanded, tmp_path):
    directory = tmp_path / "joint"
    directory.mkdir()
    for part in commanded.iterdir():
        (directory / part.name).write_bytes(part.read_bytes())
    saved = json.loads((directory / "policy.json").read_text())
    saved["config"]["run_info"]["env"]["controller"] = "joint"
    (directory / "policy.json").write_text(json.dumps(saved))
    with pytest.raises(ValueError, match="controller is 'joint', whose zero action stands"):
        evaluation.PolicySpec.parse(f"gait:{directory}")


def test_a_gait_does_not_export(commanded, tmp_path):
    with pytest.raises(ValueError, match="not a run or policy directory: only those export"):
        export_lib.export_policy(f"gait:{commanded}", tmp_path / "gait.onnx")
    assert not (tmp_path / "gait.onnx").exists()


# --- the ONNX export ------------------------------------------------------------------------------


@pytest.mark.parametrize("turn_mode", ["none", "hip_amplitude_difference"])
def test_onnx_takes_the_command_as_an_input(tmp_path, turn_mode):
    directory = _commanded_policy(tmp_path / "policy", turn_mode, env_steps=7)
    out = export_lib.export_policy(directory, tmp_path / "commanded.onnx")
    onnx_policy = OnnxPolicy.load(out)
    inputs = {node.name: node.shape for node in onnx_policy.session.get_inputs()}
    size = onnx_policy.observation_size
    assert inputs == {"observation": ["batch", size - 2], "command": ["batch", 2]}
    trained = evaluation.PolicySpec.parse(str(directory)).env_config()
    ranges = host_robot.HostRobot("flat", trained).config.commands
    assert onnx_policy.command_ranges == {
        key: pytest.approx(ranges[key])
        for key in ("speed_min", "speed_max", "yaw_rate_max", "resample_seconds")
    }
    assert onnx_policy.command_ranges["speed_max"] > 0  # resolved to the robot's
    rng = np.random.default_rng(0)
    observations = rng.normal(size=(32, size - 2)).astype(np.float32)
    command = rng.uniform(-1, 1, (32, 2)).astype(np.float32)
    (onnx_actions,) = onnx_policy.session.run(
        ["action"], {"observation": observations, "command": command}
    )
    whole = np.concatenate([observations, command], axis=-1)
    jax_actions = np.asarray(load_policy(directory).act(whole))
    assert np.abs(onnx_actions - jax_actions).max() <= 1e-5
    assert np.abs(onnx_policy(whole[0]) - jax_actions[0]).max() <= 1e-5  # split by OnnxPolicy
    assert evaluation.PolicySpec.parse(str(out)).env_steps == 7


# --- play's keys ----------------------------------------------------------------------------------


RANGES = {"speed_min": 0.0, "speed_max": 1.0, "yaw_rate_max": 0.5}


@pytest.mark.parametrize(
    "key, command, expected",
    [
        (play.KEY_UP, (0.5, 0.0), (0.6, 0.0)),
        (play.KEY_DOWN, (0.5, 0.2), (0.4, 0.2)),
        (play.KEY_LEFT, (0.5, 0.2), (0.5, 0.3)),
        (play.KEY_RIGHT, (0.5, 0.2), (0.5, 0.1)),
        (play.KEY_UP, (1.0, 0.0), (1.0, 0.0)),  # clipped to the range
        (play.KEY_DOWN, (0.0, 0.0), (0.0, 0.0)),
        (play.KEY_LEFT, (0.0, 0.5), (0.0, 0.5)),
        (play.KEY_RIGHT, (0.0, -0.45), (0.0, -0.5)),
        (play.KEY_SPACE, (0.8, -0.3), (0.0, 0.0)),
    ],
)
def test_steer_keys(key, command, expected):
    np.testing.assert_allclose(play.steer(key, command, RANGES), expected)


def test_steer_ignores_other_keys():
    assert play.steer(play.KEY_R, (0.5, 0.0), RANGES) is None


def test_play_session_is_steered(commanded):
    pilot = host_robot.Pilot.load(str(commanded))
    session = play.Session(pilot, host_robot.HostRobot("flat", pilot.config))
    session.key(play.KEY_SPACE)
    session.key(play.KEY_UP)
    session.advance()
    np.testing.assert_allclose(session.obs[-2:], [0.1, 0.0])
    assert not session.paused
    session.key(play.KEY_P)
    assert session.paused


# --- the command lines refuse a bad spec ----------------------------------------------------------


@pytest.mark.parametrize("module", [evaluate, sim2sim])
@pytest.mark.parametrize("spec", ["fast", "0.5@5", "0.5,0@-1"])
def test_a_bad_commands_spec_is_one_line_and_writes_nothing(tmp_path, capsys, module, spec):
    out = tmp_path / "eval.json"
    argv = ["--policy=fixed:trot", f"--commands={spec}", f"--out={out}"]
    assert module.main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "command" in lines[0]
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_an_evaluation_without_out_prints_its_tracking_and_writes_nothing(
    commanded, tmp_path, capsys, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    argv = [f"--policy={commanded}", "--engine=mujoco", "--commands=0.5,0@5", "--num_envs=1"]
    assert evaluate.main([*argv, "--seconds=1.0", "--no_progress"]) == 0  # two 0.5-s windows
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith("1 episode on flat in C MuJoCo: success")
    assert re.search(r"tracking \d+\.\d{3} m/s, \d+\.\d{3} rad/s RMS$", line), line
    assert list(tmp_path.iterdir()) == []


def test_sim2sim_follows_commands(commanded, tmp_path, capsys):
    out = tmp_path / "commanded.json"
    argv = [f"--policy={commanded}", "--commands=0.4,0.2@5", "--episodes=1", "--seconds=0.6"]
    assert sim2sim.main([*argv, f"--out={out}", "--no_progress"]) == 0
    summary = json.loads(out.read_text())
    assert summary["setup"]["commands"] == "0.4,0.2@5"
    assert summary["yaw_rate_tracking_rms"] is not None


@pytest.mark.parametrize(
    "robot, turn_mode, feed_forward",
    [
        ("quadcos", "hip_amplitude_difference", False),
        ("quad12", "abduction_stride", False),
        ("quadcos", "hip_amplitude_difference", True),
    ],
)
def test_host_joint_targets_turn_as_the_envs(robot, turn_mode, feed_forward):
    from quadcos import env as env_lib

    options = dict(robot=robot, turn_mode=turn_mode, posture_bound=0.2, start_ramp_s=0.5)
    if feed_forward:  # the command (0.4 m/s, 0.3 rad/s) scales each side's hip swing
        options |= {"commands.spec": "0.4,0.3@5", "commands.feed_forward": True}
    config = evaluation.env_config(options)
    host = host_robot.HostRobot("flat", config)
    mjx_env = env_lib.QuadrupedEnv("flat", config)
    host.reset(0)
    host.command = np.random.default_rng(3).uniform(-1, 1, host.action_size)
    host.phase, host.data.time = 1.3, 0.3
    drive = mjx_env.drive_for(np.float32([0.4, 0.3])) if feed_forward else None
    original = mjx_env.joint_targets(host.command.astype(np.float32), 1.3, 0.3, drive)
    straight = host.command.copy()
    straight[-1] = 0.0
    targets = host._joint_targets  # noqa: SLF001
    turned = targets(host.rhythm_parameters())
    np.testing.assert_allclose(turned, original, atol=1e-5)
    host.command = straight
    assert np.abs(turned - targets(host.rhythm_parameters())).max() > 1e-3  # the turn acts
    if feed_forward:  # the drive acts: without it the hips swing otherwise
        plain = mjx_env.joint_targets(host.command.astype(np.float32), 1.3, 0.3)
        assert np.abs(targets(host.rhythm_parameters()) - plain).max() > 1e-3


def test_tracking_reward_twin_equals_the_envs():
    from quadcos.equations import reward, slope

    rng = np.random.default_rng(4)
    for _ in range(10):
        x, y, angles = rng.normal(size=2) * 0.05, rng.normal(size=2) * 0.05, rng.normal(size=5)
        body = slope.Attitude(roll=angles[0] * 0.1, pitch=angles[1] * 0.1, yaw=angles[2])
        common = dict(x_now=x[0], x_last=x[1], y_now=y[0], y_last=y[1], fell=False, moving=True)
        tracking = dict(heading=angles[3], commanded_progress=abs(angles[4]) * 0.05)
        if rng.uniform() < 0.5:
            tracking["yaw_rate_error"] = angles[4]
        if rng.uniform() < 0.5:  # the progress low-passed (`commands.speed_tau`)
            tracking["tracked_progress"] = rng.normal() * 0.05
        if rng.uniform() < 0.5:  # the rate term beyond the paper
            tracking["action_change"] = rng.normal(size=6).astype(np.float32) * 0.1
        weights = reward.RewardWeights(action_rate=float(rng.uniform(0.0, 20.0)))
        shared = {**common, **tracking, "max_progress": 0.03}
        host = twins.reward_terms(
            **shared, body=body, slope_estimate=0.0, weights=weights, variant="full"
        )
        angles = dict(pitch=body.pitch, yaw=body.yaw, roll=body.roll, slope=0.0)
        original = reward.reward_terms(**shared, **angles, weights=weights)
        for term in reward.TERM_NAMES:
            assert host[term] == pytest.approx(float(original[term]), abs=1e-5)


@pytest.mark.slow  # an MJX compile: ~45 s on the CPU
def test_mjx_evaluation_records_policy_env_steps(commanded):
    result = evaluation.evaluate(str(commanded), num_envs=2, seconds=0.5, commands="0.5,0@5")
    assert result.summary["setup"]["policy_env_steps"] == 1234
    assert result.summary["speed_tracking_rms"] is not None
    gait = evaluation.evaluate(f"gait:{commanded}", num_envs=2, seconds=0.5, commands="0.5,0@5")
    assert gait.summary["setup"]["policy_kind"] == "gait"
    assert gait.summary["setup"]["policy_env_steps"] == 0
    # the same env, another actor: the policy's random weights move the rhythm off its centre
    assert gait.summary["mean_forward_speed"] != result.summary["mean_forward_speed"]
    # the top-level API follows the same commands (the same compiled program)
    same = quadcos.evaluate_policy(str(commanded), episodes=2, seconds=0.5, commands="0.5,0@5")
    assert same.summary["speed_tracking_rms"] == result.summary["speed_tracking_rms"]


# --- the feed-forward measured on a gait ----------------------------------------------------------


def test_the_feed_forward_leaves_out_the_walks_that_fall(monkeypatch):
    from quadcos.deploy import calibration

    # a robot's fall leaves the others' speed; more than half of them falling voids the walk
    assert calibration.standing_mean([0.4, math.nan], 1) == 0.4
    assert math.isnan(calibration.standing_mean([math.nan, math.nan, 0.3], 2))

    def walk(config, schedule, seed, robots, friction=None):  # falls on ice with long strides
        # the open-loop gait is walked: a drive's gain would make every scale walk its command,
        # its heading loop the side difference turn at ω*
        assert config.commands.speed_gain_rate == 0.0 and config.commands.heading_gain == 0.0
        scale = float(schedule.split(",")[0])
        if friction == 0.4 and scale > 0.5:
            return math.nan, math.nan
        return 0.5 * scale * (friction or 1.0), 0.2

    monkeypatch.setattr(calibration, "_walk", walk)
    config = evaluation.env_config(
        {
            "commands.spec": "random",
            "commands.feed_forward": True,
            "randomization.enabled": True,
            "randomization.friction": (0.4, 1.5),
            "commands.speed_gain_rate": 1.0,
            "commands.heading_gain": 2.0,
        }
    )
    measured = calibration.measure(config)
    # the map: each scale's mean speed over the frictions (0.4, 0.95, 1.5) it stays up at
    standing = {0.25: (0.4, 0.95, 1.5), 0.5: (0.4, 0.95, 1.5), 0.75: (0.95, 1.5), 1.0: (0.95, 1.5)}
    expected = [
        np.mean([0.5 * scale * f for f in frictions]) for scale, frictions in standing.items()
    ]
    assert measured["speed_map"] == pytest.approx(expected, abs=1e-4)
    assert measured["reference_speed"] == pytest.approx(0.5)


def test_a_gait_that_barely_turns_by_its_strides_is_warned_of(monkeypatch, caplog):
    from quadcos.deploy import calibration

    def walk(config, schedule, seed, robots, friction=None):  # 0.6 m/s a scale; sides barely turn
        return 0.6 * float(schedule.split(",")[0]), 0.03

    monkeypatch.setattr(calibration, "_walk", walk)
    config = evaluation.env_config({"commands.spec": "random", "commands.feed_forward": True})
    with caplog.at_level("WARNING", logger=calibration.logger.name):
        measured = calibration.measure(config)
    # b = 0.3 * 0.6 / 0.03 = 6 m: the top turn (0.5 rad/s) asks each side for 3 m/s
    assert measured["half_track"] == pytest.approx(6.0)
    assert "asks each side for -/+ 3.00 m/s, more than the gait's 0.60 m/s" in caplog.text
    assert "turns above 0.10 rad/s saturate" in caplog.text


def test_the_run_keeps_the_searched_gait_that_turns_both_ways(monkeypatch, caplog):
    from quadcos.deploy import calibration
    from quadcos.evaluation import gait_search
    from quadcos.training import presets

    # the search's ranking (best first): a gait that turns only right, one that fell, one that
    # turns both ways walking backwards, one that turns both ways, one that turns them better
    one_way, fell, backwards, both, better = (
        f"0.1,0.2,0.3,{phi},{phi - 3.14:g}" for phi in (0, 1, 1.5, 2, 3)
    )
    ranking = [
        {"parameters": dict(zip("abcde", map(float, centre.split(",")), strict=True)),
         "score": score}
        for centre, score in
        ((one_way, 9.0), (fell, None), (backwards, 8.0), (both, 7.0), (better, 6.0))
    ]  # fmt: skip
    turning = {one_way: (0.007, -0.5), fell: (0.3, -0.3), backwards: (0.3, -0.3), both: (0.2, -0.25),
               better: (0.4, -0.4)}  # fmt: skip
    walked = []

    def walk(config, schedule, seed, robots, friction=None):  # (speed, yaw rate) by side scales
        walked.append((config.action_centre, schedule))
        side = float(schedule.split(",")[1].split("@")[0])
        left, right = turning[config.action_centre]
        speed = -0.1 if config.action_centre == backwards else 0.6 * float(schedule.split(",")[0])
        return speed, {0.0: 0.0, 0.3: left, -0.3: right}[side]

    monkeypatch.setattr(calibration, "_walk", walk)
    search = {"action_centre": one_way, "ranking": ranking}
    monkeypatch.setattr(gait_search, "find_gait", lambda config: search)
    config = presets.build_config(presets.PRESETS["command"], {})
    with caplog.at_level("WARNING", logger=calibration.logger.name):
        found = calibration.find_gait(config)
    # the next in rank that walks and turns both ways, not the fallen one, the one walking
    # backwards nor the better-turning lower one
    assert found["action_centre"] == both
    assert "turn one way at most with the sides at 1 -/+ 0.3 / 1 +/- 0.3 (+0.007 / -0.500" in (
        caplog.text
    )
    assert f"its #3, {both}, turns +0.200 / -0.250 rad/s: kept" in caplog.text
    assert fell not in {centre for centre, _ in walked} and better not in {c for c, _ in walked}
    # its feed-forward is measured on that gait: b = 0.3 * 0.6 / 0.2
    assert found["feed_forward"]["half_track"] == pytest.approx(0.9)
    # where none turns both ways the best is kept, and said so
    search["ranking"] = ranking[:2]
    with caplog.at_level("WARNING", logger=calibration.logger.name):
        assert calibration.find_gait(config)["action_centre"] == one_way
    assert "none of the search's 1 best gaits turns both ways" in caplog.text


def test_the_feed_forward_is_measured_on_the_gait_and_applied_to_the_run(monkeypatch, tmp_path):
    from quadcos.deploy import calibration
    from quadcos.training import presets, session

    monkeypatch.setattr(calibration, "SETTLE_S", 0.5)
    monkeypatch.setattr(calibration, "MEASURE_S", 1.0)
    config = evaluation.env_config({"commands.spec": "random", "commands.feed_forward": True})
    measured = calibration.measure(config, robots=1)
    # the paper's robot trots forward at scale 1 and turns with its sides apart (the fixed trot
    # turns right with the right side's longer strides: b < 0)
    assert measured["speed"] > calibration.MIN_SPEED
    assert measured["reference_speed"] == pytest.approx(measured["speed"], abs=1e-4)
    assert abs(measured["yaw_rate"]) > calibration.MIN_YAW_RATE
    # its speed map: the straight speed at each scale (without randomisation, on the MJCF's
    # ground), growing with the scale, scale 1's the reference walk's; b from its speed per scale
    speeds = measured["speed_map"]
    assert len(speeds) == len(host_robot.env_commands.SPEED_MAP_SCALES)
    assert all(a < b for a, b in zip((0.0, *speeds), speeds, strict=False))
    assert speeds[-1] == pytest.approx(measured["speed"], abs=1e-4)
    slope = speeds[-1]  # m/s per unit of scale, the map's mean
    expected = calibration.SIDE_DIFFERENCE * slope / measured["yaw_rate"]
    assert measured["half_track"] == pytest.approx(expected, rel=1e-3)
    # a gait that does not walk keeps the config's values (v_ref = speed_max)
    standing = evaluation.env_config(
        {
            "commands.spec": "random",
            "commands.feed_forward": True,
            "action_centre": "0.01,0.01,1,0,3.14",
        }
    )
    kept = calibration.measure(standing, robots=1)
    assert kept["reference_speed"] == host_robot.env_lib.resolve(standing).commands.speed_max
    # training.run's search step puts what the search measured into the run's config
    run = presets.build_config({"env.action_centre": "search"}, {})
    found = {
        "action_centre": "0.1,0.2,0.3,0,3.14",
        "feed_forward": {
            "reference_speed": 0.7,
            "half_track": 0.4,
            "speed_map": (0.2, 0.4, 0.55, 0.7),
        },
    }
    session._resolve_centre(run, tmp_path, lambda config: found)  # noqa: SLF001
    assert run.env.action_centre == found["action_centre"]
    assert (run.env.commands.reference_speed, run.env.commands.half_track) == (0.7, 0.4)
    assert run.env.commands.speed_map == (0.2, 0.4, 0.55, 0.7)


def test_track_gaits_keeps_the_best_tracking_gait_that_never_fell(monkeypatch, caplog):
    from quadcos.deploy import calibration
    from quadcos.evaluation import gait_search, gait_tracking
    from quadcos.training import presets

    one_way, first, second, third = (f"0.1,0.2,0.3,{phi},{phi - 3.14:g}" for phi in (0, 1, 2, 3))
    ranking = [
        {"parameters": dict(zip("abcde", map(float, centre.split(",")), strict=True)), "score": 1.0}
        for centre in (one_way, first, second, third)
    ]
    turning = {one_way: (0.007, -0.5), first: (0.2, -0.2), second: (0.3, -0.3), third: (0.4, -0.4)}

    def walk(config, schedule, seed, robots, friction=None):
        side = float(schedule.split(",")[1].split("@")[0])
        left, right = turning[config.action_centre]
        return 0.6 * float(schedule.split(",")[0]), {0.0: 0.0, 0.3: left, -0.3: right}[side]

    tracked = []  # each call's gaits: (centre, half track b of its measured feed-forward)

    def track(terrain, configs, seed=0):
        tracked.append([(c.action_centre, c.commands.half_track) for c in configs])
        lines = {  # first tracks best but falls; third tracks better than second but rolls
            first: (0.01, 0.05, 0.05, 0.05), second: (0.0, 0.09, 0.08, 0.07),
            third: (0.0, 0.07, 0.06, 0.12),
        }
        return [
            dict(zip(("fall_rate", "speed_tracking_rms", "yaw_rate_tracking_rms",
                      "mean_max_abs_roll"), lines[c.action_centre]), mean_max_abs_pitch_error=0.05,
                 score=-max(lines[c.action_centre][1] / 0.1, lines[c.action_centre][2] / 0.15))
            for c in configs
        ]  # fmt: skip

    monkeypatch.setattr(calibration, "_walk", walk)
    monkeypatch.setattr(gait_tracking, "track", track)
    monkeypatch.setattr(gait_search, "find_gait", lambda config: {"action_centre": one_way,
                                                                  "ranking": ranking})
    config = presets.build_config(presets.PRESETS["command"], {"sac.gait_search.track_gaits": 3})
    with caplog.at_level("INFO", logger=calibration.logger.name):
        found = calibration.find_gait(config)
    # the three that turn both ways, each with its own feed-forward (b = 0.3 * 0.6 / left)
    assert tracked == [[(first, pytest.approx(0.9)), (second, pytest.approx(0.6)),
                        (third, pytest.approx(0.45))]]  # fmt: skip
    assert found["action_centre"] == third  # no attitude bound: the better of the clean ones
    assert found["feed_forward"]["half_track"] == pytest.approx(0.45)
    assert [g["action_centre"] for g in found["tracked_gaits"]] == [first, second, third]
    assert f"gait tracking #3 {third}: 0.0 % falls, 0.070 m/s" in caplog.text
    bounded = presets.build_config(
        presets.PRESETS["command"],
        {"sac.gait_search.track_gaits": 3, "sac.gait_search.max_attitude": 0.1},
    )
    assert calibration.find_gait(bounded)["action_centre"] == second  # third rolls 0.12
    # scored against an attitude target instead: third's roll 0.12 / 0.10 is worse than second's
    # worst ratio (0.09 m/s / 0.10); with a looser target third's tracking wins again
    for target, kept in ((0.1, second), (0.2, third)):
        scored = presets.build_config(
            presets.PRESETS["command"],
            {"sac.gait_search.track_gaits": 3, "sac.gait_search.track_attitude": target},
        )
        assert calibration.find_gait(scored)["action_centre"] == kept
    with pytest.raises(presets.UsageError, match="track_gaits must be a whole number >= 0"):
        presets.build_config(presets.PRESETS["command"], {"sac.gait_search.track_gaits": -1})


def test_gaits_given_as_data_walk_as_envs_built_with_them():
    from quadcos.evaluation import gait_tracking
    from quadcos.evaluation import rollout as rollout_lib

    base = evaluation.env_config({"commands.spec": "random", "commands.feed_forward": True,
                                  "commands.reference_speed": 0.8, "commands.half_track": 0.5})
    other = evaluation.env_config({"commands.spec": "random", "commands.feed_forward": True,
                                   "commands.reference_speed": 0.5, "commands.half_track": 0.9,
                                   "action_centre": "0.45,0.3,0.35,-3.14159,0"})
    source = sources.ActionSource(
        name="gait", kind="gait", act=sources.zero_action, params=np.zeros(1, np.float32),
        env_overrides={}, training_terrain="flat",
    )  # fmt: skip
    built = env_lib.QuadrupedEnv("flat", other)
    source = dataclasses.replace(source, params=np.zeros(built.action_size, np.float32))
    maps = gait_tracking.gait_maps(other)
    assert maps.keys() == built.gait.keys()
    for name in maps:
        np.testing.assert_array_equal(maps[name], built.gait[name])
    own = rollout_lib.rollout(built, source, num_envs=2, num_steps=10, seed=3).stats
    # Given as data, to three copies of own's two robots (their episode keys): the program that
    # `track` below runs (three gaits of two robots for 10 steps), compiled once for both.
    gaits = {name: np.stack([value] * 6) for name, value in maps.items()}
    keys = jnp.tile(jax.random.split(jax.random.PRNGKey(3), 2), (3, 1))
    given = rollout_lib.rollout(
        env_lib.QuadrupedEnv("flat", base), source, num_envs=6, num_steps=10, gaits=gaits,
        keys=keys,
    ).stats  # fmt: skip
    np.testing.assert_allclose(given.x, np.tile(own.x, 3), atol=1e-6)
    np.testing.assert_allclose(
        given.tracking.speed_sq_error, np.tile(own.tracking.speed_sq_error, 3), atol=1e-6
    )
    lines = gait_tracking.track("flat", [base, other, base], robots=2, seconds=0.5, seed=3)
    assert len(lines) == 3 and all(line["fall_rate"] == 0.0 for line in lines)
    assert lines[0]["speed_tracking_rms"] != lines[1]["speed_tracking_rms"]  # each its own gait
    assert lines[2] == lines[0]  # on the same episodes: the same gait, the same line
    for line in lines:
        worse = max(line["speed_tracking_rms"] / 0.10, line["yaw_rate_tracking_rms"] / 0.15)
        assert line["score"] == pytest.approx(-worse)
    rolls = gait_tracking.score(0.05, 0.06, attitude=0.15, attitude_target=0.1)
    assert rolls == pytest.approx(-1.5)
    assert gait_tracking.score(0.05, 0.06, attitude=0.15) == pytest.approx(-0.5)  # target off
    with pytest.raises(ValueError, match="one row per robot"):
        rollout_lib.rollout(built, source, num_envs=2, num_steps=1, gaits={
            name: value[:1] for name, value in gaits.items()})


def test_summary_line_counts_the_episodes_a_course_outlasted():
    summary = {
        "num_episodes": 8, "success_rate": 0.5, "fall_rate": 0.125, "mean_forward_speed": 0.4,
        "setup": {"terrain": "s4", "course_end_x": 10.0},
    }
    line = engines.summary_line(summary, "mjx")
    assert line.startswith("8 episodes on s4: success 0.500") and "3 out of time" in line
    one = {**summary, "num_episodes": 1, "success_rate": 1.0, "fall_rate": 0.0}
    assert engines.summary_line(one, "mujoco").startswith("1 episode on s4 in C MuJoCo:")
    assert "out of time" not in engines.summary_line(one, "mujoco")
    flat = {**summary, "setup": {"terrain": "flat"}}  # no course: the time limit is the episode
    assert "out of time" not in engines.summary_line(flat, "mjx")
