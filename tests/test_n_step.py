"""n-step returns (quadcos.training.n_step): the window stops where its episode does, at a
non-finite step and before a truncated one; the first n − 1 steps of a run store nothing; a
trainer with n_step 3 learns the toy task and stores every later step."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from brax.training import types

from quadcos import training
from quadcos.training import n_step
from tests.test_training import LEARNED_RETURN
from tests.toy_env import CHUNK, PointEnv, toy_config

GAMMA = 0.5


def _steps(reward, done, truncated, finite):
    """n consecutive vectorised steps of 6 envs ((n, 6) each); env e's observation after step k
    is 10·k + e, so the next observation names the step a window bootstraps from."""
    n, envs = np.shape(reward)
    next_obs = (10.0 * np.arange(n)[:, None] + np.arange(envs))[..., None]
    window = types.Transition(
        observation=jnp.asarray(next_obs - 10.0),
        action=jnp.zeros((n, envs, 1)),
        reward=jnp.asarray(reward, jnp.float32),
        discount=1.0 - jnp.asarray(done, jnp.float32),
        next_observation=jnp.asarray(next_obs),
        extras={"state_extras": {"truncation": jnp.asarray(truncated, jnp.float32)}},
    )
    return window, jnp.asarray(finite)


def test_the_window_stops_at_the_end_of_its_episode_a_nan_and_a_truncation():
    # envs: 0 walks on; 1 falls at step 0; 2 falls at step 1; 3 is truncated at step 1; 4's step
    # 2 is not finite; 5 is truncated at step 0 (Brax masks that transition: it stays so).
    reward = [[1.0, 1.0, 1.0, 1.0, 1.0, 1.0], [2.0] * 6, [4.0, 4.0, 4.0, 4.0, np.nan, 4.0]]
    done = [[0, 1, 0, 0, 0, 1], [0, 0, 1, 1, 0, 0], [0, 0, 0, 0, 0, 0]]
    truncated = [[0, 0, 0, 0, 0, 1], [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 0, 0]]
    finite = [[True] * 6, [True] * 6, [True, True, True, True, False, True]]
    out = n_step.returns(*_steps(reward, done, truncated, finite), GAMMA)
    np.testing.assert_allclose(out.reward, [1 + 1 + 1, 1, 1 + 1, 1, 1 + 1, 1])  # r_k · γ^k
    np.testing.assert_allclose(out.discount, [GAMMA**2, 0, 0, 1, GAMMA, 0])
    # bootstraps from: env 0 after step 2, 1 and 5 after step 0 (unused), 2 and 4 after step 1,
    # 3 from the state before its truncated step
    np.testing.assert_allclose(out.next_observation[:, 0], [20, 1, 12, 3, 14, 5])
    np.testing.assert_allclose(out.observation[:, 0], np.arange(6) - 10.0)
    np.testing.assert_allclose(out.extras["state_extras"]["truncation"], [0, 0, 0, 0, 0, 1])


def test_one_step_is_brax_transition_and_the_queue_stores_nothing_until_full():
    window, finite = _steps([[3.0] * 6], [[0, 1, 0, 0, 0, 0]], [[0] * 6], [[True] * 6])
    first = jax.tree.map(lambda x: x[0], window)
    jax.tree.map(np.testing.assert_array_equal, n_step.returns(window, finite, GAMMA), first)
    step, _ = _steps([[1.0] * 6], [[0] * 6], [[0] * 6], [[True] * 6])
    one = jax.tree.map(lambda x: x[0], step)
    queue = n_step.empty_queue(one, 3)
    stored = []
    for _ in range(4):
        queue, (transitions, valid) = n_step.push(queue, one, jnp.ones(6, bool), GAMMA)
        stored.append(bool(valid.any()))
        assert transitions.reward.shape == (6,)
    assert stored == [False, False, True, True]
    np.testing.assert_allclose(transitions.reward, 1 + GAMMA + GAMMA**2)


def test_a_trainer_with_three_step_returns_learns_the_toy_task():
    config = toy_config(num_timesteps=CHUNK + 10 * CHUNK, eval_interval=10 * CHUNK, n_step=3)
    result = training.train(PointEnv(), config, None, progress=False)
    assert result.metrics["eval/episode_reward"] > LEARNED_RETURN
    # every step stored but the run's first two (the queue filling), none lost at chunk ends
    assert int(result.state.replay.size) == result.env_steps - 2 * config.num_envs
    with pytest.raises(ValueError, match="n_step must be >= 1"):
        training.train(PointEnv(), toy_config(n_step=0), None, progress=False)
