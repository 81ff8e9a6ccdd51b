"""`quadcos.deploy.twins` against their JAX originals, the controller path in C MuJoCo (the mujoco
engine of `quadcos.deploy.engines.evaluate`, `quadcos.sim2sim`), and `quadcos.play` without a
display."""

import json
import math
import pathlib

import mujoco
import numpy as np
import pytest

from quadcos import evaluation, play, sim2sim, terrain
from quadcos.deploy import engines, host_robot, twins
from quadcos.deploy import export as export_lib
from quadcos.equations import oscillator, reward, slope

ROOT = pathlib.Path(__file__).resolve().parent.parent
FLAT_POLICY = str(ROOT / "experiments" / "policies" / "flat")
RNG = np.random.default_rng(16)


def _mujoco(policy, terrain=None, **options):
    """The evaluation JSON of `policy` in the mujoco engine."""
    return engines.evaluate(policy, terrain, engine="mujoco", **options).to_json()


# --- the twins -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "centre, scale",
    [(oscillator.FIXED_TROT, 1.0), (None, 1.0), (None, 0.4), (None, np.array([0.3, 0.3, 0, 0, 1]))],
)
def test_oscillator_twins(centre, scale):
    for _ in range(20):
        action = RNG.uniform(-1.3, 1.3, 5)
        params = twins.action_to_parameters(action, 0.2, centre, scale)
        np.testing.assert_allclose(
            params,
            oscillator.action_to_parameters(action, 0.2, centre, scale),
            rtol=1e-6,
            atol=1e-6,
        )
        phases = twins.trot_phases(params.phi1, params.phi3)
        expected = oscillator.trot_phases(params.phi1, params.phi3)
        np.testing.assert_allclose(phases, expected, atol=1e-6)
        phase = RNG.uniform(0, 2 * np.pi)
        np.testing.assert_allclose(
            twins.rhythm_at_phase(phase, params.amplitude_hip, params.amplitude_knee, phases),
            oscillator.rhythm_at_phase(phase, params.amplitude_hip, params.amplitude_knee, phases),
            atol=1e-6,
        )
        assert twins.advance_phase(phase, params.period, 0.005) == pytest.approx(
            float(oscillator.advance_phase(phase, params.period, 0.005)), abs=1e-5
        )
        posture = RNG.uniform(-1.3, 1.3, 2)
        np.testing.assert_allclose(
            twins.posture_offsets(posture, 0.6), oscillator.posture_offsets(posture, 0.6), atol=1e-6
        )
        time, ramp = RNG.uniform(0, 1.0), RNG.choice([0.0, 0.5])
        assert twins.start_ramp(time, ramp) == pytest.approx(
            float(oscillator.start_ramp(time, ramp)), abs=1e-6
        )


def test_slope_twins():
    for _ in range(50):
        quaternion = RNG.normal(size=4)
        quaternion /= np.linalg.norm(quaternion)
        feet = RNG.uniform(-0.4, 0.4, (4, 3)) + np.array(
            [[0.3, 0, -0.6]] * 2 + [[-0.3, 0, -0.6]] * 2
        )
        expected = slope.attitude(quaternion)
        np.testing.assert_allclose(twins.attitude(quaternion), expected, atol=1e-5)
        assert twins.estimate_slope(feet, quaternion) == pytest.approx(
            float(slope.estimate_slope(feet, quaternion)), abs=1e-5
        )


@pytest.mark.parametrize(
    "ground",
    [
        terrain.get("s4"),
        terrain.heightfield(lambda x, y: 0.1 * np.sin(x) * np.cos(2 * y), x_range=(-2, 5)),
    ],
)
def test_terrain_twins(ground):
    x, y = RNG.uniform(-3, 12, 200), RNG.uniform(-3, 3, 200)
    np.testing.assert_allclose(twins.height_at(ground, x, y), ground.height_at(x, y), atol=1e-5)
    np.testing.assert_allclose(twins.slope_at(ground, x, y), ground.slope_at(x, y), atol=1e-5)


