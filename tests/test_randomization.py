"""Domain randomisation: per-robot physics drawn at reset, applied inside each robot's step."""

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
import robot_variants

import quadcos
from quadcos import robot as robot_lib
from quadcos._util.overrides import apply_overrides
from quadcos.env import privileged, randomization
from quadcos.env.layout import Layout
from quadcos.robot import constants, prepare


def _config(**values):
    config = randomization.default_config()
    config.update(values)
    return config


def test_draws_stay_in_their_ranges_and_fixed_ranges_fix_the_value():
    config = _config(friction=(0.4, 0.4), latency_s=(0.02, 0.04), com_offset_m=0.01)
    draws = jax.vmap(lambda key: randomization.sample(key, config, 0.005))(
        jax.random.split(jax.random.PRNGKey(0), 256)
    )
    np.testing.assert_allclose(draws.friction, 0.4)
    assert set(np.unique(draws.latency_steps)) <= {4, 5, 6, 7, 8}
    assert len(np.unique(draws.latency_steps)) > 1
    for name in ("torso_mass_scale", "kp_scale", "damping_scale", "strength_scale"):
        low, high = config[name]
        values = np.asarray(getattr(draws, name))
        assert low <= values.min() < values.max() <= high, name
    assert np.abs(draws.com_offset).max() <= 0.01
    np.testing.assert_array_equal(draws.push, 0.0)


def test_conditions_give_each_robot_one_robustness_condition_and_only_its_perturbation():
    """`conditions` "robustness": each robot is the nominal robot, or at 40 ms of latency, or
    pushed (50 N, 0.1 s, every 2 s), or at friction 0.4 — evenly, the condition in its draw — as
    experiments/robustness/measure.py measures them one at a time; no observation noise."""
    config = _config(conditions="robustness", obs_noise=0.02, push_interval_s=5.0)
    keys = jax.random.split(jax.random.PRNGKey(0), 1024)
    draws = jax.vmap(lambda key: randomization.sample(key, config, 0.005))(keys)
    condition = np.asarray(jax.vmap(lambda key: randomization.condition_index(key, config))(keys))
    assert randomization.condition_names("robustness") == randomization.ROBUSTNESS
    assert (np.bincount(condition, minlength=4) > 200).all()
    np.testing.assert_allclose(draws.friction, np.where(condition == 3, 0.4, 1.5), rtol=1e-6)
    np.testing.assert_array_equal(draws.latency_steps, np.where(condition == 1, 8, 0))
    for name in ("torso_mass_scale", "kp_scale", "damping_scale", "strength_scale"):
        np.testing.assert_array_equal(getattr(draws, name), 1.0)

    def pushes(physics, index, key):  # 20 s of control steps: the largest push force seen
        def step(physics, key):
            physics = randomization.next_push(key, physics, config, 0.02, index)
            return physics, jnp.linalg.norm(physics.push)

        return jax.lax.scan(step, physics, jax.random.split(key, 1000))[1].max()

    pushed = np.asarray(jax.vmap(pushes)(draws, jnp.asarray(condition), keys))
    np.testing.assert_allclose(pushed, np.where(condition == 2, 50.0, 0.0), rtol=1e-5)
    assert not randomization.has_obs_noise(config)
    assert randomization.has_obs_noise(_config(conditions="nominal;observation noise 0.05"))
    assert randomization.condition_key("pushes 50 N, 0.1 s") == "pushes_50_n_0.1_s"


def test_range_ends_put_that_share_of_draws_at_the_ends_and_keep_the_rest():
    keys = jax.random.split(jax.random.PRNGKey(3), 4096)

    def draws(ends: float) -> randomization.Physics:
        config = _config(range_ends=ends)
        return jax.vmap(lambda key: randomization.sample(key, config, 0.005))(keys)

    uniform, half, every = draws(0.0), draws(0.5), draws(1.0)
    low, high = np.float32(randomization.default_config().friction)
    assert set(np.asarray(every.friction).tolist()) == {low, high}
    at_ends = np.isin(np.asarray(half.friction), (low, high))
    assert 0.45 < at_ends.mean() < 0.55
    assert 0.4 < (np.asarray(half.friction)[at_ends] == low).mean() < 0.6
    # The other draws are the uniform ones, unchanged.
    np.testing.assert_array_equal(half.friction[~at_ends], uniform.friction[~at_ends])
    np.testing.assert_array_equal(half.com_offset, uniform.com_offset)


