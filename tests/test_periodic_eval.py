"""Training-time evaluation (quadcos.training.periodic_eval): sums over alive steps, and a robot
whose physics blows up counts as a fall without turning the means into NaN; the attitude reported
as each episode's peak."""

import jax.numpy as jnp
import ml_collections
import numpy as np
import pytest
from brax import envs

from quadcos.env import randomization
from quadcos.training import periodic_eval

NAN = float("nan")


class ScriptedEnv:
    """Three robots, one control step a call: robot 0's physics blows up at its 3rd step (NaN
    reward and speed, done), robot 1 falls at its 4th (finite), robot 2 walks on. Reward 1 a step,
    speed 0.5."""

    def reset(self, keys):
        n = keys.shape[0]
        return envs.State(
            pipeline_state=None,
            obs=jnp.zeros((n, 1)),
            reward=jnp.zeros(n),
            done=jnp.zeros(n),
            metrics={
                "forward_speed": jnp.zeros(n),
                "reward/forward": jnp.zeros(n),
                "abs_roll": jnp.zeros(n),
            },
        )

    def step(self, state, action):
        t = state.obs[:, 0] + 1.0  # this step's number, from 1
        blown = (jnp.arange(3) == 0) & (t == 3)
        fell = (jnp.arange(3) == 1) & (t == 4)
        reward = jnp.where(blown, NAN, 1.0)
        speed = jnp.where(blown, NAN, 0.5)
        roll = jnp.where(blown, 9.0, jnp.where((jnp.arange(3) == 2) & (t == 5), 0.3, 0.1))
        return state.replace(
            obs=t[:, None],
            reward=reward,
            done=(blown | fell).astype(jnp.float32),
            # roll 0.1 rad a step, robot 2 rolls 0.3 at its 5th; 9 at robot 0's blown-up step
            metrics={"forward_speed": speed, "reward/forward": reward, "abs_roll": roll},
        )


def test_a_diverged_robot_counts_as_a_fall_and_leaves_the_means_finite():
    metrics = periodic_eval.evaluate(
        ScriptedEnv(), lambda obs: jnp.zeros((obs.shape[0], 1)), jnp.zeros((3, 2)), episode_length=6
    )
    metrics = {key: float(value) for key, value in metrics.items()}
    # Alive-step rewards: robot 0 its 2 finite steps, robot 1 its 4 (the fall's step counts), 2 all 6.
    assert metrics["eval/episode_reward"] == pytest.approx((2 + 4 + 6) / 3)
    assert metrics["eval/episode_length"] == pytest.approx((2 + 4 + 6) / 3)
    assert metrics["eval/reward/forward"] == pytest.approx((2 + 4 + 6) / 3)
    assert metrics["eval/forward_speed"] == pytest.approx(0.5)
    assert metrics["eval/fall_rate"] == pytest.approx(2 / 3)
    assert metrics["eval/diverged_rate"] == pytest.approx(1 / 3)
    # The attitude's per-episode peak over the counted steps, as quadcos.evaluate reports it.
    assert metrics["eval/mean_max_abs_roll"] == pytest.approx((0.1 + 0.1 + 0.3) / 3)
    assert "eval/abs_roll" not in metrics
    assert all(np.isfinite(value) for value in metrics.values())


class ConditionedEnv(ScriptedEnv):
    """ScriptedEnv whose robots take conditions (`randomization.conditions`): robot 0 the
    nominal robot, robots 1 and 2 friction 0.4."""

    def __init__(self):
        config = randomization.default_config()
        config.update(enabled=True, conditions="nominal;friction 0.4")
        self.config = ml_collections.ConfigDict({"randomization": config})
        self.unwrapped = self

    def reset(self, keys):
        state = super().reset(keys)
        return state.replace(info={"condition": jnp.array([0, 1, 1])})


def test_robots_under_conditions_are_reported_per_condition_beside_the_pooled_metrics():
    metrics = periodic_eval.evaluate(
        ConditionedEnv(),
        lambda obs: jnp.zeros((obs.shape[0], 1)),
        jnp.zeros((3, 2)),
        episode_length=6,
    )
    metrics = {key: float(value) for key, value in metrics.items()}
    assert metrics["eval/fall_rate"] == pytest.approx(2 / 3)
    assert metrics["eval/nominal/fall_rate"] == 1.0  # robot 0, whose physics blew up
    assert metrics["eval/friction_0.4/fall_rate"] == pytest.approx(0.5)  # robot 1 of 1 and 2
    assert metrics["eval/friction_0.4/mean_max_abs_roll"] == pytest.approx((0.1 + 0.3) / 2)
    assert not any("tracking" in key for key in metrics)  # robots without commands