@pytest.mark.parametrize("variant", reward.VARIANTS)
@pytest.mark.parametrize("fell", [False, True])
@pytest.mark.parametrize("max_progress", [np.inf, 0.01])
def test_reward_twin(variant, fell, max_progress):
    x, y, angles = RNG.normal(size=4), RNG.normal(size=2), RNG.normal(size=4) * 0.2
    body = slope.Attitude(roll=angles[0], pitch=angles[1], yaw=angles[2])
    weights = reward.RewardWeights()
    common = dict(
        x_now=x[0],
        x_last=x[1],
        y_now=y[0],
        y_last=y[1],
        fell=fell,
        moving=False,
        max_progress=max_progress,
    )
    host = twins.reward_terms(
        **common, body=body, slope_estimate=angles[3], weights=weights, variant=variant
    )
    original = reward.reward_terms(
        **common,
        pitch=body.pitch,
        yaw=body.yaw,
        roll=body.roll,
        slope=angles[3],
        weights=weights,
        variant=variant,
    )
    assert set(host) == set(reward.TERM_NAMES)
    for term in reward.TERM_NAMES:
        assert host[term] == pytest.approx(float(original[term]), abs=1e-4)


# --- the controller path in C MuJoCo -------------------------------------------------------------


def test_reset_stands_on_the_ramp_with_the_env_pose():
    host = host_robot.HostRobot("slope5", evaluation.env_config({}))
    obs = host.reset(0, x=3.5)  # on the 5° uphill
    pitch, slope_estimate = obs[3], host.step(np.zeros(5)).slope_estimate
    assert pitch == pytest.approx(math.radians(5), abs=0.01)
    assert slope_estimate == pytest.approx(math.radians(5), abs=0.03)
    joints = host.data.qpos[7:15].copy()
    noise = host.config.reset_joint_noise
    host.reset(1)
    assert np.abs(host.data.qpos[7:15]).max() <= noise
    assert not np.allclose(host.data.qpos[7:15], joints)  # another seed, other noise


def test_observation_layout_follows_the_config():
    config = evaluation.env_config(
        {"observe_slope": True, "observe_phase": True, "action_filter_tau": 0.0}
    )
    host = host_robot.HostRobot("flat", config)
    host.reset(0)
    result = host.step(np.full(5, 0.2))
    assert result.obs.shape == (14 + 1 + 2,)
    assert result.obs[14] == result.slope_estimate
    np.testing.assert_allclose(result.obs[15:], [math.cos(host.phase), math.sin(host.phase)])
    assert 0 < host.phase < 2 * np.pi
    filtered = host_robot.HostRobot("flat", evaluation.env_config({}))
    filtered.reset(0)
    obs = filtered.step(np.ones(5)).obs
    assert obs.shape == (19,)  # the command: 10 substeps of a 0.25-s low-pass towards 1
    np.testing.assert_allclose(obs[14:], 1 - math.exp(-0.05 / 0.25), rtol=1e-6)


def test_the_host_robot_observes_the_gyro_where_the_env_does():
    """`observe_angular_velocity`: the torso's angular velocity in its own frame (the free
    joint's qvel[3:6]) after the filtered action, as `quadcos.env.observation.observe` has it."""
    host = host_robot.HostRobot("flat", evaluation.env_config({"observe_angular_velocity": True}))
    assert host.reset(0).shape == (14 + 5 + 3,)
    for _ in range(3):
        obs = host.step(np.full(5, 0.3)).obs
    np.testing.assert_array_equal(obs[19:22], host.data.qvel[3:6])
    assert np.abs(obs[19:22]).max() > 1e-3


def test_a_rolled_robot_falls():
    host = host_robot.HostRobot("flat", evaluation.env_config({}))
    host.reset(0)
    host.data.qpos[3:7] = [math.cos(0.5), math.sin(0.5), 0.0, 0.0]  # 1 rad roll
    assert host.step(np.zeros(5)).fell


