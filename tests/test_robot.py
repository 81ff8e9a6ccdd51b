"""The robot description derived from an MJCF: the paper's robot, the test robot quad12 and its
variants, and (where ../shared/menagerie exists) MuJoCo Menagerie's Go1, Go2 and ANYmal C; the
forward kinematics against MuJoCo; the refusals; `python -m quadcos.robot describe`; the env on
the test robot."""

import json
import pathlib
import subprocess
import sys

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
import robot_variants

import quadcos
from quadcos import env as env_lib
from quadcos import robot as robot_lib
from quadcos.deploy import host_robot
from quadcos.equations import kinematics, oscillator
from quadcos.robot import prepare
from quadcos.robot.__main__ import main as robot_main
from quadcos.terrain import get

MENAGERIE = pathlib.Path(__file__).resolve().parents[2] / "shared" / "menagerie"
needs_menagerie = pytest.mark.skipif(
    not MENAGERIE.is_dir(), reason=f"no MuJoCo Menagerie copies at {MENAGERIE}"
)
MENAGERIE_ROBOTS = ("unitree_go1", "unitree_go2", "anybotics_anymal_c")


@pytest.fixture
def menagerie_root(monkeypatch):
    monkeypatch.setenv("MENAGERIE_ROOT", str(MENAGERIE))
    robot_lib.load.cache_clear()
    yield
    robot_lib.load.cache_clear()


def _legs(description):
    return {leg.label: leg for leg in description.legs}


def test_the_papers_robot_is_described_as_the_paper_draws_it():
    description = robot_lib.load("quadcos").description
    assert [leg.label for leg in description.legs] == ["LF", "RF", "LB", "RB"]
    assert description.joint_names == robot_lib.constants.JOINTS
    assert all(leg.abduction is None for leg in description.legs)
    assert all(leg.hip_sign == 1.0 and leg.knee_sign == 1.0 for leg in description.legs)
    assert description.home == (0.0,) * 8
    assert description.standing_height == pytest.approx(robot_lib.constants.STANDING_HEIGHT)
    assert description.torso_half_size == pytest.approx((0.4, 0.23, 0.062))
    assert description.mass == pytest.approx(16.0)
    assert description.actuator_kind == "position"
    assert description.orientation_sensor == robot_lib.constants.IMU_ORIENTATION_SENSOR
    assert robot_lib.load("quadcos").fall_min_height == pytest.approx(0.35)


def test_quad12_legs_are_labelled_by_where_their_hips_sit():
    description = robot_lib.load("quad12").description
    legs = _legs(description)
    # Unitree order and names: FR FL RR RL in the file.
    assert (legs["LF"].abduction, legs["LF"].hip, legs["LF"].knee) == (
        "FL_hip_joint",
        "FL_thigh_joint",
        "FL_calf_joint",
    )
    assert legs["RB"].hip == "RR_thigh_joint"
    assert legs["LF"].hip_position[0] > 0 and legs["LF"].hip_position[1] > 0
    assert legs["RB"].hip_position[0] < 0 and legs["RB"].hip_position[1] < 0
    # The thigh's axis is +y: a larger angle swings the foot backwards; a more negative calf
    # angle folds the knee and lifts the foot.
    assert all(leg.hip_sign == -1.0 and leg.knee_sign == -1.0 for leg in description.legs)
    assert legs["LF"].thigh_length == pytest.approx(0.213)
    assert legs["LF"].shank_length == pytest.approx(0.213)
    assert description.home[:3] == pytest.approx((0.0, 0.9, -1.8))
    assert description.standing_height == pytest.approx(0.288, abs=0.005)
    assert description.mass == pytest.approx(12.7, abs=0.1)
    # Actuators in the file's order (FR first) drive the description's joints (LF first).
    assert description.joint_names[description.actuator_joint[0]] == "FR_hip_joint"


def test_knees_bent_inwards_flip_the_hind_knees_sign(tmp_path):
    legs = _legs(robot_lib.load(str(robot_variants.knees_inward(tmp_path))).description)
    assert legs["LF"].knee_sign == -1.0 and legs["LB"].knee_sign == 1.0
    assert legs["LB"].hip_sign == -1.0


