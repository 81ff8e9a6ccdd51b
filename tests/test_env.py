"""The MJX env: shapes, physics facts and the paper's fixed-parameter trot.

Compiling an MJX step costs 10–20 s on two cores, so each env is built and jitted once per
session and shared: every test on flat ground resets and steps FLAT_ROBOTS robots, so that one
compiled reset and one compiled step serve them all.
"""

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

import quadcos
from quadcos import terrain as terrain_lib
from quadcos._util import caches
from quadcos.env.quadruped import GAIT_KEY
from quadcos.equations import oscillator
from quadcos.robot import constants

CONTROL_STEPS_10_S = 200  # 10 s at the default 20 Hz control
RAMP_DEGREES = (-9.0, -5.0, 0.0, 5.0, 9.0)
RAMP_BAND = 2.0  # m: width in y of each ramp of the estimator test terrain
FLAT_ROBOTS = 4


def rollout(env, steps):
    """jit(vmap) rollout of a constant action per env: returns (final state, per-step states)."""

    def run(state, action):
        def body(state, _):
            state = jax.vmap(env.step)(state, action)
            return state, state

        return jax.lax.scan(body, state, None, length=steps)

    return jax.jit(run)


@pytest.fixture(scope="session")
def flat_env():
    return quadcos.make_env("flat")


@pytest.fixture(scope="session")
def flat_reset(flat_env):
    return jax.jit(jax.vmap(flat_env.reset))


@pytest.fixture(scope="session")
def flat_step(flat_env):
    return jax.jit(jax.vmap(flat_env.step))


@pytest.fixture(scope="session")
def fixed_trot_run(flat_env, flat_reset, flat_step):
    """Four robots trotting with fixed paper-style parameters for 10 s on flat ground: (final
    state, per-step states without the physics state, on the host)."""
    state = flat_reset(jax.random.split(jax.random.PRNGKey(0), FLAT_ROBOTS))
    action = jnp.broadcast_to(flat_env.action_for(oscillator.FIXED_TROT), (FLAT_ROBOTS, 5))
    steps = []
    for _ in range(CONTROL_STEPS_10_S):
        state = flat_step(state, action)
        steps.append(jax.device_get(state.replace(pipeline_state=None)))
    return state, jax.tree.map(lambda *values: np.stack(values), *steps)


def test_zero_action_is_the_fixed_trot_by_default(flat_env):
    np.testing.assert_allclose(flat_env.action_for(oscillator.FIXED_TROT), np.zeros(5), atol=1e-6)
    midpoint = quadcos.make_env("flat", action_centre="midpoint")
    np.testing.assert_allclose(
        midpoint.action_for(oscillator.RhythmParameters(0.0, 0.0, 1.1, 0.0, 0.0)),
        np.zeros(5),
        atol=1e-6,
    )


def test_a_state_carrying_a_gait_steps_with_it(flat_env):
    """A trainer puts the gait's maps in the env states (`GAIT_KEY`): an env maps actions through
    another gait's map as that gait's env does, and its step's program is the same whichever the
    centre (a searched gait's run reuses the compiled programs of another's)."""
    other = quadcos.make_env("flat", action_centre="0.31,0.25,0.45,2.0,0.5")
    action = jnp.linspace(-0.9, 0.9, 5)
    gait = {name: jnp.asarray(value) for name, value in other.gait.items()}
    np.testing.assert_allclose(
        jnp.stack(flat_env.with_gait(gait).rhythm_parameters(action)),
        jnp.stack(other.rhythm_parameters(action)),
    )
    back = flat_env.with_gait(gait).action_for(other.rhythm_parameters(action))
    np.testing.assert_allclose(back, action, atol=1e-5)  # and back, the inverse through it too
    assert not np.allclose(
        jnp.stack(flat_env.rhythm_parameters(action)), jnp.stack(other.rhythm_parameters(action))
    )
    state = jax.eval_shape(flat_env.reset, jax.random.PRNGKey(0))
    state = state.replace(info={**state.info, GAIT_KEY: jax.eval_shape(lambda: gait)})
    programs = {jax.jit(env.step).lower(state, action).as_text() for env in (flat_env, other)}
    assert len(programs) == 1


