"""Velocity commands (issue 58): the spec parser, sampling and resampling, the heading target, the
tracking reward's reduction to Eqs. 8–13, the turning extensions of Eq. 3, a commanded env, and
the gait-quality metrics on a synthetic trace."""

import types

import flax.struct
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from brax.envs.wrappers import training as training_wrappers

import quadcos
from quadcos.deploy import twins
from quadcos.env import commands, observation, tracking
from quadcos.equations import oscillator, reward
from quadcos.evaluation import metrics, rollout, sources
from quadcos.robot import presets
from quadcos.training import periodic_eval
from quadcos.training import presets as training_presets

# --- the spec ---------------------------------------------------------------------------------


def test_parse_random_off_and_a_schedule():
    assert commands.parse_commands("") == commands.CommandSpec("off")
    assert not commands.parse_commands(" ").enabled
    assert commands.parse_commands("random") == commands.CommandSpec("random")
    parsed = commands.parse_commands("0.5,0@5;1.0,0@5; 0.6,0.4@5;0,0@2.5")
    assert parsed.mode == "schedule" and parsed.enabled
    assert parsed.schedule == (
        commands.Segment(0.5, 0.0, 5.0),
        commands.Segment(1.0, 0.0, 5.0),
        commands.Segment(0.6, 0.4, 5.0),
        commands.Segment(0.0, 0.0, 2.5),
    )


@pytest.mark.parametrize(
    "spec, bad",
    [
        ("0.5,0@5;1.0@5", "segment 2 '1.0@5'"),
        ("0.5,0", "segment 1 '0.5,0'"),
        ("0.5,x@5", "must be numbers"),
        ("0.5,0@0", "seconds must be > 0"),
        ("0.5,0@-1", "seconds must be > 0"),
        ("nan,0@1", "finite"),
        ("randm", "segment 1 'randm'"),
        ("0.5,0@5;", "segment 2 ''"),
    ],
)
def test_a_bad_spec_names_its_bad_part(spec, bad):
    with pytest.raises(ValueError, match=bad.replace("(", r"\(")):
        commands.parse_commands(spec)


def test_robot_ranges_presets_and_froude_default():
    assert presets.preset_for("unitree_go1").command_speed_max == 1.0
    assert presets.preset_for("unitree_go2").command_yaw_rate_max == 0.5
    assert presets.preset_for("anybotics_anymal_c").command_speed_max == 0.8
    assert presets.preset_for("anybotics_anymal_c").command_yaw_rate_max == 0.4
    assert commands.speed_range(0.7, 10.0) == 0.7
    for height in (0.2, 0.288, 0.5, 0.67):
        expected = np.floor(10 * np.sqrt(0.25 * 9.81 * height)) / 10
        assert commands.speed_range(None, height) == pytest.approx(expected)
        assert commands.yaw_rate_range(None, expected) == pytest.approx(expected / 2.0)
    # quad12 (Go1-sized, no preset): its config resolves to the derived ranges
    config = quadcos.env.default_config()
    config.robot = "quad12"
    config = quadcos.env.resolve(config)
    assert config.commands.speed_max == pytest.approx(0.8)
    assert config.commands.yaw_rate_max == pytest.approx(0.4)


# --- sampling, resampling, the schedule, the heading ------------------------------------------


def _config(**values):
    config = commands.default_config()
    config.update(dict(speed_min=0.2, speed_max=0.9, yaw_rate_max=0.5) | values)
    return config


def test_samples_cover_the_ranges_with_a_share_of_straight_walking():
    config = _config(zero_yaw_rate_probability=0.25)
    draws = np.asarray(jax.vmap(lambda key: commands.sample(key, config))(
        jax.random.split(jax.random.PRNGKey(1), 8000)
    ))
    speed, yaw_rate = draws[:, 0], draws[:, 1]
    assert speed.min() >= 0.2 and speed.max() <= 0.9
    assert speed.min() < 0.21 and speed.max() > 0.89
    assert np.abs(speed.mean() - 0.55) < 0.01
    assert np.abs(yaw_rate).max() <= 0.5
    straight = yaw_rate == 0
    assert abs(straight.mean() - 0.25) < 0.02  # binomial std 0.005
    assert np.abs(yaw_rate[~straight]).max() > 0.49 and abs(yaw_rate[~straight].mean()) < 0.02


def test_a_share_of_draws_stands_and_the_others_are_the_draws_without_it():
    keys = jax.random.split(jax.random.PRNGKey(2), 4000)

    def draws(**values) -> np.ndarray:
        config = _config(**values)
        return np.asarray(jax.vmap(lambda key: commands.sample(key, config))(keys))

    walking, standing = draws(), draws(zero_command_probability=0.3)
    still = np.all(standing == 0, axis=1)
    assert abs(still.mean() - 0.3) < 0.025  # binomial std 0.007
    assert not np.any(np.all(walking == 0, axis=1))  # v* >= 0.2: no standing draw without it
    np.testing.assert_array_equal(standing[~still], walking[~still])
    # which draws stand is independent of the others: the turns left walking span both ends
    turns = walking[~still, 1]
    assert turns.min() < -0.45 and turns.max() > 0.45 and abs(turns.mean()) < 0.03
    config = _config(spec="random", zero_command_probability=1.5)
    with pytest.raises(ValueError, match=r"commands.zero_command_probability must be in \[0, 1\]"):
        commands.validate(config)