def test_a_draw_changes_only_the_model_fields_it_names():
    env = quadcos.make_env("flat")
    physics = randomization.Physics(
        friction=jnp.float32(0.5),
        torso_mass_scale=jnp.float32(1.2),
        com_offset=jnp.array([0.01, 0.0, -0.02]),
        kp_scale=jnp.float32(0.9),
        damping_scale=jnp.float32(1.1),
        strength_scale=jnp.float32(0.8),
        latency_steps=jnp.int32(2),
        push=jnp.zeros(3),
        push_left_s=jnp.float32(0.0),
        level=jnp.float32(1.0),
    )
    torso = env.mj_model.body(constants.TORSO_BODY).id
    model = randomization.apply(env.model, physics, torso)
    np.testing.assert_allclose(model.geom_friction[:, 0], 0.5)
    np.testing.assert_allclose(model.geom_friction[:, 1:], env.model.geom_friction[:, 1:])
    np.testing.assert_allclose(model.body_mass[torso], 1.2 * env.model.body_mass[torso], rtol=1e-6)
    others = np.arange(env.mj_model.nbody) != torso
    np.testing.assert_array_equal(model.body_mass[others], env.model.body_mass[others])
    np.testing.assert_allclose(
        model.body_ipos[torso], env.model.body_ipos[torso] + physics.com_offset
    )
    np.testing.assert_allclose(model.actuator_gainprm[:, 0], 0.9 * 400.0, rtol=1e-6)
    np.testing.assert_allclose(model.actuator_biasprm[:, 1], -0.9 * 400.0, rtol=1e-6)
    np.testing.assert_allclose(model.dof_damping, 1.1 * env.model.dof_damping, rtol=1e-6)
    np.testing.assert_allclose(model.actuator_forcerange, 0.8 * env.model.actuator_forcerange)


def test_torque_motors_keep_their_gains():
    env = quadcos.make_env("flat", robot="quad12")
    # Motors (gain 1, no bias): the env closes their PD; the draw must not turn them into servos.
    nu = env.mj_model.nu
    motors = env.model.replace(
        actuator_gainprm=env.model.actuator_gainprm.at[:, 0].set(1.0),
        actuator_biasprm=env.model.actuator_biasprm.at[:, :3].set(0.0),
    )
    physics = randomization.sample(jax.random.PRNGKey(0), randomization.default_config(), 0.005)
    physics = physics._replace(kp_scale=jnp.float32(0.8))
    model = randomization.apply(motors, physics, 1)
    np.testing.assert_array_equal(model.actuator_gainprm[:, 0], np.ones(nu))
    np.testing.assert_array_equal(model.actuator_biasprm[:, :3], np.zeros((nu, 3)))
    servos = randomization.apply(env.model, physics, 1)
    np.testing.assert_allclose(
        servos.actuator_biasprm[:, 1], -0.8 * env.model.actuator_gainprm[:, 0], rtol=1e-6
    )


def test_a_weaker_draw_clips_the_torque_motors_pd(tmp_path):
    path = robot_variants.motors_without_gains(tmp_path)
    model = prepare.load_spec(path).compile()
    description = robot_lib.describe(model, name="motors", kp=100.0, kd=2.0)
    layout = Layout.of(description, model, np)
    data = mujoco.MjData(model)
    far = data.qpos[layout.joint_qpos] + 2.0  # a PD torque beyond every limit
    full, weak = layout.controls(far, data), layout.controls(far, data, 0.75)
    limits = layout.torque_limit[layout.actuator_joint]
    np.testing.assert_allclose(np.abs(full), limits)
    np.testing.assert_allclose(np.abs(weak), 0.75 * limits)
    physics = randomization.sample(jax.random.PRNGKey(0), randomization.default_config(), 0.005)
    physics = physics._replace(strength_scale=jnp.float32(0.6), level=jnp.float32(0.5))
    assert float(randomization.strength(physics)) == pytest.approx(0.8)  # at half its level