def test_motors_need_gains_and_then_run_a_pd_loop(tmp_path):
    path = robot_variants.motors_without_gains(tmp_path)
    with pytest.raises(ValueError, match="motor.*without gains.*kp and kd"):
        robot_lib.load(str(path))
    model = prepare.load_spec(path).compile()
    description = robot_lib.describe(model, name="motors", kp=100.0, kd=2.0)
    assert description.actuator_kind == "motor"
    assert description.gains.kp == (100.0,) * 12
    assert max(description.gains.torque_limit) == pytest.approx(35.55)


def test_without_a_keyframe_the_home_pose_must_be_given(tmp_path):
    path = robot_variants.no_keyframe(tmp_path)
    with pytest.raises(ValueError, match="outside its range.*give a home pose"):
        robot_lib.load(str(path))  # joint zero: the calves cannot reach 0
    model = prepare.load_spec(path).compile()
    home = {
        f"{leg}_{kind}_joint": value
        for leg in ("FR", "FL", "RR", "RL")
        for kind, value in (("hip", 0.0), ("thigh", 0.9), ("calf", -1.8))
    }
    description = robot_lib.describe(model, name="no_keyframe", home=home)
    assert description.standing_height == pytest.approx(0.288, abs=0.005)


@pytest.mark.parametrize(
    "variant, message",
    [
        ("no_freejoint", "no freejoint"),
        ("three_legs", "3 legs"),
        ("five_legs", "5 legs"),
        ("one_joint_leg", "1 joint"),
    ],
)
def test_what_cannot_be_driven_is_refused_in_one_line(variant, message, tmp_path):
    path = getattr(robot_variants, variant)(tmp_path)
    with pytest.raises(ValueError, match=message) as error:
        robot_lib.load(str(path))
    assert str(path) in str(error.value) and "\n" not in str(error.value)


def _foot_error(robot: robot_lib.Robot, poses: int = 50) -> float:
    """The largest distance (m) between the description's forward kinematics and MuJoCo's feet
    over random poses within the joint ranges."""
    description = robot.description
    model = prepare.load_spec(robot.source.path).compile()
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    low, high = np.array(description.joint_ranges).T
    home = np.array(description.home)
    worst = 0.0
    for _ in range(poses):
        joints = np.clip(home + rng.uniform(-0.6, 0.6, home.size), low, high)
        data.qpos[:] = model.qpos0
        data.qpos[:7] = rng.normal(size=7)  # anywhere, turned anyhow: the torso frame removes it
        data.qpos[3:7] /= np.linalg.norm(data.qpos[3:7])
        data.qpos[list(description.joint_qpos)] = joints
        mujoco.mj_kinematics(model, data)
        root = model.body(description.root_body).id
        world = np.stack([data.geom_xpos[leg.foot_geom] for leg in description.legs])
        in_torso = (world - data.xpos[root]) @ data.xmat[root].reshape(3, 3)
        feet = kinematics.foot_positions(description.chains, joints, xp=np)
        worst = max(worst, float(np.abs(feet - in_torso).max()))
    return worst


def test_forward_kinematics_equals_mujocos_feet(tmp_path):
    for spec in ("quadcos", "quad12", str(robot_variants.knees_inward(tmp_path))):
        assert _foot_error(robot_lib.load(spec)) < 1e-3, spec


@needs_menagerie
@pytest.mark.parametrize("name", MENAGERIE_ROBOTS)
def test_menagerie_robots_are_described(name, menagerie_root):
    robot = robot_lib.load(f"menagerie:{name}")
    description = robot.description
    assert robot.source.name == name
    assert [leg.label for leg in description.legs] == ["LF", "RF", "LB", "RB"]
    assert all(leg.abduction is not None for leg in description.legs)
    assert _foot_error(robot) < 1e-3
    expected = {
        "unitree_go1": (0.27, 12.7),
        "unitree_go2": (0.27, 15.2),
        "anybotics_anymal_c": (0.56, 45.0),
    }
    height, mass = expected[name]
    assert description.standing_height == pytest.approx(height, rel=0.1)
    assert description.mass == pytest.approx(mass, rel=0.02)
    assert description.actuator_kind == ("motor" if name == "unitree_go2" else "position")
    if name == "anybotics_anymal_c":  # knees bent inwards: front and hind knees fold opposite ways
        legs = _legs(description)
        assert legs["LF"].knee_sign == -legs["LB"].knee_sign