def test_random_commands_are_resampled_every_period_only():
    plan = commands.Plan(commands.CommandSpec("random"), _config(resample_seconds=1.0))
    command = plan.start(jax.random.PRNGKey(0))
    np.testing.assert_array_equal(command.initial, command.velocity)
    times = np.round(np.arange(0, 3.01, 0.05), 6)
    seen = [np.asarray(command.velocity)]
    for before, now in zip(times[:-1], times[1:]):
        command = plan.advance(command, jnp.float32(before), jnp.float32(now))
        seen.append(np.asarray(command.velocity))
    changes = [i for i in range(1, len(seen)) if not np.array_equal(seen[i], seen[i - 1])]
    assert [float(times[i]) for i in changes] == [1.0, 2.0, 3.0]
    moved = command.replace(
        heading=jnp.float32(0.3), speed=jnp.float32(0.4), gain=jnp.float32(0.7),
        correction=jnp.float32(0.2), yaw_rate=jnp.float32(0.3),
    )
    restarted = plan.restart(moved, jnp.bool_(True))
    np.testing.assert_array_equal(restarted.velocity, command.initial)
    assert float(restarted.heading) == 0.0 and float(restarted.speed) == 0.0
    assert float(restarted.gain) == 1.0 and float(restarted.correction) == 0.0
    assert float(restarted.yaw_rate) == 0.0
    kept = plan.restart(moved, jnp.bool_(False))  # no reset: every field as it was
    assert float(kept.yaw_rate) == pytest.approx(0.3) and float(kept.gain) == pytest.approx(0.7)


def test_the_observed_speed_settles_on_the_mean_of_a_strided_walk():
    """A gait whose progress per step alternates 0.01 / 0.04 m (0.5 m/s on average, strided):
    the filter's output settles within a few time constants near 0.5 m/s and its ripple is a
    fraction of the raw speed's 0.3 m/s swing."""
    dt, tau, speed, seen = 0.05, 0.5, 0.0, []
    for step in range(200):
        speed = commands.low_passed_speed(speed, 0.01 if step % 2 else 0.04, dt, tau)
        seen.append(speed)
    late = np.asarray(seen[-20:])
    assert abs(late.mean() - 0.5) < 0.02 and np.ptp(late) < 0.05
    assert seen[9] < 0.5 * 0.7  # after 0.5 s (one τ): 1 − e⁻¹ of the way, not there yet
    assert commands.low_passed_speed(0.3, 0.04, dt, 0.0) == 0.3  # τ = 0: not observed


def test_the_drives_gain_settles_where_the_robot_walks_its_command():
    """A robot whose strides walk 1.3× what the drive asks (speed = 1.3 · g · v*, strided): the
    gain integrates the relative error to 1 / 1.3; it holds below GAIN_MIN_SPEED, stays within
    GAIN_RANGE, and is 1 for ever at rate 0. NumPy and JAX give the same numbers."""
    dt, gain, gains = 0.05, 1.0, []
    for step in range(400):
        speed = 1.3 * gain * 0.6 * (0.5 if step % 2 else 1.5)  # strided about 1.3 g v*
        gain = commands.corrected_gain(gain, 0.6, speed * dt, dt, 1.0, np)
        gains.append(gain)
    assert abs(np.mean(gains[-20:]) - 1 / 1.3) < 0.02
    assert commands.corrected_gain(1.2, 0.05, 0.0, dt, 1.0, np) == 1.2  # v* too slow: held
    assert commands.corrected_gain(0.51, 0.6, 0.06, dt, 50.0, np) == commands.GAIN_RANGE[0]
    assert commands.corrected_gain(1.0, 0.6, 0.0, dt, 0.0, np) == 1.0
    jax_gain = commands.corrected_gain(jnp.float32(0.9), 0.6, 0.02, dt, 2.0, jnp)
    assert float(jax_gain) == pytest.approx(commands.corrected_gain(0.9, 0.6, 0.02, dt, 2.0, np))
    np.testing.assert_allclose(
        commands.driven(jnp.asarray([[0.5, 0.2]]), jnp.asarray([0.8])), [[0.4, 0.16]]
    )


def test_the_heading_loop_turns_a_lagging_robot_towards_the_commanded_heading():
    """k·(ψ* − yaw), wrapped: a robot 0.2 rad behind ψ* is turned faster (2 rad/s·0.2 = 0.4
    rad/s onto ω*), one ahead slower, one across ±π the short way; none at k = 0. The env's
    command after a step holds the correction the next step's drive adds to ω*."""
    assert float(commands.steering(0.3, 0.1, 2.0, np)) == pytest.approx(0.4)
    assert float(commands.steering(-0.1, 0.1, 2.0, np)) == pytest.approx(-0.4)
    assert float(commands.steering(3.1, -3.1, 1.0, np)) == pytest.approx(6.2 - 2 * np.pi)
    assert float(commands.steering(0.3, 0.1, 0.0, np)) == 0.0
    np.testing.assert_allclose(
        commands.driven(np.asarray([0.5, 0.2]), 0.8, np, 0.1), [0.4, 0.24], rtol=1e-6
    )
    config = commands.default_config()
    config.update(spec="0.5,0.4@5", speed_max=1.0, yaw_rate_max=0.5, tracking="yaw_rate")
    config.heading_gain = 2.0
    plan = commands.Plan(commands.validate(config), config)
    command = plan.start(jax.random.PRNGKey(0))
    _, command = plan.step(
        command, jnp.float32(0.0), jnp.float32(0.0), 0.05, 0.0, 0.05, jnp.float32(0.02)
    )
    assert float(command.heading) == pytest.approx(0.02)  # ψ* = ω*·dt, the robot did not turn
    assert float(command.correction) == pytest.approx(0.04)