def test_a_draw_acts_at_its_level_from_the_nominal_robot():
    env = quadcos.make_env("flat")
    config = _config(latency_s=(0.04, 0.04), com_offset_m=0.02)
    drawn = randomization.sample(jax.random.PRNGKey(3), config, 0.005)
    assert float(drawn.level) == 1.0  # a fresh draw acts fully
    drawn = drawn._replace(push=jnp.array([50.0, 0.0, 0.0]), friction=jnp.float32(0.5))
    torso = env.mj_model.body(constants.TORSO_BODY).id
    fields = ("geom_friction", "body_mass", "body_ipos", "actuator_gainprm", "actuator_biasprm")
    fields += ("dof_damping", "actuator_forcerange")
    nominal = randomization.apply(env.model, drawn._replace(level=jnp.float32(0.0)), torso)
    full = randomization.apply(env.model, drawn, torso)
    half = randomization.apply(env.model, drawn._replace(level=jnp.float32(0.5)), torso)
    for field in fields:
        np.testing.assert_allclose(getattr(nominal, field), getattr(env.model, field), rtol=1e-6)
        expected = (np.asarray(getattr(env.model, field)) + np.asarray(getattr(full, field))) / 2
        np.testing.assert_allclose(getattr(half, field), expected, rtol=1e-5, atol=1e-7)
    assert int(randomization.latency_steps(drawn)) == 8
    assert int(randomization.latency_steps(drawn._replace(level=jnp.float32(0.5)))) == 4
    np.testing.assert_allclose(randomization.push_force(drawn._replace(level=0.25)), [12.5, 0, 0])


def test_the_ramp_raises_each_training_robots_level_with_its_steps_and_keeps_it_at_reset():
    from brax import envs

    from quadcos.training import curriculum

    physics = randomization.sample(jax.random.PRNGKey(0), _config(), 0.005)
    physics = jax.tree.map(lambda value: jnp.stack([value, value]), physics)  # two envs

    class Inner(envs.Env):  # what the ramp sees of the batched training env: levels passed on
        def reset(self, rng):
            info = {"physics": physics}
            return envs.State(None, jnp.zeros((2, 1)), jnp.zeros(2), jnp.zeros(2), {}, info)

        def step(self, state, action):
            return state.replace(obs=state.info["physics"].level[:, None])

        observation_size = action_size = 1
        backend = "mjx"

    ramp = curriculum.RandomizationRamp(Inner(), dt=0.05, ramp_s=0.1)
    state = ramp.reset(jax.random.split(jax.random.PRNGKey(1), 2))
    np.testing.assert_array_equal(state.info["physics"].level, [0.0, 0.0])
    seen = []
    for _ in range(4):
        state = ramp.step(state, jnp.zeros((2, 1)))
        seen.append(float(state.obs[0, 0]))
    assert seen == pytest.approx([0.0, 0.5, 1.0, 1.0])  # min(1, steps · dt / ramp_s)
    env = quadcos.make_env("flat", **{"randomization.enabled": True})
    one = jax.tree.map(lambda value: value[0], physics)._replace(level=jnp.float32(0.3))
    info = {"physics": one, "rng": jax.random.PRNGKey(2), "fresh_draw": jnp.bool_(False)}
    redrawn = env._perturb(info | {"action": jnp.zeros(env.action_size)}, jnp.bool_(True))
    assert float(redrawn["physics"].level) == pytest.approx(0.3)  # the auto-reset's new draw