def test_the_trainers_programs_are_kept_for_every_gait(tmp_path, monkeypatch):
    """The trainer passes the gait as data, so its traced programs' key leaves the gait's config
    fields out (`QuadrupedEnv.gait_fields`) and keeps every other."""
    monkeypatch.setattr(caches, "traced_directory", lambda: tmp_path)

    def key(**overrides) -> str | None:
        env = quadcos.make_env("flat", **overrides)
        return caches.trainer_fingerprint(env, None, {}, one_device=True)

    gait = {"commands.spec": "random", "commands.feed_forward": True}
    searched = key(action_centre="0.3,0.2,0.4,3.0,0.0", **gait, **{"commands.half_track": 0.4})
    assert searched is not None
    other = {"commands.speed_map": (0.2, 0.4, 0.6, 0.8), "commands.half_track": 0.5}
    assert key(action_centre="0.31,0.25,0.45,2.0,0.5", **gait, **other) == searched
    assert key(action_centre="0.3,0.2,0.4,3.0,0.0", observe_slope=True, **gait) != searched


def test_moving_is_measured_along_x_or_the_heading(flat_reset):
    before = jax.tree.map(lambda leaf: leaf[0], flat_reset(jax.random.split(jax.random.PRNGKey(0), 1)))
    before = before.pipeline_state
    heading = quadcos.make_env("flat", survival_speed_frame="heading")
    yaw_pi = jnp.asarray([0.0, 0.0, 0.0, 1.0])
    turned = before.replace(qpos=before.qpos.at[3:7].set(yaw_pi))
    if heading.layout.orientation_sensor is not None:  # the IMU reads the turned pose
        sensor = heading.layout.orientation_sensor
        turned = turned.replace(sensordata=turned.sensordata.at[sensor].set(yaw_pi))
    moved = jnp.asarray([-0.05, 0.02, 0.0])  # 5 cm towards -x: forwards for a robot facing -x
    along_x = quadcos.make_env("flat")._moved_forward(turned, moved)
    np.testing.assert_allclose([along_x, heading._moved_forward(turned, moved)], [-0.05, 0.05],
                               atol=1e-6)
    np.testing.assert_allclose(heading._moved_forward(before, moved), -0.05, atol=5e-3)


def test_sizes(flat_env):
    # v_x, v_y, v_z, pitch, yaw, roll, ξ1..ξ8, then the filtered command (5)
    assert flat_env.observation_size == 19
    assert quadcos.make_env("flat", action_filter_tau=0.0).observation_size == 14  # the paper's
    assert flat_env.action_size == 5
    assert flat_env.dt == pytest.approx(0.05)


@pytest.fixture(scope="module")
def gyro_rate_env():
    """An env with two options beyond the paper, one program for both tests: the gyro observed
    and the action-rate term weighted 10; (env, its batched reset, its batched step)."""
    env = quadcos.make_env("flat", observe_angular_velocity=True, **{"reward.action_rate": 10.0})
    return env, jax.jit(jax.vmap(env.reset)), jax.jit(jax.vmap(env.step))


def test_the_gyro_is_observed_after_the_filtered_action(gyro_rate_env):
    env, reset, step = gyro_rate_env
    assert env.observation_size == 14 + 5 + 3
    state = reset(jax.random.split(jax.random.PRNGKey(0), 2))
    for _ in range(3):
        state = step(state, jnp.full((2, 5), 0.3))
    gyro = np.asarray(state.obs[:, 19:22])
    np.testing.assert_array_equal(gyro, np.asarray(state.pipeline_state.qvel[:, 3:6]))
    assert np.abs(gyro).max() > 1e-3  # the trot rocks the torso: the gyro reads it


def test_action_rate_charges_the_commands_change_in_the_step(gyro_rate_env):
    """With `reward.action_rate` w the step pays −w Σ Δc² for its command's change Δc (the
    filtered action: observations 14 to 18)."""
    _, reset, step = gyro_rate_env
    state = reset(jax.random.split(jax.random.PRNGKey(3), 2))
    action = jnp.array([[0.2, -0.1, 0.05, 0.1, -0.3], [0.0, 0.0, 0.0, 0.0, 0.0]])
    first = step(state, action)
    second = step(first, -action)
    for before, after in ((state, first), (first, second)):
        change = np.asarray(after.obs[:, 14:19]) - np.asarray(before.obs[:, 14:19])
        np.testing.assert_allclose(
            after.metrics["reward/action_rate"], -10.0 * (change**2).sum(1), rtol=1e-4, atol=1e-7
        )
    assert float(second.metrics["reward/action_rate"][0]) < float(
        first.metrics["reward/action_rate"][0]
    ) < 0  # turning back costs more than setting out
    assert float(second.metrics["reward/action_rate"][1]) == 0.0  # a still command: nothing