def test_the_command_preset_closes_both_loops_and_the_papers_presets_leave_them_open():
    closed = training_presets.build_config(training_presets.PRESETS["command"], {}).env.commands
    assert (closed.speed_gain_rate, closed.heading_gain) == (1.0, 2.0)
    for name in ("gpu", "any_slope", "robust"):
        opened = training_presets.build_config(training_presets.PRESETS[name], {}).env.commands
        assert (opened.speed_gain_rate, opened.heading_gain) == (0.0, 0.0)


def test_schedule_against_numpy():
    spec = commands.parse_commands("0.5,0@5;1.0,0@5;0.6,0.4@5;0,0@5")
    plan = commands.Plan(spec, _config())
    for time in (0.0, 2.0, 4.999, 5.0, 7.0, 10.0, 14.0, 15.0, 19.9, 25.0, 100.0):
        ends = np.cumsum([s.seconds for s in spec.schedule])
        index = min(int(np.searchsorted(ends, time, side="right")), len(ends) - 1)
        expected = (spec.schedule[index].speed, spec.schedule[index].yaw_rate)
        got = plan.at(jax.random.PRNGKey(0), jnp.float32(time))
        np.testing.assert_allclose(got, expected, err_msg=f"t = {time}")


def test_heading_integrates_the_yaw_rate_on_a_leash():
    heading = jnp.float32(0.0)
    for _ in range(10):  # the robot follows: its yaw is the heading
        heading = commands.advance_heading(heading, 0.4, heading, 0.05, 0.5)
    assert float(heading) == pytest.approx(0.2, rel=1e-5)
    # a robot that does not turn: the heading leads it by the leash at most
    stuck = jnp.float32(0.0)
    for _ in range(100):
        stuck = commands.advance_heading(stuck, 0.4, 0.0, 0.05, 0.5)
    assert float(stuck) == pytest.approx(0.5, rel=1e-5)
    # across ±π the heading wraps
    assert float(commands.advance_heading(3.1, 1.0, 3.1, 0.1, 0.5)) == pytest.approx(
        3.2 - 2 * np.pi, abs=1e-5
    )
    # no turn commanded, a robot within the leash: exactly 0, bit for bit
    yaws = jnp.linspace(-0.5, 0.5, 101)
    zero = jax.vmap(lambda yaw: commands.advance_heading(0.0, 0.0, yaw, 0.05, 0.5))(yaws)
    np.testing.assert_array_equal(zero, 0.0)


def test_yaw_rate_tracking_reads_the_steps_own_turn():
    plan = commands.Plan(commands.CommandSpec("random"), _config(tracking="yaw_rate"))
    command = plan.start(jax.random.PRNGKey(0)).replace(velocity=jnp.asarray([0.5, 0.4]))
    tracking, after = plan.step(
        command, jnp.float32(3.13), jnp.float32(-3.13), 0.05, 0.0, 0.05, jnp.float32(0.02)
    )
    turned = 6.26 - 2 * np.pi  # across ±π: a turn of −0.023 rad, not +6.26
    assert float(tracking["yaw_rate_error"]) == pytest.approx(turned / 0.05 - 0.4, abs=1e-3)
    assert float(tracking["heading"]) == pytest.approx(-3.13)  # the heading at the step's start
    assert float(tracking["commanded_progress"]) == pytest.approx(0.025)
    assert float(after.heading) == 0.0  # no ψ* to integrate
    assert float(after.speed) == 0.0  # observed_speed_tau 0: no speed observed
    with pytest.raises(ValueError, match="commands.tracking must be one of heading, yaw_rate"):
        commands.validate(_config(spec="random", tracking="heading_rate"))


def test_low_passed_yaw_rate_tracks_the_turn_over_strides_not_its_sway():
    """`yaw_rate_tau` > 0: the yaw term's ω is the yaw rate low-passed over τ, so a stride's sway
    about a steady turn costs far less than the per-step rate charges, and the low-passed rate
    settles on the turn's mean."""
    errors = {}
    for tau in (0.0, 0.25):
        config = _config(spec="random", tracking="yaw_rate", yaw_rate_tau=tau, resample_seconds=60)
        plan = commands.Plan(commands.validate(config), config)
        command = plan.start(jax.random.PRNGKey(0)).replace(velocity=jnp.asarray([0.5, 0.3]))
        yaw, error, rate = 0.0, [], []
        for step in range(200):  # 0.3 rad/s with a ±0.3 rad/s sway over a 0.4-s stride
            turn = 0.05 * (0.3 + 0.3 * np.sin(2 * np.pi * step * 0.05 / 0.4))
            times = (0.05 * step, 0.05 * step + 0.05)
            tracking, command = plan.step(
                command, jnp.float32(yaw + turn), jnp.float32(yaw), 0.05, *times, jnp.float32(0.02)
            )
            yaw += turn
            error.append(abs(float(tracking["yaw_rate_error"])))
            rate.append(float(command.yaw_rate))
        errors[tau] = np.mean(error[104:])  # 12 whole strides
        assert np.mean(rate[104:]) == (pytest.approx(0.3, abs=0.01) if tau else 0.0)
    sway = 0.3 * np.mean(np.abs(np.sin(np.arange(8) * np.pi / 4)))  # 8 steps a stride
    # one step from rest: the step's own turn is in the rate charged, blended in by 1 − e^(−dt/τ)
    config = _config(spec="random", tracking="yaw_rate", yaw_rate_tau=0.25, resample_seconds=60)
    plan = commands.Plan(commands.validate(config), config)
    command = plan.start(jax.random.PRNGKey(0)).replace(velocity=jnp.asarray([0.5, 0.3]))
    tracking, after = plan.step(
        command, jnp.float32(0.02), jnp.float32(0.0), 0.05, 0.0, 0.05, jnp.float32(0.02)
    )
    first = (1 - np.exp(-0.05 / 0.25)) * 0.02 / 0.05
    assert float(after.yaw_rate) == pytest.approx(first, rel=1e-5)
    assert float(tracking["yaw_rate_error"]) == pytest.approx(first - 0.3, rel=1e-5)
    assert errors[0.0] == pytest.approx(sway, rel=0.01)
    assert errors[0.25] < 0.3 * errors[0.0]
    with pytest.raises(ValueError, match="yaw_rate_tau needs commands.tracking='yaw_rate'"):
        commands.validate(_config(spec="random", tracking="heading", yaw_rate_tau=0.2))
    with pytest.raises(ValueError, match="commands.yaw_rate_tau must be finite and >= 0"):
        commands.validate(_config(spec="random", tracking="yaw_rate", yaw_rate_tau=-1.0))