def _describe_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "quadcos.robot", "describe", *args], capture_output=True, text=True
    )


def test_describe_prints_json_and_refuses_in_one_line(tmp_path, capsys, menagerie_root):
    result = _describe_cli("--robot=quad12")
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["name"] == "quad12" and len(summary["legs"]) == 4
    assert summary["legs"][0]["joints"]["hip"] == "FL_thigh_joint"
    assert summary["actuator_kind"] == "position" and summary["mass_kg"] > 12
    # docs/robots.md's sample (one leg of four): the same keys, physics and first gains
    docs = (pathlib.Path(__file__).parents[1] / "docs" / "robots.md").read_text()
    sample = json.loads(docs.split("describe`\n")[1].split("```json\n")[1].split("```")[0])
    assert list(sample) == list(summary) and sample["physics"] == summary["physics"]
    assert sample["gains"]["FL_hip_joint"] == summary["gains"]["FL_hip_joint"]
    assert sample["legs"][0] == summary["legs"][0]
    # The refusals through the same main() in this process (a Python each costs seconds).
    bad = robot_variants.three_legs(tmp_path)
    for spec in (str(bad), str(tmp_path / "missing.xml"), "menagerie:unitree_go3"):
        assert robot_main(["describe", f"--robot={spec}"]) == 2
        out, err = capsys.readouterr()
        assert out == "" and len(err.strip().splitlines()) == 1, err
    assert "close: unitree_go2" in err or not MENAGERIE.is_dir()