@pytest.mark.parametrize("min_speed, survival", [(0.0, 10.0), (0.5, 0.0)])
def test_survival_pays_a_step_backwards_only_without_a_min_speed(min_speed, survival):
    host = host_robot.HostRobot("flat", evaluation.env_config({"survival_min_speed": min_speed}))
    host.reset(0)
    host.data.qvel[0] = -1.0  # pushed backwards
    result = host.step(np.zeros(5))
    assert result.forward_speed < 0 and result.reward_terms["survival"] == survival


@pytest.mark.parametrize("frame, survival", [("x", 0.0), ("heading", 10.0)])
def test_moving_is_judged_along_the_heading_where_the_frame_says(frame, survival):
    """A robot facing -x walking forward 1 m/s: backwards along x, forwards along its heading."""
    config = evaluation.env_config({"survival_min_speed": 0.5, "survival_speed_tau": 0.0,
                                    "survival_speed_frame": frame})
    host = host_robot.HostRobot("flat", config)
    host.reset(0)
    host.data.qpos[3:7] = [0.0, 0.0, 0.0, 1.0]  # yaw π
    host.data.qvel[0] = -1.0
    mujoco.mj_forward(host.model, host.data)  # the IMU reads the turned pose
    assert host.step(np.zeros(5)).reward_terms["survival"] == survival
    with pytest.raises(ValueError, match="survival_speed_frame"):
        evaluation.env_config({"survival_speed_frame": "y"})


def test_the_host_robot_charges_the_commands_change_as_the_env_does():
    """`reward.action_rate` w: −w Σ Δc² for the step's command change Δc (the env's
    test_action_rate_charges_the_commands_change_in_the_step); off (0) by default."""
    action = np.array([0.2, -0.1, 0.05, 0.1, -0.3])
    for weight in (0.0, 10.0):
        host = host_robot.HostRobot("flat", evaluation.env_config({"reward.action_rate": weight}))
        host.reset(0)
        terms = []
        for step_action in (action, -action, -action):
            before = host.command.copy()
            paid = host.step(step_action).reward_terms["action_rate"]
            terms.append(paid)
            assert paid == pytest.approx(-weight * np.sum((host.command - before) ** 2))
        assert (terms[1] < terms[0] < 0) if weight else terms == [0.0, 0.0, 0.0]


def test_cli_writes_an_evaluation_json(tmp_path, capsys):
    out = tmp_path / "trot.json"
    args = ["--policy=fixed:trot", "--terrain=flat", "--episodes=2", "--seconds=2", f"--out={out}"]
    assert sim2sim.main([*args, "--no_progress"]) == 0
    result = json.loads(out.read_text())
    assert result["num_episodes"] == 2 and result["setup"]["engine"] == "mujoco"
    assert result["setup"]["robot"]["name"] == "quadcos"
    assert result["success_rate"] == 1.0 and result["mean_forward_speed"] > 0.3
    assert result["episodes"][0]["reset_seed"] == [0, 0]
    assert "2 episodes on flat in C MuJoCo: success 1.000" in capsys.readouterr().out


