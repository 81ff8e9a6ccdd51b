"""Eqs. 8–13 against the paper's numbers, in quadcos axes (forward = +x)."""

import jax
import numpy as np
import pytest

from quadcos.equations import reward

WALK = dict(
    x_now=1.01, x_last=1.0, y_now=0.002, y_last=0.0, pitch=0.1, yaw=-0.05, roll=0.02, slope=0.08
)


def test_paper_defaults():
    # the paper's seven, then the action-rate weight beyond it, off
    assert reward.RewardWeights() == (-100.0, 10.0, 150.0, 100.0, 30.0, 40.0, 30.0, 0.0)


def test_walking_step_is_eq13_with_beta_one():
    terms = reward.reward_terms(**WALK, fell=False)
    expected = 10 + 150 * 0.01 - 100 * 0.002 - (30 * 0.02 + 40 * 0.05 + 30 * 0.02)
    assert set(terms) == {"fall", "survival", "forward", "lateral", "orientation", "action_rate"}
    assert float(terms["action_rate"]) == 0.0
    np.testing.assert_allclose(float(sum(terms.values())), expected, rtol=1e-5)
    assert float(terms["fall"]) == 0.0


def test_a_fall_gives_only_the_penalty():
    terms = reward.reward_terms(**WALK, fell=True)
    assert float(sum(terms.values())) == -100.0
    assert float(terms["survival"]) == 0.0 and float(terms["forward"]) == 0.0


def test_term_signs():
    terms = reward.reward_terms(**WALK, fell=False)
    assert terms["survival"] > 0 and terms["forward"] > 0
    assert terms["lateral"] < 0 and terms["orientation"] < 0
    backwards = reward.reward_terms(**{**WALK, "x_now": 0.99}, fell=False)
    assert backwards["forward"] < 0


def test_pitch_is_rewarded_for_following_the_slope():
    on_slope = reward.reward_terms(**{**WALK, "pitch": 0.087, "slope": 0.087}, fell=False)
    level = reward.reward_terms(**{**WALK, "pitch": 0.0, "slope": 0.087}, fell=False)
    assert on_slope["orientation"] > level["orientation"]


def test_xy_variant_keeps_only_progress_terms():
    terms = reward.reward_terms(**WALK, fell=False, variant="xy")
    np.testing.assert_allclose(float(sum(terms.values())), 150 * 0.01 - 100 * 0.002, rtol=1e-5)
    assert float(reward.reward_terms(**WALK, fell=True, variant="xy")["fall"]) == -100.0


def test_batched_under_vmap():
    batch = {k: np.full(7, v) for k, v in WALK.items()}
    terms = jax.vmap(lambda b, f: reward.reward_terms(**b, fell=f))(
        batch, np.array([0, 1, 0, 0, 1, 0, 0])
    )
    total = sum(terms.values())
    assert total.shape == (7,)
    assert float(total[1]) == -100.0


def test_unknown_variant():
    with pytest.raises(ValueError, match="unknown reward variant 'yx'"):
        reward.reward_terms(**WALK, fell=False, variant="yx")


def test_survival_only_for_steps_of_movement():
    """Eq. 9 read as "for every step of movement": a step that does not move pays no r_s."""
    moving = reward.reward_terms(**WALK, fell=False, moving=True)
    still = reward.reward_terms(**WALK, fell=False, moving=False)
    assert float(moving["survival"]) == 10.0 and float(still["survival"]) == 0.0
    assert float(still["forward"]) == float(moving["forward"])
    fallen = reward.reward_terms(**WALK, fell=True, moving=True)
    assert float(fallen["survival"]) == 0.0


def test_term_names_are_the_keys_of_reward_terms_in_order():
    assert tuple(reward.reward_terms(**WALK, fell=False)) == reward.TERM_NAMES


def test_progress_beyond_the_cap_earns_nothing_more():
    # WALK moves 0.01 m in the step; a cap of 0.004 m pays for 0.004 m, slower steps in full.
    capped = reward.reward_terms(**WALK, fell=False, max_progress=0.004)
    assert float(capped["forward"]) == pytest.approx(150 * 0.004)
    slow = reward.reward_terms(**{**WALK, "x_now": 1.002}, fell=False, max_progress=0.004)
    assert float(slow["forward"]) == pytest.approx(150 * 0.002)
    back = reward.reward_terms(**{**WALK, "x_now": 0.99}, fell=False, max_progress=0.004)
    assert float(back["forward"]) == pytest.approx(-150 * 0.01)
    uncapped = reward.reward_terms(**WALK, fell=False)
    assert float(uncapped["forward"]) == pytest.approx(150 * 0.01)


def test_action_rate_charges_the_commands_squared_change_while_walking():
    change = np.array([0.1, -0.2, 0.0, 0.3, 0.0])  # 0.01 + 0.04 + 0.09 = 0.14
    weights = reward.RewardWeights(action_rate=10.0)
    terms = reward.reward_terms(**WALK, fell=False, weights=weights, action_change=change)
    assert float(terms["action_rate"]) == pytest.approx(-1.4)
    plain = reward.reward_terms(**WALK, fell=False, weights=weights)
    assert float(plain["action_rate"]) == 0.0  # no change given: nothing charged
    for name in reward.TERM_NAMES[:-1]:  # the paper's terms untouched
        assert float(terms[name]) == float(plain[name])
    fallen = reward.reward_terms(**WALK, fell=True, weights=weights, action_change=change)
    assert float(fallen["action_rate"]) == 0.0  # a fall pays r_p alone
    unweighted = reward.reward_terms(**WALK, fell=False, action_change=change)
    assert float(unweighted["action_rate"]) == 0.0  # the paper's weights: off