def test_low_passed_speed_lets_the_forward_term_see_a_mean_error_inside_the_strides_sway():
    """`speed_tau` > 0: the forward term tracks the speed low-passed over τ. Per step, |d − c| of a
    trot whose speed swings ±0.3 m/s about its mean charges a 0.1-m/s mean error a quarter of what
    the error costs; low-passed, more than half, and the tracked speed settles on the mean."""
    weights = reward.RewardWeights(forward=1.0)
    drops = {}
    for tau in (0.0, 0.25):
        earned = {}
        for mean in (0.5, 0.4):  # m/s, commanded 0.5
            config = _config(spec="random", tracking="yaw_rate", speed_tau=tau, resample_seconds=60)
            plan = commands.Plan(commands.validate(config), config)
            command = plan.start(jax.random.PRNGKey(0)).replace(velocity=jnp.asarray([0.5, 0.0]))
            terms, speeds = [], []
            for step in range(200):  # a 0.4-s stride of 8 steps
                moved = 0.05 * (mean + 0.3 * np.sin(2 * np.pi * step * 0.05 / 0.4))
                times = (0.05 * step, 0.05 * step + 0.05)
                tracking, command = plan.step(
                    command, jnp.float32(0.0), jnp.float32(0.0), 0.05, *times, jnp.float32(moved)
                )
                assert ("tracked_progress" in tracking) == (tau > 0)  # τ = 0: the terms as before
                # the reward as the env computes it: the step moved `moved` m along its heading
                terms.append(float(reward.reward_terms(
                    x_now=moved, x_last=0.0, y_now=0.0, y_last=0.0, pitch=0.0, yaw=0.0, roll=0.0,
                    slope=0.0, fell=False, weights=weights, **tracking,
                )["forward"]))
                speeds.append(float(command.tracked_speed))
            earned[mean] = np.mean(terms[104:])  # 12 whole strides
            assert np.mean(speeds[104:]) == (pytest.approx(mean, abs=1e-3) if tau else 0.0)
        drops[tau] = earned[0.5] - earned[0.4]
        assert float(plan.restart(command, jnp.bool_(True)).tracked_speed) == 0.0
    ideal = 0.1 * 0.05  # the mean error's progress in a step (w1 = 1)
    assert drops[0.0] == pytest.approx(0.25 * ideal, rel=0.02)
    assert drops[0.25] > 0.5 * ideal
    with pytest.raises(ValueError, match="speed_tau needs commands.tracking='yaw_rate'"):
        commands.validate(_config(spec="random", tracking="heading", speed_tau=0.2))
    with pytest.raises(ValueError, match="commands.speed_tau must be finite and >= 0"):
        commands.validate(_config(spec="random", tracking="yaw_rate", speed_tau=-1.0))


# --- the reward -------------------------------------------------------------------------------


def numpy_eq8_13(x_now, x_last, y_now, y_last, pitch, yaw, roll, slope, fell, w):
    """Eqs. 8–13 written out in float64 (quadcos axes: forward = +x)."""
    alpha = float(fell)
    beta = 1.0 - alpha
    r_y = w.forward * (x_now - x_last)
    r_x = -w.lateral * abs(y_now - y_last)
    r_o = -w.pitch * abs(pitch - slope) - w.yaw * abs(yaw) - w.roll * abs(roll)
    return alpha * w.fall_penalty + beta * (w.survival + r_y + r_x + r_o)


def test_commanded_reward_at_zero_heading_is_eqs_8_to_13_exactly():
    rng = np.random.default_rng(0)
    weights = reward.RewardWeights()
    for _ in range(200):
        inputs = dict(
            x_now=rng.uniform(-5, 5), y_now=rng.uniform(-1, 1), pitch=rng.uniform(-0.5, 0.5),
            yaw=rng.uniform(-np.pi, np.pi),
            roll=rng.uniform(-0.5, 0.5),
            slope=rng.uniform(-0.2, 0.2),
        )
        inputs |= dict(x_last=inputs["x_now"] - rng.uniform(-0.1, 0.1))
        inputs |= dict(y_last=inputs["y_now"] - rng.uniform(-0.05, 0.05))
        inputs = {k: np.float32(v) for k, v in inputs.items()}
        fell = bool(rng.uniform() < 0.2)
        paper = reward.reward_terms(**inputs, fell=fell)
        commanded = reward.reward_terms(**inputs, fell=fell, heading=jnp.float32(0.0))
        for name in reward.TERM_NAMES:  # bit for bit
            assert np.asarray(commanded[name]).tobytes() == np.asarray(paper[name]).tobytes(), name
        expected = numpy_eq8_13(**{k: float(v) for k, v in inputs.items()}, fell=fell, w=weights)
        total = float(sum(commanded.values()))
        assert total == pytest.approx(expected, rel=1e-5, abs=1e-4)