def test_pushes_start_run_for_their_duration_and_stop():
    config = _config(push_interval_s=1e-9, push_force_n=50.0, push_duration_s=0.1)
    physics = randomization.sample(jax.random.PRNGKey(0), config, 0.005)
    forces = []
    for step in range(4):
        physics = randomization.next_push(jax.random.PRNGKey(step), physics, config, 0.05)
        forces.append(float(jnp.linalg.norm(physics.push)))
    # Starts at once (interval ~0), acts for 0.1 s = 2 control steps, then a new push starts.
    np.testing.assert_allclose(forces, [50.0, 50.0, 50.0, 50.0], rtol=1e-5)
    config.push_interval_s = 1e9  # a push under way ends and none follows
    physics = randomization.next_push(jax.random.PRNGKey(9), physics, config, 0.05)
    physics = randomization.next_push(jax.random.PRNGKey(10), physics, config, 0.05)
    assert float(jnp.linalg.norm(physics.push)) == 0.0


@pytest.mark.parametrize(
    "key, value, message",
    [
        ("randomization.friction", (1.0, 0.5), "randomization.friction must be (low, high)"),
        ("randomization.latency_s", (-0.01, 0.0), "randomization.latency_s must be"),
        ("randomization.push_force_n", -1.0, "randomization.push_force_n must be finite and >= 0"),
        ("randomization.obs_noise", -0.1, "randomization.obs_noise must be finite and >= 0"),
        ("randomization.ramp_s", -1.0, "randomization.ramp_s must be finite and >= 0"),
        ("randomization.range_ends", 1.5, "randomization.range_ends must be a share from 0 to 1"),
        (
            "randomization.eval_conditions",
            "nominal;ice",
            "eval_conditions: unknown condition 'ice'",
        ),
        ("randomization.conditions", "robustness", "conditions needs randomization.enabled"),
        ("randomization.eval_conditions", "nominal;nominal", "a condition named twice"),
    ],
)
def test_bad_ranges_are_named(key, value, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        quadcos.env.validate_config(apply_overrides(quadcos.env.default_config(), {key: value}))


def test_a_latency_beyond_the_control_step_is_refused_when_randomising():
    late = {"randomization.latency_s": (0.0, 0.06), "control_dt": 0.05}
    config = apply_overrides(quadcos.env.default_config(), late)
    quadcos.env.validate_config(config)  # not randomised: the range is not drawn from
    config.randomization.enabled = True
    with pytest.raises(
        ValueError, match=r"randomization.latency_s reaches 0.06 s, beyond control_dt"
    ):
        quadcos.env.validate_config(config)


ROBOTS = 16


@pytest.fixture(scope="module")
def randomised():
    """A randomised env without pushes (each test sets its own), with observation noise, and its
    reset and step over `ROBOTS` robots: one pair of programs for the tests below."""
    overrides = {
        "randomization.enabled": True,
        "randomization.friction": (0.2, 1.5),
        "randomization.push_interval_s": 0.0,
        "randomization.obs_noise": 0.05,
    }
    env = quadcos.make_env("flat", **overrides)
    return env, jax.jit(jax.vmap(env.reset)), jax.jit(jax.vmap(env.step))


@pytest.mark.slow
def test_randomised_robots_differ_and_a_push_moves_the_torso_sideways(randomised):
    env, reset, step = randomised
    state = reset(jax.random.split(jax.random.PRNGKey(1), ROBOTS))
    assert len(np.unique(state.info["physics"].friction)) == ROBOTS
    # Robots with the same draw; robot 0 is pushed along +y with 200 N, the others are not.
    action = jnp.zeros((ROBOTS, env.action_size))
    state = step(reset(jnp.stack([jax.random.PRNGKey(2)] * ROBOTS)), action)
    push = jnp.zeros((ROBOTS, 3)).at[0, 1].set(200.0)
    # float32, not a weakly typed 0.05: the state keeps its types, and `step` is not traced again.
    push_left_s = jnp.full(ROBOTS, 0.05, jnp.float32)
    physics = state.info["physics"]._replace(push=push, push_left_s=push_left_s)
    state = state.replace(info={**state.info, "physics": physics})
    for _ in range(3):
        state = step(state, action)
    y = np.asarray(state.pipeline_state.qpos[:, 1])
    np.testing.assert_allclose(y[1:], y[1], atol=1e-6)  # same draw, same motion
    assert y[0] - y[1] > 0.02, y
    assert np.isfinite(np.asarray(state.obs)).all() and not np.asarray(state.done).any()


@pytest.mark.slow
def test_a_robot_steps_with_its_resets_draw_and_draws_anew_after_an_auto_reset(randomised):
    """A robot keeps the physics its reset drew (an evaluation in robustness conditions groups
    its robots by that draw's condition); Brax's auto-reset restores the first physics state and
    keeps the finished episode's info, and the step after it draws anew."""
    env, reset, step = randomised
    action = jnp.zeros((ROBOTS, env.action_size))
    first = reset(jax.random.split(jax.random.PRNGKey(6), ROBOTS))
    state = step(first, action)
    np.testing.assert_array_equal(state.info["physics"].friction, first.info["physics"].friction)
    auto_reset = step(state.replace(pipeline_state=first.pipeline_state), action)
    redrawn = np.asarray(auto_reset.info["physics"].friction)
    assert (redrawn != np.asarray(first.info["physics"].friction)).all(), redrawn


@pytest.mark.slow
def test_observation_noise_reaches_the_policy_not_the_robot(randomised):
    env, reset, step = randomised
    # The same 8 robots twice: their resets draw their physics from the same keys; then the two
    # halves' noise is drawn from other keys.
    half = ROBOTS // 2
    state = reset(jnp.tile(jax.random.split(jax.random.PRNGKey(4), half), (2, 1)))
    action = jnp.zeros((ROBOTS, env.action_size))
    state = step(state, action)
    state.info["rng"] = jax.random.split(jax.random.PRNGKey(5), ROBOTS)
    state = step(state, action)
    one, other = jax.tree.map(lambda x: x[:half], state), jax.tree.map(lambda x: x[half:], state)
    np.testing.assert_allclose(
        one.pipeline_state.qpos, other.pipeline_state.qpos, atol=1e-6
    )  # the robot moves whatever its noise
    difference = np.asarray(one.obs - other.obs)  # two draws: 0.05·√2 apart
    assert 0.06 < difference.std() < 0.08 and abs(difference.mean()) < 0.01, difference.std()


@pytest.mark.slow
def test_a_privileged_critic_observes_each_robots_draw_and_the_action_still_pending(randomised):
    """`quadcos.env.privileged`: clean velocities, then the draw as it acts (level, friction,
    scales, latency, CoM offset, push time left), the push and the action that acts for the
    latency's first steps of the next control step."""
    env, reset, step = randomised
    action = jnp.linspace(-0.5, 0.5, ROBOTS * env.action_size).reshape(ROBOTS, -1)
    state = step(reset(jax.random.split(jax.random.PRNGKey(7), ROBOTS)), action)
    inputs = privileged.of(env)
    seen = np.asarray(inputs.observe(state))
    physics = state.info["physics"]
    assert seen.shape == (ROBOTS, inputs.size) == (ROBOTS, 6 + 11 + 3 + env.action_size)
    np.testing.assert_allclose(
        seen[:, :3], state.pipeline_state.qvel[:, env.layout.linear_velocity]
    )
    np.testing.assert_allclose(seen[:, 7], physics.friction)
    latency = np.asarray(physics.latency_steps) * env.config.physics_dt
    np.testing.assert_allclose(seen[:, 12], latency, atol=1e-6)
    assert len(np.unique(seen[:, 12])) > 1 and seen[:, 12].max() <= 0.04 + 1e-6
    np.testing.assert_allclose(seen[:, -env.action_size :], action, atol=1e-6)
    with pytest.raises(ValueError, match="needs a quadcos env; object"):
        privileged.of(object())


@pytest.mark.slow
def test_warp_steps_randomised_robots_as_jax_does():
    """MJX-Warp takes the per-robot model fields: under the same draws (friction, mass, centre of
    mass, gains, damping, strength, latency, pushes) its robots move as MJX-JAX's. Runs where
    warp-lang is installed (the `warp` extra; on a CPU too)."""
    pytest.importorskip("warp", reason="warp-lang (the warp extra) is not installed")
    overrides = {"randomization.enabled": True, "randomization.push_interval_s": 0.5}
    positions = {}
    for impl in ("jax", "warp"):
        env = quadcos.make_env("flat", impl=impl, **overrides)
        state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(3), 4))
        step = jax.jit(jax.vmap(env.step))
        for _ in range(20):
            state = step(state, jnp.zeros((4, env.action_size)))
        positions[impl] = np.asarray(state.pipeline_state.qpos[:, :3])
    nominal = quadcos.make_env("flat", impl="jax")
    state = jax.jit(jax.vmap(nominal.reset))(jax.random.split(jax.random.PRNGKey(3), 4))
    step = jax.jit(jax.vmap(nominal.step))
    for _ in range(20):
        state = step(state, jnp.zeros((4, nominal.action_size)))
    np.testing.assert_allclose(positions["warp"], positions["jax"], atol=2e-3)
    # ... and the draws matter: the randomised robots are not where the nominal ones are.
    assert (
        np.abs(positions["jax"][:, :2] - np.asarray(state.pipeline_state.qpos[:, :2])).max() > 0.05
    )


