"""The rhythm controller against an independent NumPy reading of the paper's Eqs. 1–3."""

import jax
import numpy as np
import pytest

from quadcos.equations import oscillator


def numpy_eq3(t, amplitude_hip, amplitude_knee, period, phases):
    """Eq. 3 written out joint by joint: even indices hips (full wave), odd knees (half wave)."""
    out = np.empty(8)
    for i in range(8):
        if i % 2 == 0:
            out[i] = amplitude_hip * np.cos(2 * np.pi * t / period + phases[i])
        else:
            y = amplitude_knee * np.cos(2 * np.pi * t / period + phases[i])
            out[i] = y if y >= 0 else 0.0
    return out


def test_matches_numpy_eq3_at_random_inputs():
    rng = np.random.default_rng(0)
    n = 256
    t = rng.uniform(0, 10, n)
    amplitude_hip = rng.uniform(-2, 2, n)
    amplitude_knee = rng.uniform(-2, 2, n)
    period = rng.uniform(0.1, 2, n)
    phases = rng.uniform(-2 * np.pi, 2 * np.pi, (n, 8))
    got = np.asarray(
        jax.jit(oscillator.cosine_rhythm)(t, amplitude_hip, amplitude_knee, period, phases)
    )
    want = np.stack(
        [numpy_eq3(*args) for args in zip(t, amplitude_hip, amplitude_knee, period, phases)]
    )
    # float32: 2πt/T reaches ~600 rad, so the argument carries ~4e-5 rad of rounding.
    np.testing.assert_allclose(got, want, atol=2e-4)


def test_figure4_single_leg_example():
    """Fig. 4: A_h=1.5, A_k=1, T=2, φ0=0, φ1=π/2: stance 0..1 s hip 1.5→−1.5, knee still;
    swing 1..2 s hip −1.5→1.5, knee 0→1→0."""
    phases = np.array([0, np.pi / 2] * 4)
    t = np.linspace(0, 2, 201)
    out = np.asarray(oscillator.cosine_rhythm(t, 1.5, 1.0, 2.0, np.broadcast_to(phases, (201, 8))))
    hip, knee = out[:, 0], out[:, 1]
    np.testing.assert_allclose(hip[[0, 100, 200]], [1.5, -1.5, 1.5], atol=1e-5)
    assert np.all(np.diff(hip[:101]) <= 1e-6)  # stance: hip sweeps back monotonically
    np.testing.assert_allclose(knee[:101], 0.0, atol=1e-6)  # stance: knee does not move
    np.testing.assert_allclose(knee[150], 1.0, atol=1e-5)  # mid-swing: knee fully bent
    assert np.all(knee >= 0)


def test_trot_table():
    phases = np.asarray(oscillator.trot_phases(0.3, -1.1))
    np.testing.assert_allclose(phases, [0, 0.3, np.pi, -1.1, np.pi, -1.1, 0, 0.3], atol=1e-6)
    batched = oscillator.trot_phases(np.zeros((3, 2)), np.ones((3, 2)))
    assert batched.shape == (3, 2, 8)


def test_trot_gait_table_equals_trot_phases():
    np.testing.assert_allclose(
        oscillator.gait_phases("trot"),
        np.mod(oscillator.trot_phases(np.pi / 2, 3 * np.pi / 2), 2 * np.pi),
        atol=1e-5,
    )


@pytest.mark.parametrize(
    "gait, in_phase, anti_phase",
    [
        ("pace", [(0, 2), (1, 3)], [(0, 1)]),
        ("bound", [(0, 1), (2, 3)], [(0, 2)]),
        ("pronk", [(0, 1), (2, 3), (0, 3)], []),
    ],
)
def test_other_gait_tables(gait, in_phase, anti_phase):
    hips = np.asarray(oscillator.gait_phases(gait))[0::2]
    for a, b in in_phase:
        assert np.isclose(np.mod(hips[a] - hips[b], 2 * np.pi), 0, atol=1e-6)
    for a, b in anti_phase:
        assert np.isclose(np.mod(hips[a] - hips[b], 2 * np.pi), np.pi, atol=1e-6)


def test_walk_is_four_beat():
    hips = np.sort(np.mod(np.asarray(oscillator.gait_phases("walk"))[0::2], 2 * np.pi))
    np.testing.assert_allclose(np.diff(hips), np.pi / 2, atol=1e-6)


def test_unknown_gait_is_named():
    with pytest.raises(ValueError, match="unknown gait 'gallop'"):
        oscillator.gait_phases("gallop")