def test_only_the_feet_touch_the_ground(flat_env):
    # A torso contact only ever acts on a fallen robot (the env ends those episodes), and box vs
    # heightfield collisions dominated MJX's cost on slopes.
    model = flat_env.mj_model
    colliding = {model.geom(g).name for g in range(model.ngeom) if model.geom_contype[g]}
    assert colliding == {f"{leg}_foot" for leg in ("LF", "RF", "LB", "RB")}


@pytest.mark.slow
def test_optional_observations_and_joint_controller():
    env = quadcos.make_env("flat", observe_slope=True, observe_phase=True, controller="joint")
    assert env.observation_size == 14 + 1 + 2 + 8
    assert env.action_size == 8
    state = jax.jit(env.reset)(jax.random.PRNGKey(0))
    assert state.obs.shape == (env.observation_size,)  # the counted size is the observed one
    state = jax.jit(env.step)(state, jnp.full(8, 0.1))
    assert np.isfinite(np.asarray(state.obs)).all()
    np.testing.assert_allclose(  # the filtered command, then the joints follow it
        state.obs[-8:], 0.1 * (1 - np.exp(-env.dt / env.config.action_filter_tau)), rtol=1e-4
    )


def test_reset_is_finite_and_standing(flat_env, flat_reset):
    state = flat_reset(jax.random.split(jax.random.PRNGKey(1), FLAT_ROBOTS))
    assert state.obs.shape == (FLAT_ROBOTS, 19) == (FLAT_ROBOTS, flat_env.observation_size)
    np.testing.assert_array_equal(state.obs[:, 14:], 0.0)  # the command starts at the centre
    assert np.isfinite(state.obs).all()
    np.testing.assert_allclose(
        state.pipeline_state.qpos[:, 2], constants.STANDING_HEIGHT, atol=0.01
    )
    assert set(state.metrics) >= {
        "reward/fall",
        "reward/survival",
        "reward/forward",
        "reward/lateral",
        "reward/orientation",
        "forward_speed",
        "slope_estimate",
        "slope_truth",
    }


def test_a_reset_poses_the_robot_as_mujoco_does_and_leaves_the_solver_to_the_step(
    flat_env, flat_reset
):
    """The reset computes the position stage only (quadcos.env.backends.pose): bodies, geoms and
    position sensors as C MuJoCo's mj_forward puts them; no warm start for the first step."""
    data = flat_reset(jax.random.split(jax.random.PRNGKey(1), FLAT_ROBOTS)).pipeline_state
    reference = mujoco.MjData(flat_env.mj_model)
    reference.qpos[:] = np.asarray(data.qpos[0], np.float64)
    mujoco.mj_forward(flat_env.mj_model, reference)
    np.testing.assert_allclose(data.geom_xpos[0], reference.geom_xpos, atol=1e-5)
    np.testing.assert_allclose(data.xquat[0], reference.xquat, atol=1e-5)
    model = flat_env.mj_model
    position = [  # the position sensors' values (velocity and acceleration ones wait for the step)
        model.sensor_adr[i] + k
        for i in range(model.nsensor)
        if model.sensor_needstage[i] == mujoco.mjtStage.mjSTAGE_POS
        for k in range(model.sensor_dim[i])
    ]
    np.testing.assert_allclose(data.sensordata[0, position], reference.sensordata[position], atol=1e-5)
    np.testing.assert_array_equal(data.qacc_warmstart, 0.0)


def test_fixed_trot_walks_forward_for_10_s(fixed_trot_run):
    final, trace = fixed_trot_run
    assert not np.asarray(trace.done).any(), "a robot fell"
    distance = np.asarray(final.pipeline_state.qpos[:, 0])
    assert (distance / 10.0 >= 0.2).all(), f"too slow: {distance / 10} m/s"
    assert np.isfinite(np.asarray(trace.obs)).all()


def test_reward_terms_while_walking(fixed_trot_run):
    _, trace = fixed_trot_run
    metrics = {k: np.asarray(v) for k, v in trace.metrics.items()}
    assert (metrics["reward/survival"] == 10.0).all()
    assert (metrics["reward/fall"] == 0.0).all()
    assert metrics["reward/forward"].sum(0).min() > 0  # net progress along +x
    assert (metrics["reward/lateral"] <= 0).all() and (metrics["reward/orientation"] <= 0).all()
    total = sum(
        metrics[f"reward/{t}"] for t in ("fall", "survival", "forward", "lateral", "orientation")
    )
    np.testing.assert_allclose(total, np.asarray(trace.reward), rtol=1e-5, atol=1e-4)
    assert (metrics["reward/action_rate"] == 0.0).all()  # beyond the paper: off by default
    np.testing.assert_allclose(metrics["forward_speed"].mean(), 0.5, atol=0.3)


