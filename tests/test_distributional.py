"""The distributional critics (`config.critic_atoms`, quadcos.training.distributional): C51's
projection, the twin Q as the distributions' means, a loss that fits a known return, a trainer
that learns the toy task with them, and settings that cannot make a support refused."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest
from brax.training import types

from quadcos import training
from quadcos.training import distributional, networks
from tests.test_training import LEARNED_RETURN
from tests.toy_env import CHUNK, PointEnv, toy_config

SUPPORT = distributional.Support(atoms=11, v_min=-5.0, v_max=5.0)


def _probs(key: int, batch: int = 64) -> jax.Array:
    return jax.nn.softmax(3.0 * jax.random.normal(jax.random.PRNGKey(key), (batch, 11)))


def test_the_projection_keeps_the_mass_and_the_moved_mean_and_clips_at_the_ends():
    probs = _probs(0)
    z = SUPPORT.values
    reward = jax.random.uniform(jax.random.PRNGKey(1), (64,), minval=-1.0, maxval=1.0)
    discount = jax.random.uniform(jax.random.PRNGKey(2), (64,), minval=0.0, maxval=0.8)
    projected = distributional.project(probs, reward, discount, SUPPORT)
    np.testing.assert_allclose(projected.sum(-1), 1.0, rtol=1e-5)
    assert float(projected.min()) >= 0.0
    # |r| <= 1 and |discount · z| <= 4: no moved atom leaves [-5, 5], so the mean moves exactly
    np.testing.assert_allclose(projected @ z, reward + discount * (probs @ z), atol=1e-5)
    # a done transition (discount 0) is its reward, between the two atoms beside it
    done = distributional.project(probs[:1], jnp.array([0.25]), jnp.zeros(1), SUPPORT)
    np.testing.assert_allclose(done[0, 5:7], [0.75, 0.25], atol=1e-6)
    # beyond the support every atom lands on its end
    far = distributional.project(probs, jnp.full(64, 100.0), jnp.ones(64), SUPPORT)
    np.testing.assert_allclose(far[:, -1], 1.0, rtol=1e-5)
    # below it, on the first; a moved atom on an atom keeps its probability there
    low = distributional.project(probs, jnp.full(64, -100.0), jnp.ones(64), SUPPORT)
    np.testing.assert_allclose(low[:, 0], 1.0, rtol=1e-5)
    on_atoms = distributional.project(probs, jnp.ones(64), jnp.ones(64), SUPPORT)
    np.testing.assert_allclose(on_atoms[:, 1:-1], probs[:, :-2], atol=1e-6)
    # a spacing that float32 does not hold exactly loses no mass at the ends
    inexact = distributional.Support(atoms=51, v_min=-60.0, v_max=10.0)
    uniform = jnp.full((64, 51), 1 / 51)
    ends = distributional.project(uniform, jnp.full(64, 1e3), jnp.ones(64), inexact)
    np.testing.assert_allclose(ends.sum(-1), 1.0, rtol=1e-6)


def test_the_twin_q_is_the_two_distributions_means():
    critics = distributional.make_critics(
        3, 2, types.identity_observation_preprocessor, (16,), True, SUPPORT
    )
    params = critics.q_network.init(jax.random.PRNGKey(0))
    obs, action = jnp.ones((5, 3)), jnp.zeros((5, 2))
    logits = critics.logits(None, params, obs, action)
    q = critics.q_network.apply(None, params, obs, action)
    assert logits.shape == (5, 2, 11) and q.shape == (5, 2)
    np.testing.assert_allclose(q, jax.nn.softmax(logits) @ SUPPORT.values, rtol=1e-5)
    assert not np.allclose(q[:, 0], q[:, 1])  # two critics, initialised apart


def test_the_loss_fits_the_critics_mean_to_a_done_transitions_scaled_reward():
    """Transitions that end (discount 0) have the scaled reward as their whole return: a few
    hundred updates of the cross-entropy bring both critics' means there, each state its own."""
    config = toy_config(
        critic_atoms=11, critic_value_range=(-5.0, 5.0), normalize_observations=False
    )
    sac_networks = networks.make_networks(2, 1, (8,), (16,), False)
    critics = networks.make_critics(2, 1, config)
    loss = distributional.CriticLoss(sac_networks, critics, 2.0, config.discount)
    observation = jnp.linspace(-1.0, 1.0, 32)[:, None] * jnp.ones((32, 2))
    transitions = types.Transition(
        observation=observation,
        action=jnp.zeros((32, 1)),
        reward=observation[:, 0],  # scaled: -2 ... 2
        discount=jnp.zeros(32),
        next_observation=observation,
        extras={"state_extras": {"truncation": jnp.zeros(32)}, "policy_extras": {}},
    )
    policy_params = sac_networks.policy_network.init(jax.random.PRNGKey(1))
    q_params = critics.q_network.init(jax.random.PRNGKey(2))
    optimizer = optax.adam(3e-3)

    @jax.jit
    def update(q_params, opt_state, key):
        (value, _), grad = jax.value_and_grad(loss, has_aux=True)(
            q_params, policy_params, None, q_params, 0.5, transitions, key
        )
        change, opt_state = optimizer.update(grad, opt_state)
        return optax.apply_updates(q_params, change), opt_state, value

    opt_state, first = optimizer.init(q_params), None
    for step in range(400):
        q_params, opt_state, value = update(q_params, opt_state, jax.random.PRNGKey(step))
        first = value if first is None else first
    q = critics.q_network.apply(None, q_params, observation, transitions.action)
    assert float(value) < 0.5 * float(first)
    np.testing.assert_allclose(q, 2.0 * np.tile(observation[:, :1], (1, 2)), atol=0.15)