def test_action_bounds():
    corners = np.array([[-1.0] * 5, [1.0] * 5, [5.0] * 5, [-5.0] * 5])
    params = oscillator.action_to_parameters(corners)
    np.testing.assert_allclose(params.amplitude_knee, [-0.5, 0.5, 0.5, -0.5])
    np.testing.assert_allclose(params.amplitude_hip, [-0.5, 0.5, 0.5, -0.5])
    np.testing.assert_allclose(
        params.period, [oscillator.PERIOD_MIN, 2.0, 2.0, oscillator.PERIOD_MIN], rtol=1e-6
    )
    np.testing.assert_allclose(
        params.phi1, [-2 * np.pi, 2 * np.pi, 2 * np.pi, -2 * np.pi], rtol=1e-6
    )
    assert float(params.period.min()) > 0


def test_action_round_trip():
    action = np.random.default_rng(1).uniform(-1, 1, (16, 5))
    back = oscillator.parameters_to_action(oscillator.action_to_parameters(action))
    np.testing.assert_allclose(back, action, atol=1e-5)


def test_phase_form_equals_literal_form_while_period_is_constant():
    period, dt = 0.6, 0.004
    phase, phases = 0.0, oscillator.trot_phases(0.7, -0.4)
    for step in range(1, 400):
        phase = oscillator.advance_phase(phase, period, dt)
        literal = oscillator.cosine_rhythm(step * dt, 0.3, 0.4, period, phases)
        continuous = oscillator.rhythm_at_phase(phase, 0.3, 0.4, phases)
    np.testing.assert_allclose(continuous, literal, atol=1e-4)


def test_phase_form_is_continuous_when_period_changes():
    phases = oscillator.trot_phases(np.pi / 2, -np.pi / 2)
    t, dt = 1.3, 0.004
    jump = oscillator.cosine_rhythm(t, 0.5, 0.5, 1.5, phases) - oscillator.cosine_rhythm(
        t, 0.5, 0.5, 0.5, phases
    )
    phase = 2 * np.pi * t / 1.5
    step = oscillator.rhythm_at_phase(
        oscillator.advance_phase(phase, 0.5, dt), 0.5, 0.5, phases
    ) - oscillator.rhythm_at_phase(phase, 0.5, 0.5, phases)
    assert float(np.abs(jump).max()) > 0.2  # the literal form jumps
    assert float(np.abs(step).max()) < 0.05  # the integrated one does not


def test_centred_action_map_keeps_the_bounds():
    centre = oscillator.FIXED_TROT
    lower, upper = oscillator.parameter_bounds()
    np.testing.assert_allclose(
        oscillator.action_to_parameters(np.zeros(5), centre=centre), centre, atol=1e-6
    )
    np.testing.assert_allclose(
        oscillator.action_to_parameters(-np.ones(5), centre=centre), lower, rtol=1e-6
    )
    np.testing.assert_allclose(
        oscillator.action_to_parameters(np.ones(5), centre=centre), upper, rtol=1e-6
    )
    action = np.random.default_rng(2).uniform(-1, 1, (32, 5))
    back = oscillator.parameters_to_action(
        oscillator.action_to_parameters(action, centre=centre), centre=centre
    )
    np.testing.assert_allclose(back, action, atol=1e-5)


def test_scaled_action_map_reaches_its_share_of_each_span():
    centre = oscillator.FIXED_TROT
    lower, upper = oscillator.parameter_bounds()
    top = oscillator.action_to_parameters(np.ones(5), centre=centre, scale=0.3)
    bottom = oscillator.action_to_parameters(-np.ones(5), centre=centre, scale=0.3)
    np.testing.assert_allclose(top, np.add(centre, 0.3 * np.subtract(upper, centre)), rtol=1e-5)
    np.testing.assert_allclose(bottom, np.add(centre, 0.3 * np.subtract(lower, centre)), rtol=1e-5)
    action = np.random.default_rng(3).uniform(-1, 1, (32, 5))
    params = oscillator.action_to_parameters(action, centre=centre, scale=0.3)
    back = oscillator.parameters_to_action(params, centre=centre, scale=0.3)
    np.testing.assert_allclose(back, action, atol=1e-5)
    # The bounds themselves are out of reach: their action lies beyond ±1.
    assert float(np.abs(oscillator.parameters_to_action(upper, centre=centre, scale=0.3)).min()) > 3


def test_centre_on_a_bound_is_refused():
    with pytest.raises(ValueError, match="strictly inside"):
        oscillator.action_to_parameters(
            np.zeros(5), centre=oscillator.RhythmParameters(0.5, 0.1, 1.0, 0.0, 0.0)
        )


def test_posture_offsets_move_the_front_and_hind_hips_only():
    offsets = oscillator.posture_offsets(np.array([0.5, -1.5]), 0.6)  # -1.5 is clipped to -1
    np.testing.assert_allclose(offsets, [0.3, 0, 0.3, 0, -0.6, 0, -0.6, 0], atol=1e-6)
    batch = oscillator.posture_offsets(np.ones((3, 2)), 0.2)
    assert batch.shape == (3, 8)
    np.testing.assert_allclose(batch[:, 0::2], 0.2, atol=1e-7)  # every hip
    np.testing.assert_allclose(batch[:, 1::2], 0.0)  # no knee