@needs_menagerie
def test_describe_go1_through_menagerie_root(menagerie_root, capsys):
    assert robot_main(["describe", "--robot=menagerie:unitree_go1"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["root_body"] == "trunk" and summary["menagerie_commit"]


@pytest.fixture(scope="module")
def quad12_env():
    return quadcos.make_env("slope5", robot="quad12")


def test_the_test_robot_holds_its_home_pose_on_flat_and_slope5(quad12_env):
    """Zero rhythm amplitude for 5 s: the trunk stays within 5 % of its home height, on flat
    ground before the ramp and on the 5° ramp itself (the same compiled env: slope5 starts flat)."""
    env = quad12_env
    stand = env.action_for(oscillator.RhythmParameters(0.0, 0.0, 1.0, 0.0, 0.0))
    steps = round(5.0 / env.dt)

    def hold(state, _):
        state = env.step(state, stand)
        return state, state.pipeline_state.qpos[2] - env.terrain.height_at(
            state.pipeline_state.qpos[0], state.pipeline_state.qpos[1]
        )

    @jax.jit
    def run(x):
        start = env.reset_at(jax.random.PRNGKey(0), x, jnp.zeros(()))
        final, heights = jax.lax.scan(hold, start, None, length=steps)
        return heights, final.done

    # Its height: the keyframe's (feet 18 mm into the ground, as Go1's); the kinematic standing
    # height, feet just touching, is 0.288 m.
    home_height = robot_variants.HOME_HEIGHT
    for x in (0.0, 3.0):  # flat, then on the ramp (its height measured along the vertical)
        heights, done = run(jnp.asarray(x))
        assert not bool(done)
        slope = float(env.terrain.slope_at(x, 0.0))
        expected = home_height / np.cos(slope)
        assert np.abs(np.asarray(heights[-20:]) / expected - 1).max() < 0.05, x


def test_the_env_drives_the_test_robot(quad12_env):
    env = quad12_env
    assert env.action_size == 5
    state = jax.jit(env.reset)(jax.random.PRNGKey(1))
    assert state.obs.shape == (env.observation_size,)
    assert env.observation_size == 3 + 3 + 12 + 5  # velocity, attitude, 12 joints, command
    targets = env.joint_targets(jnp.zeros(5), jnp.zeros(()), jnp.zeros(()))
    legs = env.robot.description
    rhythm = env.rhythm(jnp.zeros(5), jnp.zeros(()), jnp.zeros(()))
    hip = legs.hip_joint[0]
    assert float(targets[hip]) == pytest.approx(
        legs.home[hip] + legs.legs[0].hip_sign * float(rhythm[0])
    )
    abduction = legs.joint_names.index(legs.legs[0].abduction)
    assert float(targets[abduction]) == legs.home[abduction]  # abduction held at home


def test_a_bad_robot_stops_train_before_anything_is_written(tmp_path, capsys):
    from quadcos import train

    run_dir = tmp_path / "run"
    for spec in (str(robot_variants.five_legs(tmp_path)), str(tmp_path / "missing.xml")):
        assert train.main(["--preset=smoke", f"--robot={spec}", f"--output_dir={run_dir}"]) == 2
        assert len(capsys.readouterr().err.strip().splitlines()) == 1
        assert not run_dir.exists()


@needs_menagerie
def test_the_committed_go1_policy_walks_go1(menagerie_root):
    policy = pathlib.Path(__file__).resolve().parents[1] / "experiments" / "policies" / "go1_flat"
    # Trained on MJX-Warp at the preset's 4 / 8 solver iterations; the CPU's MJX-JAX needs the
    # converged 8 / 8 for this fast gait (experiments/robots/physics/README.md: 18.8 % at 4 / 8).
    result = quadcos.evaluate_policy(
        str(policy), "flat", episodes=2, seconds=2.0, solver_iterations=8, ls_iterations=8
    )
    assert result.falls == 0.0 and result.speed > 0.5
    assert result.to_json()["setup"]["robot"]["name"] == "unitree_go1"


def test_servo_gains_stiffen_the_position_servos_everywhere_the_robot_is_built(tmp_path):
    """`env.servo_kp`/`servo_kd` set every position servo's gain and damping in the env's model
    and in C MuJoCo's (deploy); a stiffer servo holds a loaded joint closer to its target."""
    def sag(servo):  # the largest joint error standing under its own weight, targets held
        model = robot_lib.build_model(
            get("flat"), robot_lib.load("quad12"), timestep=0.005, servo=servo
        )
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, 0)
        data.qpos[2] += 0.05
        joints = model.actuator_trnid[:, 0]
        data.ctrl[:] = data.qpos[model.jnt_qposadr[joints]]
        for _ in range(400):
            mujoco.mj_step(model, data)
        return float(np.abs(data.qpos[model.jnt_qposadr[joints]] - data.ctrl).max()), model

    soft, stock = sag(None)
    stiff, stiffened = sag((4 * float(stock.actuator_gainprm[0, 0]), 1.0))
    assert stiff < 0.5 * soft
    assert np.allclose(stiffened.actuator_biasprm[:, 1], -stiffened.actuator_gainprm[:, 0])
    assert np.allclose(stiffened.actuator_biasprm[:, 2], -1.0)
    overrides = {"robot": "quad12", "servo_kp": 123.0, "servo_kd": 2.5}
    env = env_lib.make_env("flat", **overrides)
    host = host_robot.HostRobot("flat", host_robot.Pilot.load("fixed:trot", overrides).config)
    for model in (env.mj_model, host.model):
        assert np.allclose(model.actuator_gainprm[:, 0], 123.0)
        assert np.allclose(model.actuator_biasprm[:, 1:3], [-123.0, -2.5])
    motors = prepare.load_spec(robot_variants.motors_without_gains(tmp_path))
    with pytest.raises(ValueError, match="position actuators; actuator .* torque motor"):
        prepare.set_servo_gains(motors, 100.0, 1.0)


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"servo_kp": -1.0}, "servo_kp must be finite and >= 0; got -1.0"),
        ({"servo_kd": 2.0}, "servo_kd 2.0 needs servo_kp > 0"),
    ],
)
def test_bad_servo_gains_are_refused_naming_the_key(overrides, message):
    with pytest.raises(ValueError, match=message):
        env_lib.make_env("flat", robot="quad12", **overrides)