def test_the_targets_mean_is_brax_soft_bellman_target_and_truncation_counts_nothing():
    """On a support wide enough that nothing clips, the projected target's mean is Brax's scalar
    target r·scale + γ·d·(min_k Q_k(s', a') − α log π(a' | s')) with the same a': the reward's
    scale, γ, the entropy term's sign and the lower critic all as Brax has them."""
    config = toy_config(critic_atoms=101, critic_value_range=(-400.0, 400.0))
    trainer = training.SACTrainer(PointEnv(), config)
    state = trainer.prefill(trainer.init())
    batch = trainer.replay.sample(state.replay, jax.random.PRNGKey(0), 128)
    batch = batch._replace(discount=batch.discount.at[:40].set(0.0))  # some ended
    loss = trainer._sgd_step.critic_loss  # noqa: SLF001
    assert isinstance(loss, distributional.CriticLoss)
    alpha, key = 0.37, jax.random.PRNGKey(5)
    args = (state.policy_params, state.normalizer_params, state.target_q_params, alpha, batch, key)
    target, clipped = loss.target(*args)
    assert not clipped.any()  # ±400 holds every moved atom
    # Brax's target, its next action drawn with the same key
    networks, dist = trainer.networks, trainer.networks.parametric_action_distribution
    next_params = networks.policy_network.apply(
        state.normalizer_params, state.policy_params, batch.next_observation
    )
    raw = dist.sample_no_postprocessing(next_params, key)
    next_q = networks.q_network.apply(
        state.normalizer_params,
        state.target_q_params,
        batch.next_observation,
        dist.postprocess(raw),
    )
    next_v = jnp.min(next_q, axis=-1) - alpha * dist.log_prob(next_params, raw)
    brax = batch.reward * config.reward_scaling + batch.discount * config.discount * next_v
    np.testing.assert_allclose(target @ loss.critics.support.values, brax, rtol=1e-4, atol=1e-3)
    # a truncated transition adds nothing to the loss
    full, metrics = loss(state.q_params, *args[:3], alpha, batch, key)
    assert float(metrics["critic_target_clipped"]) == 0.0
    # on a support too narrow for these returns the metric says how much of the target clipped
    narrow = dataclasses.replace(loss.critics, support=distributional.Support(101, -0.1, 0.1))
    narrow_loss = dataclasses.replace(loss, critics=narrow)
    _, narrow_metrics = narrow_loss(state.q_params, *args[:3], alpha, batch, key)
    assert 0.5 < float(narrow_metrics["critic_target_clipped"]) <= 1.0
    truncated = batch.extras["state_extras"]["truncation"].at[:64].set(1.0)
    extras = {**batch.extras, "state_extras": {"truncation": truncated}}
    half, _ = loss(state.q_params, *args[:3], alpha, batch._replace(extras=extras), key)
    first_half = batch.extras["state_extras"]["truncation"].at[64:].set(1.0)
    other = {**batch.extras, "state_extras": {"truncation": first_half}}
    rest, _ = loss(state.q_params, *args[:3], alpha, batch._replace(extras=other), key)
    np.testing.assert_allclose(half + rest, full, rtol=1e-5)
    assert 0 < float(half) < float(full)


def test_a_trainer_with_distributional_critics_learns_the_toy_task():
    config = toy_config(
        num_timesteps=CHUNK + 10 * CHUNK,
        eval_interval=10 * CHUNK,
        critic_atoms=51,
        critic_value_range=(-60.0, 10.0),  # the toy's scaled returns: -5 · |x - 0.5| / (1 - 0.9)
    )
    result = training.train(PointEnv(), config, None, progress=False)
    assert result.metrics["eval/episode_reward"] > LEARNED_RETURN
    assert 0.0 <= result.metrics["train/critic_target_clipped"] < 0.01  # the range holds them
    assert result.state.q_params["params"]["MLP_0"]["hidden_2"]["bias"].shape == (51,)


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"critic_atoms": 1}, "critic_atoms must be 0 .off. or >= 2, got 1"),
        ({"critic_atoms": 51, "critic_value_range": (10.0, -10.0)}, "v_min < v_max, got .10.0"),
    ],
)
def test_a_support_that_cannot_be_made_is_refused(overrides, message):
    with pytest.raises(ValueError, match=message):
        training.train(PointEnv(), toy_config(**overrides), None, progress=False)