def test_forward_tracking_against_numpy():
    rng = np.random.default_rng(1)
    for _ in range(100):
        heading, progress = rng.uniform(-3, 3), rng.uniform(-0.02, 0.08)
        commanded = rng.uniform(0, 0.05)
        lateral = rng.uniform(-0.01, 0.01)
        dx = progress * np.cos(heading) - lateral * np.sin(heading)
        dy = progress * np.sin(heading) + lateral * np.cos(heading)
        yaw = heading + rng.uniform(-0.3, 0.3)
        terms = reward.reward_terms(
            x_now=dx, x_last=0.0, y_now=dy, y_last=0.0, pitch=0.0, yaw=reward.wrap_angle(yaw),
            roll=0.0, slope=0.0, fell=False, heading=heading, commanded_progress=commanded,
        )
        expected = 150.0 * (progress if progress <= commanded else 2 * commanded - progress)
        assert float(terms["forward"]) == pytest.approx(expected, abs=2e-4)
        assert float(terms["lateral"]) == pytest.approx(-100.0 * abs(lateral), abs=2e-4)
        yaw_error = (yaw - heading + np.pi) % (2 * np.pi) - np.pi
        assert float(terms["orientation"]) == pytest.approx(-40.0 * abs(yaw_error), abs=2e-4)
        rate_error = rng.uniform(-1, 1)
        by_rate = reward.reward_terms(
            x_now=dx, x_last=0.0, y_now=dy, y_last=0.0, pitch=0.0, yaw=reward.wrap_angle(yaw),
            roll=0.0, slope=0.0, fell=False, heading=heading, commanded_progress=commanded,
            yaw_rate_error=rate_error,
        )
        assert float(by_rate["orientation"]) == pytest.approx(-40.0 * abs(rate_error), abs=2e-4)
        assert float(by_rate["forward"]) == float(terms["forward"])


# --- the turn extensions of Eq. 3 -------------------------------------------------------------


def _rhythm(n=64, seed=0):
    rng = np.random.default_rng(seed)
    return np.asarray(
        oscillator.rhythm_at_phase(
            rng.uniform(0, 2 * np.pi, n),
            rng.uniform(-0.5, 0.5, n),
            rng.uniform(-0.5, 0.5, n),
            rng.uniform(-2 * np.pi, 2 * np.pi, (n, 8)),
        )
    )


def test_zero_turn_is_eq3_exactly():
    rhythm = _rhythm()
    zero = np.zeros(len(rhythm), np.float32)
    same = oscillator.hip_amplitude_difference(rhythm, zero, 0.5)
    np.testing.assert_array_equal(same, rhythm)
    np.testing.assert_array_equal(oscillator.abduction_stride(rhythm, zero, 0.5), 0.0)


def test_turn_extensions_against_numpy():
    rhythm = _rhythm(seed=2)
    turn = np.random.default_rng(3).uniform(-1.5, 1.5, len(rhythm))
    bound = 0.4
    u = np.clip(turn, -1, 1)
    expected = rhythm.copy()
    for leg, side in ((0, -1), (1, +1), (2, -1), (3, +1)):  # LF, RF, LB, RB: right side +
        expected[:, 2 * leg] *= 1 + side * bound * u
    got = oscillator.hip_amplitude_difference(rhythm, turn, bound)
    np.testing.assert_allclose(got, expected, rtol=1e-6, atol=1e-7)
    lateral = np.stack(
        [bound * u * sign * rhythm[:, 2 * leg] for leg, sign in enumerate((1, 1, -1, -1))], -1
    )
    np.testing.assert_allclose(oscillator.abduction_stride(rhythm, turn, bound), lateral, atol=1e-7)


def test_the_feed_forward_is_a_differential_drive():
    velocity = np.float32([[0.6, 0.0], [0.6, 0.4], [0.0, 0.4], [0.0, 0.0], [2.0, -3.0]])
    linear = tuple(0.3 * scale for scale in commands.SPEED_MAP_SCALES)  # v_ref 0.3 m/s
    scales = np.asarray(commands.drive_scales(velocity, linear, 0.5, 1.5))
    expected = [[2.0, 2.0], [1.33333, 2.66667], [-0.66667, 0.66667], [0.0, 0.0], [8.0, 1.67]]
    np.testing.assert_allclose(scales, np.clip(expected, -1.5, 1.5), rtol=1e-4)
    rhythm = _rhythm(seed=4)
    np.testing.assert_array_equal(oscillator.side_scaled(rhythm, np.ones((len(rhythm), 2))), rhythm)
    sides = np.random.default_rng(5).uniform(-1.5, 1.5, (len(rhythm), 2))
    expected = rhythm.copy()
    for leg, side in ((0, 0), (1, 1), (2, 0), (3, 1)):  # LF, RF, LB, RB: left 0, right 1
        expected[:, 2 * leg] *= sides[:, side]
    got = oscillator.side_scaled(rhythm, sides)
    np.testing.assert_allclose(got, expected, rtol=1e-6, atol=1e-7)
    for row in range(3):
        np.testing.assert_allclose(
            twins.side_scaled(rhythm[row], sides[row]), expected[row], rtol=1e-6, atol=1e-7
        )
        np.testing.assert_allclose(
            twins.drive_scales(velocity[row], linear, 0.5, 1.5), scales[row], rtol=1e-5
        )
    with pytest.raises(ValueError, match="half_track"):
        quadcos.make_env("flat", **{"commands.half_track": float("inf")})


