"""Held exploration noise (`sac.noise_hold_steps`): each env keeps its draw for a while."""

import jax
import numpy as np
import pytest

from quadcos import training
from tests.toy_env import PointEnv


def trainer(noise_hold_steps: int) -> training.SACTrainer:
    config = training.default_config()
    config.num_envs = 8
    config.batch_size = 16
    config.replay_size = 1_024
    config.min_replay_size = 8
    config.hidden_sizes.policy = (8,)
    config.hidden_sizes.q = (8,)
    config.noise_hold_steps = noise_hold_steps
    return training.SACTrainer(PointEnv(), config)


def consecutive_actions(trainer: training.SACTrainer, uniform: bool, steps: int = 40) -> np.ndarray:
    state = trainer.init()
    explore = jax.jit(lambda state, key: trainer._exploring_actions(state, key, uniform=uniform))
    actions = []
    for key in jax.random.split(jax.random.PRNGKey(0), steps):
        action, state = explore(state, key)
        actions.append(np.asarray(action))
    return np.stack(actions)  # (steps, envs, action_size); the env state does not move here


@pytest.mark.parametrize("uniform", [True, False])
def test_held_draws_repeat_and_fresh_draws_do_not(uniform):
    held = consecutive_actions(trainer(noise_hold_steps=10), uniform)
    fresh = consecutive_actions(trainer(noise_hold_steps=1), uniform)
    repeats = lambda actions: np.mean(np.all(actions[1:] == actions[:-1], axis=-1))
    # Redrawn with probability 1/10 a step: ~90 % of steps repeat the previous action.
    assert 0.75 < repeats(held) < 0.98
    assert repeats(fresh) == 0.0
    assert np.all(np.abs(held) <= 1.0)
    if uniform:  # the CDF of the held normal draw is uniform on [-1, 1]
        assert abs(float(np.mean(held))) < 0.2 and 0.2 < float(np.std(held)) < 0.8