def test_a_fall_ends_the_episode_with_the_penalty(flat_reset, flat_step):
    state = flat_reset(jax.random.split(jax.random.PRNGKey(2), FLAT_ROBOTS))
    qpos = state.pipeline_state.qpos
    # Robot 0 upside down, the others untouched.
    qpos = qpos.at[0, constants.QPOS_QUATERNION].set(jnp.array([0.0, 1.0, 0.0, 0.0]))
    state = state.replace(pipeline_state=state.pipeline_state.replace(qpos=qpos))
    state = flat_step(state, jnp.zeros((FLAT_ROBOTS, 5)))
    np.testing.assert_array_equal(np.asarray(state.done), [1.0] + [0.0] * (FLAT_ROBOTS - 1))
    assert float(state.reward[0]) == -100.0
    assert (np.asarray(state.reward[1:]) > 0).all()


def test_a_finite_blow_up_is_a_fall_with_a_nan_reward(flat_reset, flat_step):
    # MJX can blow up without a NaN (a Go1 evaluation: 1e5 m/s): beyond MAX_SPEED it is a fall
    # whose reward is NaN, as a non-finite one's, which training's NaN guard and the evaluations
    # count as diverged.
    state = flat_reset(jax.random.split(jax.random.PRNGKey(3), FLAT_ROBOTS))
    qvel = state.pipeline_state.qvel.at[1, 0].set(50 * quadcos.env.MAX_SPEED)
    state = state.replace(pipeline_state=state.pipeline_state.replace(qvel=qvel))
    state = flat_step(state, jnp.zeros((FLAT_ROBOTS, 5)))
    np.testing.assert_array_equal(np.asarray(state.done), [0.0, 1.0, 0.0, 0.0])
    rewards = np.asarray(state.reward)
    assert np.isnan(rewards[1]) and np.isfinite(rewards[[0, 2, 3]]).all()


def test_command_follows_the_action_with_the_filter_time_constant(
    flat_env, flat_reset, flat_step
):
    """From the centre, one control step of a constant action a moves the command (the last 5
    observations) to a·(1 − exp(−control_dt/τ)), clipped to [−1, 1] first."""
    state = flat_reset(jax.random.split(jax.random.PRNGKey(3), FLAT_ROBOTS))
    action = jnp.array(
        [
            [0.2, -0.1, 0.05, 0.1, -0.3],
            [3.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, -2.0, 0.5, -0.5, 0.0],
            [0.0, 0.0, 0.0, 0.0, 0.0],
        ]
    )
    state = flat_step(state, action)
    reached = 1.0 - np.exp(-flat_env.dt / flat_env.config.action_filter_tau)
    np.testing.assert_allclose(state.obs[:, 14:], np.clip(action, -1, 1) * reached, atol=1e-5)


def test_zero_action_targets_are_the_envs_own_under_the_zero_action(
    flat_env, flat_reset, flat_step
):
    """What the bench's walking physics sets (`zero_action_targets` at a time) is what the env
    commands after holding the zero action from its reset: the last substep's controls."""
    state = flat_reset(jax.random.split(jax.random.PRNGKey(5), FLAT_ROBOTS))
    zero = jnp.zeros((FLAT_ROBOTS, flat_env.action_size))
    for _ in range(3):
        state = flat_step(state, zero)
    data = state.pipeline_state
    last_substep = data.time - flat_env.config.physics_dt
    targets = jax.vmap(flat_env.zero_action_targets)(last_substep)
    assert np.ptp(np.asarray(targets), axis=0).max() < 1e-6  # robots reset together move alike
    assert np.abs(targets - flat_env.layout.home).max() > 0.05  # the trot, not the home pose
    np.testing.assert_allclose(
        jax.vmap(flat_env.layout.controls)(targets, data), data.ctrl, atol=1e-4
    )


def _ramps(x, y):
    """Side-by-side planes through the origin, one per slope, each RAMP_BAND wide in y."""
    band = np.clip(
        np.round(y / RAMP_BAND).astype(int) + len(RAMP_DEGREES) // 2, 0, len(RAMP_DEGREES) - 1
    )
    return np.tan(np.deg2rad(np.asarray(RAMP_DEGREES)))[band] * x