def test_reference_physics_converges_where_training_takes_the_presets_shortcut(tmp_path):
    # quad12's preset trains with 4 / 8 solver iterations; the reference keeps the MJCF's (100 / 50).
    config = evaluation.env_config({"robot": "quad12"})
    training = host_robot.HostRobot("flat", config, physics="training")
    reference = host_robot.HostRobot("flat", config)
    assert (training.model.opt.iterations, training.model.opt.ls_iterations) == (4, 8)
    assert (reference.model.opt.iterations, reference.model.opt.ls_iterations) == (100, 50)
    assert reference.physics == {
        "solver": "reference",
        "timestep": training.physics["timestep"],
        "iterations": 100,
        "ls_iterations": 50,
        "cone": "elliptic",
        "friction": None,
    }
    with pytest.raises(ValueError, match="unknown physics 'fast'"):
        host_robot.HostRobot("flat", config, physics="fast")
    for bad in ("0/8", "4/", "4/8/2"):
        with pytest.raises(ValueError, match="N/M"):
            host_robot.HostRobot("flat", config, physics=bad)
    chosen = host_robot.HostRobot("flat", config, physics="12/20")
    assert (chosen.model.opt.iterations, chosen.model.opt.ls_iterations) == (12, 20)
    assert chosen.physics["solver"] == "12/20"
    out = tmp_path / "q.json"
    args = ["--policy=fixed:trot", "--robot=quad12", "--episodes=1", "--seconds=0.5"]
    assert sim2sim.main([*args, "--physics=training", f"--out={out}", "--no_progress"]) == 0
    assert json.loads(out.read_text())["setup"]["physics"] == training.physics


def test_policy_walks_and_a_course_ends_at_its_end():
    result = _mujoco(FLAT_POLICY, "flat", episodes=1, seconds=2.0)
    assert result["mean_forward_speed"] > 0.5 and result["success_rate"] == 1.0
    short = "sections:0@0.5;lead_in=0.5;run_out=5"  # course end at x = 1 m
    result = _mujoco(FLAT_POLICY, short, episodes=1, seconds=10.0)
    episode = result["episodes"][0]
    assert episode["finished_course"] and episode["success"] and episode["seconds"] < 3.0