@needs_menagerie
def test_servo_gains_for_torque_motors_stop_train_before_anything_is_written(
    tmp_path, capsys, menagerie_root
):
    from quadcos import train

    run_dir = tmp_path / "run"
    argv = ["--preset=smoke", "--robot=menagerie:unitree_go2", f"--output_dir={run_dir}"]
    assert train.main([*argv, "--config.env.servo_kp=100"]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "servo_kp 100.0 applies to position servos" in error[0]
    assert "unitree_go2 drives torque motors" in error[0]
    assert not run_dir.exists()


def test_short_names_are_read_from_the_spec_alone():
    short = robot_lib.sources.short_name
    assert short("menagerie:anybotics_anymal_c") == "anybotics_anymal_c"
    assert short("menagerie:anybotics_anymal_c/anymal_c_mjx.xml") == "anybotics_anymal_c"
    assert short("") == short("quadcos") == "quadcos"
    assert short("quad12") == "quad12"
    assert short("/no/such/dir/anymal_c.xml") == "anymal_c"  # a path: no robot preset applies


@needs_menagerie
def test_the_command_preset_stiffens_anymal_c_ranks_by_conditions_flags_win(menagerie_root):
    from quadcos.training import phases, presets

    def built(preset, **overrides):
        return presets.build_config(presets.PRESETS[preset], overrides)

    anymal = "menagerie:anybotics_anymal_c"
    config = built("command", **{"env.robot": anymal})
    assert (config.env.servo_kp, config.env.servo_kd) == (300.0, 4.0)
    assert (config.env.solver_iterations, config.env.ls_iterations) == (20, 20)
    assert config.sac.gait_search.min_speed == 0.15
    assert config.sac.gait_search.confirm_robots == 256
    assert config.env.commands.turn_max == 0.4
    assert config.env.commands.yaw_rate_tau == 0.25
    assert config.env.survival_speed_frame == "heading"
    # the command line wins; other robots, ANYmal C by its path and other presets are untouched
    flagged = built("command", **{"env.robot": anymal, "env.servo_kp": 500.0})
    assert flagged.env.servo_kp == 500.0 and flagged.env.servo_kd == 4.0
    # ANYmal C's SAC: 2 updates per env step, ranked in the robustness conditions
    assert config.sac.updates_per_step == 2
    assert config.env.randomization.eval_conditions == "robustness"
    assert config.sac.gait_search.track_gaits == 0  # its search's best gait
    # ... switched at the actor's start to the second phase's settings, the draws' ends a third
    second = phases.second(config)
    assert (config.sac.reward_scaling, config.env.reward.forward) == (0.1, 450.0)
    assert (second.sac.reward_scaling, second.env.reward.forward) == (0.028, 1600.0)
    assert second.sac.learning_rate.actor == 3e-5 and second.sac.smoothness.temporal == 30.0
    assert config.env.randomization.range_ends == 0.33
    for robot in ("menagerie:unitree_go1", "menagerie:unitree_go2"):
        go = built("command", **{"env.robot": robot})
        assert go.env.randomization.eval_conditions == "robustness"
        assert (go.sac.gait_search.track_gaits, go.sac.gait_search.max_attitude) == (16, 0.085)
        assert go.sac.updates_per_step == 8
        assert go.sac.at_actor_start == "" and go.env.randomization.range_ends == 0.0
    assert built("command", **{}).env.randomization.eval_conditions == ""  # the default robot
    scratch = built("scratch", **{"env.robot": "menagerie:unitree_go1"})
    assert scratch.sac.gait_search.track_gaits == 0
    path = str(MENAGERIE / "anybotics_anymal_c" / "anymal_c.xml")
    for preset, robot in (("command", "menagerie:unitree_go1"), ("command", path),
                          ("scratch", anymal)):
        other = built(preset, **{"env.robot": robot})
        assert (other.env.servo_kp, other.env.solver_iterations) == (0.0, 0)
        assert other.sac.gait_search.min_speed == 0.0 and other.env.commands.turn_max == 0.0
        assert other.env.survival_speed_frame == "x"
        # the low-passed yaw rate is the command preset's on every robot, no other preset's
        assert other.env.commands.yaw_rate_tau == (0.25 if preset == "command" else 0.0)