@pytest.mark.slow
def test_estimator_on_ramps_within_one_degree():
    """Robots standing still on 0°, ±5°, ±9° ramps estimate the slope within 1° (Eq. 5)."""
    half = RAMP_BAND * len(RAMP_DEGREES) / 2
    ramps = terrain_lib.heightfield(
        _ramps, x_range=(-3.0, 3.0), y_range=(-half, half), name="ramps"
    )
    env = quadcos.make_env(ramps)
    ys = RAMP_BAND * (np.arange(len(RAMP_DEGREES)) - len(RAMP_DEGREES) // 2)
    keys = jax.random.split(jax.random.PRNGKey(3), len(ys))
    state = jax.jit(jax.vmap(env.reset_at))(keys, jnp.zeros(len(ys)), jnp.asarray(ys, jnp.float32))
    still = oscillator.RhythmParameters(0.0, 0.0, 1.0, 0.0, 0.0)  # A_k = A_h = 0: targets stay 0
    stand = jnp.broadcast_to(env.action_for(still), (len(ys), 5))
    final, trace = rollout(env, 30)(state, stand)  # 1.5 s to settle
    assert not np.asarray(trace.done).any()
    estimate = np.rad2deg(np.asarray(final.metrics["slope_estimate"]))
    truth = np.rad2deg(np.asarray(final.metrics["slope_truth"]))
    np.testing.assert_allclose(truth, RAMP_DEGREES, atol=0.2)
    np.testing.assert_allclose(estimate, RAMP_DEGREES, atol=1.0)


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"controller": "cpg"}, "unknown controller 'cpg'"),
        ({"oscillator_form": "x"}, "unknown oscillator_form 'x'"),
        ({"reward_variant": "yx"}, "unknown reward_variant 'yx'"),
        ({"action_centre": "gallop"}, "unknown action_centre 'gallop'"),
        ({"control_dt": 0.052}, "whole multiple of physics_dt"),
        ({"action_filter_tau": -0.1}, "action_filter_tau must be >= 0"),
        ({"spawn_x_max": -1.0}, "spawn_x_max must be finite and >= 0"),
        ({"posture_bound": 0.8}, r"posture_bound must be in \[0, 0.7\]"),
        ({"posture_bound": 0.3, "controller": "joint"}, "posture_bound > 0 needs controller"),
        ({"forward_speed_cap": -1.0}, "forward_speed_cap must be finite and >= 0"),
        ({"action_scale": 0.0}, r"action_scale must be in \(0, 1\]"),
        ({"held_rhythm": "period,gait"}, "held_rhythm names 'gait'; known: amplitude_knee"),
        ({"not_a_key": 1}, "unknown config key 'not_a_key'"),
    ],
)
def test_bad_env_config_is_named(overrides, message):
    with pytest.raises(ValueError, match=message):
        quadcos.make_env("flat", **overrides)


@pytest.mark.slow
def test_random_spawns_cover_the_range(flat_reset):
    env = quadcos.make_env("flat", spawn_x_max=5.0)
    keys = jax.random.split(jax.random.PRNGKey(0), 32)
    x = np.asarray(jax.jit(jax.vmap(env.reset))(keys).pipeline_state.qpos[:, 0])
    assert np.all((x >= 0) & (x <= 5)) and np.ptp(x) > 3
    default = flat_reset(keys[:FLAT_ROBOTS])  # the size the other tests compiled
    assert np.all(np.asarray(default.pipeline_state.qpos[:, 0]) == 0)


def test_spawns_beyond_the_course_are_refused():
    # slope5's heightfield ends 3 m after the course end (x = 11 m)
    with pytest.raises(ValueError, match="spawn_x_max 13.5 m puts robots within 1.0 m of the end"):
        quadcos.make_env("slope5", spawn_x_max=13.5)
    assert quadcos.make_env("slope5", spawn_x_max=12.0).config.spawn_x_max == 12.0


def test_unknown_terrain_is_named():
    with pytest.raises(ValueError, match="unknown terrain 's5'"):
        quadcos.make_env("s5")


def test_missing_mjcf_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.xml"):
        quadcos.make_env("flat", robot=str(tmp_path / "nope.xml"))


def test_broken_mjcf_is_named(tmp_path):
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body><geom type='sphere'/></worldbody></mujoco>")
    with pytest.raises(ValueError, match="broken.xml"):
        quadcos.make_env("flat", robot=str(broken))