@pytest.mark.parametrize(
    "args, named",
    [
        (["--policy=fixed:trot", "--terrain=s5"], "s5"),
        (["--policy=/nowhere/policy"], "/nowhere/policy"),
        (["--policy=fixed:9,0,0.6,0,0"], "amplitude_knee=9"),
        (["--policy=fixed:trot", "--episodes=0"], "episodes"),
        (["--policy=fixed:trot", "--obs_noise=-0.1"], "--obs_noise"),
        (["--policy=fixed:trot", "--latency_ms=nan"], "--latency_ms"),
        (["--policy=fixed:trot", "--latency_ms=ten"], "--latency_ms"),
        (["--policy=fixed:trot", "--physics=fast"], "--physics"),
        (["--policy=fixed:trot", "--physics=4/0"], "--physics"),
        (["--policy=fixed:trot", "--friction=-0.4"], "--friction"),
    ],
)
def test_cli_bad_input_is_one_line(tmp_path, capsys, args, named):
    assert sim2sim.main([*args, f"--out={tmp_path / 'x.json'}", "--no_progress"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and named in lines[0]
    assert not (tmp_path / "x.json").exists()


# --- the exported .onnx in C MuJoCo, observation noise and latency -----------------------------


def test_an_onnx_pilot_acts_as_the_npz_pilot(tmp_path):
    npz = host_robot.Pilot.load(str(export_lib.export_policy(FLAT_POLICY, tmp_path / "flat.npz")))
    onnx = host_robot.Pilot.load(str(export_lib.export_policy(FLAT_POLICY, tmp_path / "flat.onnx")))
    assert onnx.config.to_dict() == npz.config.to_dict()
    assert (onnx.spec.kind, npz.spec.kind) == ("onnx", "npz")
    assert onnx.spec.training_terrain == npz.spec.training_terrain == "flat"
    host = host_robot.HostRobot("flat", npz.config)
    observations = [host.reset(0)]
    for _ in range(20):
        observations.append(host.step(npz.actor()(observations[-1])).obs)
    for obs in observations:
        np.testing.assert_allclose(onnx.actor()(obs), npz.actor()(obs), atol=1e-5)
    result = _mujoco(onnx.spec, episodes=1, seconds=2.0)
    assert result["success_rate"] == 1.0 and result["mean_forward_speed"] > 0.5
    assert (
        result["setup"]["policy"].endswith("flat.onnx")
        and "onnxruntime" in (result["setup"]["versions"])
    )


def _episode(**faults):
    result = _mujoco(FLAT_POLICY, "flat", episodes=1, seconds=1.0, **faults)
    return result["episodes"], result["setup"]


def test_no_noise_and_no_latency_change_nothing_and_are_recorded():
    plain, setup = _episode()
    assert (setup["obs_noise"], setup["latency_s"], setup["latency_physics_steps"]) == (0, 0, 0)
    assert _episode(obs_noise=0.0, latency_s=0.0)[0] == plain
    noisy, setup = _episode(obs_noise=0.05, latency_s=0.02)
    assert noisy != plain
    assert (setup["obs_noise"], setup["latency_s"], setup["latency_physics_steps"]) == (
        0.05,
        0.02,
        4,
    )
    assert _episode(obs_noise=0.05, latency_s=0.02)[0] == noisy  # seeded


def test_a_set_friction_reaches_every_geom_and_is_recorded():
    config = evaluation.env_config({})
    host = host_robot.HostRobot("flat", config, friction=0.4)
    np.testing.assert_array_equal(host.model.geom_friction[:, 0], 0.4)
    assert host.physics["friction"] == 0.4
    own = host_robot.HostRobot("flat", config)
    assert own.physics["friction"] is None and own.model.geom_friction[:, 0].max() > 0.4
    slippery, setup = _episode(friction=0.4)
    assert setup["physics"]["friction"] == 0.4 and slippery != _episode()[0]
    with pytest.raises(ValueError, match="friction"):
        host_robot.HostRobot("flat", config, friction=float("nan"))


def _commands(monkeypatch, latency_s, actions):
    """The command at each physics substep of `actions` (one per control step), without the
    action filter (the command is the action acting)."""
    host = host_robot.HostRobot("flat", evaluation.env_config({"action_filter_tau": 0.0}), latency_s)
    host.reset(0)
    commands, mj_step = [], host_robot.mujoco.mj_step

    def recording_step(model, data):
        commands.append(host.command.copy())
        mj_step(model, data)

    monkeypatch.setattr(host_robot.mujoco, "mj_step", recording_step)
    for action in actions:
        host.step(action)
    return np.asarray(commands)


@pytest.mark.parametrize(
    "latency_s, first, second",
    [
        (0.0, [1] * 10, [2] * 10),
        (0.02, [0] * 4 + [1] * 6, [1] * 4 + [2] * 6),
        (0.05, [0] * 10, [1] * 10),
    ],
)
def test_latency_delays_the_action(monkeypatch, latency_s, first, second):
    """20 ms (4 physics steps): the previous action for the first 4 substeps of each control
    step, as the MJX env's randomised latency; one control step (50 ms): one step late."""
    action_a, action_b = np.full(5, 0.3), np.full(5, -0.6)
    commands = _commands(monkeypatch, latency_s, [action_a, action_b, np.zeros(5)])
    table = {0: np.zeros(5), 1: action_a, 2: action_b}
    expected = np.array([table[which] for which in first + second])
    np.testing.assert_allclose(commands[:20], expected, atol=1e-12)
    if latency_s == 0.05:
        np.testing.assert_allclose(commands[20:], np.tile(action_b, (10, 1)), atol=1e-12)


def test_a_latency_of_one_control_step_walks_one_step_behind():
    delayed = host_robot.HostRobot("flat", evaluation.env_config({}), latency_s=0.05)
    plain = host_robot.HostRobot("flat", evaluation.env_config({}))
    delayed.reset(3)
    plain.reset(3)
    actions = np.random.default_rng(5).uniform(-1, 1, (6, 5))
    late = [delayed.step(action).obs for action in actions]
    on_time = [plain.step(action).obs for action in [np.zeros(5), *actions[:-1]]]
    np.testing.assert_array_equal(late, on_time)


def test_delay_drive_makes_the_latency_delay_the_drive_in_c_mujoco_as_in_the_env():
    """The env's `randomization.delay_drive` (tests/test_randomization.py) on the host: without
    it a gait (zero actions) walks the same at 40 ms as without latency; with it the same
    without latency and another walk at 40 ms."""
    overrides = {"commands.spec": "0.2,0@0.1;0.6,0.4@2", "commands.feed_forward": True,
                 "commands.speed_gain_rate": 1.0, "commands.heading_gain": 2.0}

    def walk(latency_s: float, delay: bool) -> np.ndarray:
        config = evaluation.env_config({**overrides, "randomization.delay_drive": delay})
        host = host_robot.HostRobot("flat", config, latency_s=latency_s)
        host.reset(3)
        for _ in range(20):
            host.step(np.zeros(host.action_size))
        return host.data.qpos.copy()

    plain = walk(0.0, False)
    np.testing.assert_array_equal(walk(0.04, False), plain)
    np.testing.assert_array_equal(walk(0.0, True), plain)
    assert np.abs(walk(0.04, True) - plain).max() > 1e-3


# --- play ----------------------------------------------------------------------------------------


def test_play_without_a_display_says_so(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(play.sys, "platform", "linux")
    assert play.main(["--policy=fixed:trot", "--terrain=slope5"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "no display" in lines[0] and "--video" in lines[0]
    assert "--terrain=slope5" in lines[0]


def test_play_session_steps_pauses_and_restarts():
    pilot = host_robot.Pilot.load(FLAT_POLICY)
    session = play.Session(pilot, host_robot.HostRobot("flat", pilot.config))
    for _ in range(5):
        session.advance()
    assert session.host.data.time == pytest.approx(0.25)
    labels, values = session.overlay()
    assert "A_k / A_h" in labels and "slope est. / true" in labels and "m/s" in values
    session.key(play.KEY_SPACE)
    session.advance()
    assert session.host.data.time == pytest.approx(0.25) and "paused" in session.overlay()[1]
    session.key(play.KEY_SPACE)
    session.key(play.KEY_R)
    session.advance()
    assert session.episode == 1 and session.host.data.time == pytest.approx(0.05)


def test_survival_for_movement_waits_for_the_low_passed_speed():
    """With survival_min_speed, r_s starts once the 1-s low-passed speed of a trot from rest
    reaches it (the MJX env: step 12 of the fixed trot), and then stays."""
    config = evaluation.env_config({"survival_min_speed": 0.1})
    host = host_robot.HostRobot("flat", config)
    host.reset(0)
    trot = np.asarray(
        oscillator.parameters_to_action(
            oscillator.FIXED_TROT, config.period_min, host.action_centre
        )
    )
    paid = [host.step(trot).reward_terms["survival"] for _ in range(40)]
    first = paid.index(10.0)
    assert 8 <= first <= 16 and set(paid[first:]) == {10.0} and set(paid[:first]) == {0.0}


def test_evaluate_cli_runs_c_mujoco_with_engine_mujoco(tmp_path, capsys):
    from quadcos import evaluate

    out = tmp_path / "trot.json"
    argv = ["--policy=fixed:trot", "--engine=mujoco", "--num_envs=2", "--seconds=2", f"--out={out}"]
    assert evaluate.main([*argv, "--no_progress"]) == 0
    result = json.loads(out.read_text())
    assert result["setup"]["engine"] == "mujoco" and result["num_episodes"] == 2
    assert "in C MuJoCo: success 1.000" in capsys.readouterr().out
    assert evaluate.main([*argv, "--trace=t.json"]) == 2


def test_posture_offsets_the_host_robots_hips():
    posed = host_robot.HostRobot("flat", evaluation.env_config({"posture_bound": 0.4}))
    plain = host_robot.HostRobot("flat", evaluation.env_config({}))
    assert posed.action_size == 7
    posed.reset(0)
    plain.reset(0)
    posed.command = np.r_[np.full(5, 0.2), 0.5, -1.0]
    plain.command = np.full(5, 0.2)
    offsets = posed._joint_targets(posed.rhythm_parameters()) - plain._joint_targets(
        plain.rhythm_parameters()
    )
    np.testing.assert_allclose(offsets, [0.2, 0, 0.2, 0, -0.4, 0, -0.4, 0], atol=1e-12)
    result = posed.step(np.r_[np.zeros(5), 1.0, 1.0])  # a step in C MuJoCo takes 7 values
    assert result.obs.shape == (14 + 7,)


def test_the_host_robot_lets_the_rhythm_in_as_the_env_does():
    ramped = host_robot.HostRobot("flat", evaluation.env_config({"start_ramp_s": 0.5}))
    plain = host_robot.HostRobot("flat", evaluation.env_config({}))
    for robot in (ramped, plain):
        robot.reset(0)
        robot.command = np.full(5, 0.2)
    home = ramped.layout.home
    full = plain._joint_targets(plain.rhythm_parameters()) - home
    assert np.abs(full).max() > 0.05
    np.testing.assert_allclose(ramped._joint_targets(ramped.rhythm_parameters()), home, atol=1e-12)
    for robot in (ramped, plain):
        robot.data.time = 0.25
    halfway = ramped._joint_targets(ramped.rhythm_parameters()) - home
    np.testing.assert_allclose(halfway, full / 2, atol=1e-12)


def test_the_host_robot_observes_the_drive_s_state_before_the_command():
    """`commands.observe_drive`: g, s and the low-passed yaw rate before (v*, ω*) in C MuJoCo, as
    MJX's `observation.with_command` puts them (tests/test_commands.py)."""
    overrides = {"commands.spec": "0.5,0.2@5", "commands.observe_drive": True,
                 "commands.speed_gain_rate": 1.0, "commands.heading_gain": 2.0,
                 "commands.yaw_rate_tau": 0.25, "commands.tracking": "yaw_rate"}
    host = host_robot.HostRobot("flat", evaluation.env_config(overrides))
    assert host.reset(0).size == 19 + 3 + 2
    for _ in range(4):
        obs = host.step(np.full(host.action_size, 0.3)).obs
    drive = host.commands
    np.testing.assert_array_equal(obs[-5:-2], [drive.gain, drive.correction, drive.yaw_rate])
    assert drive.gain != 1.0 and drive.yaw_rate != 0.0  # the loops and the filter moved


def test_the_host_robot_observes_its_low_passed_speed_before_the_command():
    """`commands.observed_speed_tau`: the robot's progress along its heading at each step's start,
    low-passed, sits before (v*, ω*) — as `QuadrupedEnv._with_command` puts it."""
    config = evaluation.env_config(
        {"commands.spec": "0.5,0.2@5", "commands.observed_speed_tau": 0.3}
    )
    host = host_robot.HostRobot("flat", config)
    obs = host.reset(0)
    assert obs.size == 19 + 1 + 2  # the paper's state and the filtered command, speed, (v*, ω*)
    np.testing.assert_allclose(obs[-3:], [0.0, 0.5, 0.2])
    speed, blend, moving = 0.0, 1 - math.exp(-host.dt / 0.3), False
    for _ in range(8):
        (x, y) = host.data.qpos[:2].copy()
        yaw = twins.attitude(host.layout.orientation(host.data)).yaw
        obs = host.step(np.full(host.action_size, 0.3)).obs
        dx, dy = host.data.qpos[:2] - (x, y)
        speed += blend * ((dx * math.cos(yaw) + dy * math.sin(yaw)) / host.dt - speed)
        assert obs[-3] == pytest.approx(speed, abs=1e-9)
        moving |= abs(speed) > 1e-3
    assert moving  # the robot moved: the filter saw something