def test_the_drive_inverts_a_measured_speed_map():
    config = commands.default_config()
    config.speed_map = (0.3, 0.6, 0.8, 0.9)  # m/s at the scales 0.25, 0.5, 0.75, 1
    speeds = commands.speed_map(config)
    walked = np.float32([0.15, 0.3, 0.7, 0.9, 1.1, -0.6])
    velocity = np.stack([walked, np.zeros_like(walked)], axis=-1)
    scales = np.asarray(commands.drive_scales(velocity, speeds, 0.5, 1.5))
    # Between the knots linear, past the last at the map's mean 0.9 m/s per unit scale, odd.
    expected = [0.125, 0.25, 0.625, 1.0, 1.1 / 0.9, -0.5]
    np.testing.assert_allclose(scales, np.stack([expected, expected], axis=-1), rtol=1e-5)
    for row in range(len(walked)):
        np.testing.assert_allclose(
            twins.drive_scales(velocity[row], speeds, 0.5, 1.5), scales[row], rtol=1e-5
        )
    for bad in ((0.3, 0.6, 0.5, 0.9), (0.3, 0.6), ("fast",) * 4):
        config.speed_map = bad
        with pytest.raises(ValueError, match="speed_map"):
            commands.speed_map(config)
    with pytest.raises(ValueError, match="feed_forward"):
        quadcos.make_env("flat", controller="joint", **{"commands.feed_forward": True})


def test_the_turn_cap_limits_what_the_drive_asks_of_the_sides():
    linear = tuple(0.3 * scale for scale in commands.SPEED_MAP_SCALES)
    asked = np.float32([[0.6, 0.8], [0.6, -3.0], [0.0, 0.2], [0.5, 0.0]])
    within = np.float32([[0.6, 0.4], [0.6, -0.4], [0.0, 0.2], [0.5, 0.0]])
    capped = np.asarray(commands.drive_scales(asked, linear, 0.5, 1.5, turn_max=0.4))
    np.testing.assert_allclose(capped, commands.drive_scales(within, linear, 0.5, 1.5), rtol=1e-6)
    uncapped = np.asarray(commands.drive_scales(asked, linear, 0.5, 1.5))
    assert not np.allclose(uncapped[:2], capped[:2])  # 0: no cap
    for row in range(len(asked)):
        np.testing.assert_allclose(
            twins.drive_scales(asked[row], linear, 0.5, 1.5, 0.4), capped[row], rtol=1e-5
        )
    config = commands.default_config()
    config.speed_map, config.half_track, config.feed_forward = (0.3, 0.6, 0.8, 0.9), 0.5, True
    config.turn_max = 0.4
    mapping = commands.drive_map(config)
    np.testing.assert_allclose(
        commands.drive(config, asked, mapping), commands.drive(config, within, mapping), rtol=1e-6
    )
    with pytest.raises(ValueError, match="turn_max"):
        quadcos.make_env("flat", **{"commands.turn_max": -0.1})


# --- the env ----------------------------------------------------------------------------------

SCHEDULE = "0.5,0@0.1;1.0,0.3@5"


@pytest.fixture(scope="module")
def commanded_env():
    """quad12 (12 joints) with a schedule, its speed observed and the abduction turn: one
    compiled reset and step."""
    commanded = {"commands.spec": SCHEDULE, "commands.observed_speed_tau": 0.5}
    return quadcos.make_env("flat", robot="quad12", turn_mode="abduction_stride", **commanded)


def test_the_drive_s_state_is_observed_between_the_speed_and_the_command():
    config = quadcos.env.default_config()
    config.commands.update(spec="0.5,0.2@5", observe_drive=True, observed_speed_tau=0.3)
    plan = commands.Plan(commands.validate(config.commands), config.commands)
    drive = plan.start(jax.random.PRNGKey(0)).replace(
        speed=jnp.float32(0.4), gain=jnp.float32(1.2), correction=jnp.float32(-0.1),
        yaw_rate=jnp.float32(0.15),
    )
    obs = observation.with_command(config, jnp.zeros(3), {"velocity_command": drive})
    np.testing.assert_allclose(obs, [0, 0, 0, 0.4, 1.2, -0.1, 0.15, 0.5, 0.2])
    sizes = [quadcos.make_env("flat", **{"commands.spec": "random", "commands.observe_drive": on})
             .observation_size for on in (False, True)]
    assert sizes[1] == sizes[0] + 3


def test_sizes_grow_only_with_commands_and_turning(commanded_env):
    plain = quadcos.make_env("flat", robot="quad12")
    # the command, its observed speed, the turn's filtered action
    assert commanded_env.observation_size == plain.observation_size + 2 + 1 + 1
    assert commanded_env.action_size == plain.action_size + 1
    unfiltered = dict(robot="quad12", action_filter_tau=0.0)
    assert (
        quadcos.make_env("flat", **unfiltered, **{"commands.spec": "random"}).observation_size
        == quadcos.make_env("flat", **unfiltered).observation_size + 2
    )
    randomized = {**unfiltered, "randomization.enabled": True}  # reset draws physics too
    assert (
        quadcos.make_env("flat", **randomized, **{"commands.spec": "random"}).observation_size
        == quadcos.make_env("flat", **unfiltered).observation_size + 2
    )
    assert quadcos.make_env("flat", turn_mode="hip_amplitude_difference").action_size == 6
    with pytest.raises(ValueError, match="abduction joints"):
        quadcos.make_env("flat", turn_mode="abduction_stride")
    with pytest.raises(ValueError, match="segment 1"):
        quadcos.make_env("flat", **{"commands.spec": "fast"})
    with pytest.raises(ValueError, match="not trained with velocity commands"):
        plain.with_commands("random")
    with pytest.raises(ValueError, match="cannot run without them"):
        commanded_env.with_commands("")