def test_nominal_pins_every_range_at_the_nominal_robot():
    """NOMINAL (a single perturbation's base) leaves no range drawn: each fixed at one value, the
    scales at 1, no latency, pushes, noise or centre-of-mass offset; what it leaves unset is no
    range (a push's size, the training ramp, the share of draws at the ends, whether the drive
    is late with the action)."""
    pinned = {key.removeprefix("randomization."): v for key, v in randomization.NOMINAL.items()}
    for name in randomization.RANGES:
        low, high = pinned[name]
        assert low == high, name
        assert name == "friction" or low == (0.0 if name == "latency_s" else 1.0), name
    assert pinned["enabled"] and pinned["com_offset_m"] == 0
    assert pinned["push_interval_s"] == 0 and pinned["obs_noise"] == 0
    unset = set(randomization.default_config()) - set(pinned)
    assert unset == {"push_force_n", "push_duration_s", "ramp_s", "range_ends", "eval_conditions",
                     "delay_drive"}
    assert pinned["conditions"] == ""  # the ranges, also for a policy trained on conditions
    config = apply_overrides(quadcos.env.default_config(), randomization.NOMINAL)
    randomization.validate(config.randomization)  # a config the env accepts


@pytest.mark.slow
def test_delay_drive_makes_the_latency_delay_the_commanded_drive_as_it_does_the_action():
    """Without `delay_drive` only the action is late: a gait (zero actions) walks the same at
    40 ms of latency as without it. With it the drive's scales are the previous step's for the
    latency's substeps: the same walk without latency, another with it (the drive's gain and
    heading loops change its scales every step)."""
    overrides = {
        "commands.spec": "0.2,0@0.1;0.6,0.4@2",
        "commands.feed_forward": True,
        "commands.speed_gain_rate": 1.0,
        "commands.heading_gain": 2.0,
        "randomization.enabled": True,
        "randomization.push_interval_s": 0.0,
    }
    qpos = {}
    for delay in (False, True):
        env = quadcos.make_env("flat", **overrides, **{"randomization.delay_drive": delay})
        reset, step = jax.jit(jax.vmap(env.reset)), jax.jit(jax.vmap(env.step))
        state = reset(jnp.stack([jax.random.PRNGKey(0)] * 2))  # two robots of one draw
        late = jnp.array([0, round(0.04 / env.config.physics_dt)], jnp.int32)  # 0 and 40 ms
        physics = state.info["physics"]._replace(latency_steps=late, level=jnp.ones(2))
        state = state.replace(info={**state.info, "physics": physics})
        action = jnp.zeros((2, env.action_size))
        for _ in range(20):
            state = step(state, action)
        qpos[delay] = np.asarray(state.pipeline_state.qpos)
    np.testing.assert_allclose(qpos[False][1], qpos[False][0], atol=1e-6)
    np.testing.assert_allclose(qpos[True][0], qpos[False][0], atol=1e-6)
    assert np.abs(qpos[True][1] - qpos[True][0]).max() > 1e-3