def test_mjcf_that_fails_to_compile_is_named(tmp_path):
    text = constants.MJCF_PATH.read_text().replace('mass="12"', 'mass="-12"')
    bad = tmp_path / "negative_mass.xml"
    bad.write_text(text)
    with pytest.raises(ValueError, match="negative_mass.xml"):
        quadcos.make_env("flat", robot=str(bad))


def test_posture_adds_front_and_hind_hip_offsets_to_the_rhythm(flat_env):
    posed = quadcos.make_env("flat", posture_bound=0.4)
    assert posed.action_size == 7
    assert posed.observation_size == flat_env.observation_size + 2  # its command has 7 values
    np.testing.assert_allclose(posed.action_for(oscillator.FIXED_TROT), np.zeros(7), atol=1e-6)
    action = jnp.array([0.3, -0.2, 0.1, 0.5, -0.4, 1.0, -0.5])
    offsets = posed.joint_targets(action, 1.0, 0.0) - flat_env.joint_targets(action[:5], 1.0, 0.0)
    np.testing.assert_allclose(offsets, [0.4, 0, 0.4, 0, -0.2, 0, -0.2, 0], atol=1e-6)
    assert posed.rhythm_parameters(action) == flat_env.rhythm_parameters(action[:5])


def test_the_start_ramp_lets_the_rhythm_in_over_the_first_seconds(flat_env):
    ramped = quadcos.make_env("flat", posture_bound=0.4, start_ramp_s=0.5)
    plain = quadcos.make_env("flat", posture_bound=0.4)
    action = jnp.array([0.3, -0.2, 0.1, 0.5, -0.4, 1.0, -0.5])
    home = ramped.layout.home
    np.testing.assert_allclose(ramped.joint_targets(action, 1.0, 0.0), home, atol=1e-6)
    full = plain.joint_targets(action, 1.0, 0.25) - home
    assert float(jnp.abs(full).max()) > 0.1
    np.testing.assert_allclose(ramped.joint_targets(action, 1.0, 0.25) - home, full / 2, atol=1e-6)
    for time in (0.5, 3.0):  # then all of it, as without the ramp
        expected = plain.joint_targets(action, 1.0, time)
        np.testing.assert_allclose(ramped.joint_targets(action, 1.0, time), expected, atol=1e-6)
    with pytest.raises(ValueError, match="start_ramp_s"):
        quadcos.make_env("flat", start_ramp_s=-1.0)
    with pytest.raises(ValueError, match="start_ramp_s > 0 needs controller='oscillator'"):
        quadcos.make_env("flat", start_ramp_s=0.5, controller="joint")


def test_action_scale_reaches_its_share_of_each_range_and_fixed_gaits_stay_where_they_were(flat_env):
    scaled = quadcos.make_env("flat", action_scale=0.3)
    centre, full, part = (
        flat_env.rhythm_parameters(jnp.zeros(5)),
        flat_env.rhythm_parameters(jnp.ones(5)),
        scaled.rhythm_parameters(jnp.ones(5)),
    )
    np.testing.assert_allclose(np.subtract(part, centre), 0.3 * np.subtract(full, centre), rtol=1e-5)
    # A fixed rhythm within reach commands the same parameters in both.
    within = flat_env.rhythm_parameters(jnp.full(5, 0.2))
    np.testing.assert_allclose(
        scaled.rhythm_parameters(scaled.action_for(within)), within, rtol=1e-5, atol=1e-6
    )


def test_held_rhythm_parameters_stay_at_the_centre_and_the_others_move_as_before(flat_env):
    held = quadcos.make_env("flat", held_rhythm="period, phi1,phi3", action_scale=0.5)
    action = jnp.array([0.8, -0.6, 1.0, -1.0, 0.7])
    centre = flat_env.rhythm_parameters(jnp.zeros(5))
    free = flat_env.rhythm_parameters(0.5 * action)
    got = held.rhythm_parameters(action)
    np.testing.assert_allclose(got[:2], free[:2], rtol=1e-5)
    np.testing.assert_allclose(got[2:], centre[2:], rtol=1e-6)
    # The action that commands them sets nothing where the rhythm is held.
    np.testing.assert_allclose(held.action_for(got)[2:], 0.0)
    np.testing.assert_allclose(held.action_for(got)[:2], action[:2], rtol=1e-5)


def test_the_speed_cap_limits_what_a_step_of_progress_pays():
    from quadcos import env as env_lib

    capped = quadcos.make_env("flat", forward_speed_cap=0.8).config
    assert env_lib.max_progress(capped, 0.05) == pytest.approx(0.04)
    assert env_lib.max_progress(env_lib.default_config(), 0.05) == float("inf")