def test_a_command_beyond_the_trained_ranges_is_followed_with_a_warning(commanded_env, caplog):
    limits = commanded_env.config.commands
    assert limits.speed_max > 0 and limits.yaw_rate_max > 0  # resolved from the robot
    inside = f"{limits.speed_max},{-limits.yaw_rate_max}@1;0,0@1"
    with caplog.at_level("WARNING", logger="quadcos.env.commands"):
        commanded_env.with_commands(inside)
        assert not caplog.records
        commanded_env.with_commands(f"{inside};0.2,{2 * limits.yaw_rate_max}@1")
    (record,) = caplog.records
    assert "segment 3" in record.getMessage() and "outside the ranges" in record.getMessage()
    # every foot moves to the left with a larger abduction angle on quad12: all signs +1
    np.testing.assert_array_equal(np.abs(commanded_env.layout.abduction_map).sum(0), 1.0)


def test_a_commanded_env_follows_its_schedule(commanded_env):
    env = commanded_env
    reset, step = jax.jit(jax.vmap(env.reset)), jax.jit(jax.vmap(env.step))
    state = reset(jax.random.split(jax.random.PRNGKey(0), 2))
    assert state.obs.shape == (2, env.observation_size)  # command and turn filter counted
    np.testing.assert_allclose(state.obs[:, -3:], [[0.0, 0.5, 0.0]] * 2)  # speed 0 at a reset
    action = jnp.zeros((2, env.action_size)).at[:, -1].set(0.5)
    yaws, headings = [], []
    for _ in range(3):
        last = np.asarray(state.obs[:, -3])
        x_before = np.asarray(state.pipeline_state.qpos[:, 0])
        state = step(state, action)
        yaws.append(np.asarray(state.obs[:, 4]))
        headings.append(np.asarray(state.info["velocity_command"].heading))
        assert np.isfinite(np.asarray(state.obs)).all() and np.isfinite(state.reward).all()
        # the observed speed: the step's progress (~ along x: the yaw stays small) low-passed
        moved = np.asarray(state.pipeline_state.qpos[:, 0]) - x_before
        expected = last + (1 - np.exp(-env.dt / 0.5)) * (moved / env.dt - last)
        np.testing.assert_allclose(state.obs[:, -3], expected, atol=2e-3)
    # t = 0.05: still 0.5 m/s; from t = 0.1 on, the second segment, observed for the next step
    np.testing.assert_allclose(state.obs[:, -2:], [[1.0, 0.3]] * 2)
    np.testing.assert_allclose(headings[1], 0.0, atol=1e-7)  # ω* = 0 in the first two steps
    # third step: ψ* = 0.3 rad/s × 0.05 s, within the leash of the robot's yaw
    np.testing.assert_allclose(headings[2], 0.015, rtol=1e-4)


def test_the_trainers_evaluation_tracks_commands_as_quadcos_evaluate_does(commanded_env):
    """`periodic_eval` and `quadcos.evaluation`'s rollout from the same keys (the same episodes)
    measure the same speed and yaw-rate tracking (both count with `quadcos.env.tracking`)."""
    env, n, steps = commanded_env, 2, 20  # two 0.5-s windows
    zeros = jnp.zeros(env.action_size)
    source = sources.ActionSource(
        name="zero action", kind="gait", act=lambda p, obs: jnp.broadcast_to(p, (len(obs), p.size)),
        params=zeros, env_overrides={}, training_terrain="flat",
    )
    expected = metrics.gait_aggregate(rollout.rollout(env, source, num_envs=n, num_steps=steps).stats)
    batched = training_wrappers.VmapWrapper(env)
    measured = jax.jit(
        lambda keys: periodic_eval.evaluate(
            batched, lambda obs: jnp.broadcast_to(zeros, (len(obs), zeros.size)), keys,
            episode_length=steps,
        )
    )(jax.random.split(jax.random.PRNGKey(0), n))
    assert expected["speed_tracking_rms"] > 0.05  # the schedule asks 0.5, then 1.0 m/s
    for key in ("speed_tracking_rms", "yaw_rate_tracking_rms"):
        assert float(measured[f"eval/{key}"]) == pytest.approx(expected[key], rel=1e-4)


# --- metrics ----------------------------------------------------------------------------------


@flax.struct.dataclass
class _Data:
    """What the gait statistics read of an mjx.Data."""

    qpos: jax.Array
    geom_xpos: jax.Array
    qfrc_actuator: jax.Array
    qvel: jax.Array


@pytest.mark.parametrize("terrain", ["flat", "slope5"])
def test_the_layouts_feet_are_the_foot_geoms_of_the_model_on_a_terrain(terrain):
    env = quadcos.make_env(terrain)
    model = env.mj_model
    for geom, radius, leg in zip(
        np.asarray(env.layout.foot_geoms), np.asarray(env.layout.foot_radius), "LF RF LB RB".split()
    ):
        assert model.geom(int(geom)).name == f"{leg}_foot"
        assert model.geom_size[geom][0] == pytest.approx(radius)


def test_gait_metrics_on_a_synthetic_trace():
    """Two robots, 0.1-s steps: robot 0 walks +x at 0.5 m/s (commanded 0.6) turning at 0.2 rad/s
    (commanded 0), one foot on the ground slipping 0.05 m/s; robot 1 falls at its first step."""
    dt, n = 0.1, 2
    layout = types.SimpleNamespace(
        foot_geoms=jnp.arange(4),
        foot_radius=jnp.full(4, 0.02),
        joint_qvel=jnp.arange(2),
        torque_limit=jnp.array([10.0, 20.0]),
        mass=4.0,
    )
    env = types.SimpleNamespace(
        dt=dt, layout=layout, commanded=True,
        terrain=types.SimpleNamespace(height_at=lambda x, y: 0.0 * x),
    )
    command = jnp.array([[0.6, 0.0], [0.6, 0.0]])

    def state(step):
        yaw = 0.2 * dt * step
        qpos = jnp.zeros((n, 7)).at[:, 0].set(0.5 * dt * step)
        qpos = qpos.at[:, 3].set(np.cos(yaw / 2)).at[:, 6].set(np.sin(yaw / 2))
        feet = jnp.full((n, 4, 3), 0.5).at[:, 0].set(jnp.array([0.05 * dt * step, 0.0, 0.02]))
        data = _Data(
            qpos=qpos,
            geom_xpos=feet,
            qfrc_actuator=jnp.array([[2.0, -4.0]] * n),
            qvel=jnp.array([[1.0, 1.0]] * n),
        )
        info = {"velocity_command": types.SimpleNamespace(velocity=command)}
        return types.SimpleNamespace(pipeline_state=data, info=info, reward=jnp.ones(n))

    first = state(0)
    base = rollout.EpisodeStats(
        running=jnp.ones(n, bool), lane=jnp.zeros(n, jnp.int32), fell=jnp.zeros(n, bool),
        finished=jnp.zeros(n, bool), steps=jnp.zeros(n, jnp.int32), start_x=jnp.zeros(n),
        start_y=jnp.zeros(n), x=jnp.zeros(n), y=jnp.zeros(n), **{
            name: jnp.zeros(n) for name in (
                "max_lateral_deviation", "max_abs_roll", "max_abs_yaw", "max_abs_pitch_error",
                "slope_sq_error", "episode_reward",
            )
        }, reward_terms={},
    )
    gait = rollout._initial_gait_stats(env, first, base)
    for step in range(1, 11):  # two tracking windows of 5 steps
        counts = jnp.array([True, step == 1])
        new = state(step)
        stats = base.replace(
            steps=gait.steps + counts, x=jnp.where(counts, new.pipeline_state.qpos[:, 0], gait.x)
        )
        gait = rollout._update_gait_stats(env, gait, stats, new, counts)
        base = stats
    host = jax.device_get(gait)
    values = [metrics.gait_values(host, i) for i in range(n)]
    # speed along the heading: 0.05 m per step at a yaw of 0.02·k rad: 0.5·cos(0.02 k) m/s,
    # averaged over each window of 5 steps (0.5 s)
    speeds = (0.5 * np.cos(0.02 * np.arange(1, 11))).reshape(2, 5).mean(-1)
    rms = np.sqrt(np.mean((speeds - 0.6) ** 2))
    assert int(host.tracking.windows[0]) == 2 and int(host.tracking.windows[1]) == 0
    assert values[0]["speed_tracking_rms"] == pytest.approx(rms, rel=1e-4)
    assert values[0]["yaw_rate_tracking_rms"] == pytest.approx(0.2, rel=1e-3)
    assert values[1]["speed_tracking_rms"] is None  # it fell before a window closed
    assert values[0]["foot_slip_m_per_s"] == pytest.approx(0.05, rel=1e-4)
    # |τ·q̇| = 6 W for 1 s over 0.5 m: 6 J / (4 kg · 9.81 · 0.5 m)
    assert values[0]["cost_of_transport"] == pytest.approx(6.0 / (4.0 * 9.81 * 0.5), rel=1e-4)
    assert values[0]["peak_joint_torque_ratio"] == pytest.approx(0.2)
    assert int(host.steps[1]) == 1 and float(host.energy[1]) == pytest.approx(0.6)
    pooled = metrics.gait_aggregate(host)
    assert pooled["speed_tracking_rms"] == pytest.approx(rms, rel=1e-4)  # robot 0's windows
    # The trainer's evaluation pools the same sums in JAX (quadcos.env.tracking.pooled_rms).
    speed_rms, yaw_rate_rms = tracking.pooled_rms(gait.tracking)
    assert float(speed_rms) == pytest.approx(pooled["speed_tracking_rms"], rel=1e-5)
    assert float(yaw_rate_rms) == pytest.approx(pooled["yaw_rate_tracking_rms"], rel=1e-5)
    assert pooled["cost_of_transport"] == pytest.approx(6.6 / (4.0 * 9.81 * 0.55), rel=1e-4)
    assert pooled["peak_joint_torque_ratio"] == pytest.approx(0.2)
    # A fall's energy is left out of the pooled cost of transport (robot 1 fell, blown up).
    blown_up = host.replace(fell=np.array([False, True]), energy=np.array([host.energy[0], 1e9]))
    assert metrics.gait_aggregate(blown_up)["cost_of_transport"] == pytest.approx(
        values[0]["cost_of_transport"], rel=1e-4
    )
    uncommanded = metrics.gait_values(host.replace(commanded=False), 0)
    assert uncommanded["speed_tracking_rms"] is None


def test_command_tracking_figure_has_a_column_per_robot_and_needs_commands():
    from quadcos.viz import plots

    time = np.arange(40) * 0.05
    series = {
        "time": time.tolist(),
        "forward_speed": np.full(40, 0.5).tolist(),
        "yaw": (0.2 * time).tolist(),
        "speed_command": np.full(40, 0.5).tolist(),
        "yaw_rate_command": np.full(40, 0.2).tolist(),
    }
    trace = {"series": series, "success": True, "fell": False, "finished_course": False}
    figure = plots.plot_command_tracking({"a": trace, "b": trace})
    assert len(figure.axes) == 4
    achieved_yaw_rate = figure.axes[2].lines[0].get_ydata()  # row 2, column 1
    np.testing.assert_allclose(achieved_yaw_rate, 0.2, atol=1e-9)
    without = {"series": {k: v for k, v in series.items() if "command" not in k}}
    with pytest.raises(ValueError, match="no velocity command"):
        plots.plot_command_tracking({"plain": without})
