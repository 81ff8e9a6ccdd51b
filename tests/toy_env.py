"""A pure-JAX Brax env small enough to train SAC on in seconds on a CPU."""

from brax.envs import base
import jax
import jax.numpy as jnp

from quadcos import training

# One chunk = 16 envs x 50 steps = 800 env steps; prefill = 800 env steps.
CHUNK = 800


class PointEnv(base.Env):
    """A point on a line steered towards a target.

    Position x' = x + step_size * action, action in [-1, 1]; x0 ~ U(-0.5, 0.5).
    Reward: -|x' - target| per step. The episode ends (a "fall") when
    |x'| > limit. Observation: (x, target - x).

    Test hook: with `nan_at_step` set, every env whose x0 > 0 gets a NaN
    position (hence NaN observation and reward) at its `nan_at_step`-th step
    after a reset.
    """

    def __init__(
        self,
        target: float = 0.5,
        step_size: float = 0.2,
        limit: float = 1.5,
        nan_at_step: int | None = None,
    ):
        self.target = target
        self.step_size = step_size
        self.limit = limit
        self.nan_at_step = nan_at_step

    def reset(self, rng: jax.Array) -> base.State:
        position = jax.random.uniform(rng, (), minval=-0.5, maxval=0.5)
        zero = jnp.zeros(())
        return base.State(
            pipeline_state=position,
            obs=self._obs(position),
            reward=zero,
            done=zero,
            metrics={"reward/distance": zero, "distance": zero},
            info={"time": jnp.zeros((), jnp.int32), "start": position},
        )

    def step(self, state: base.State, action: jax.Array) -> base.State:
        position = state.pipeline_state + self.step_size * action[0]
        time = state.info["time"] + 1
        if self.nan_at_step is not None:
            poisoned = (time == self.nan_at_step) & (state.info["start"] > 0)
            position = jnp.where(poisoned, jnp.nan, position)
        distance = jnp.abs(position - self.target)
        done = (jnp.abs(position) > self.limit).astype(jnp.float32)
        return state.replace(
            pipeline_state=position,
            obs=self._obs(position),
            reward=-distance,
            done=done,
            metrics={"reward/distance": -distance, "distance": distance},
            info={**state.info, "time": time},
        )

    def _obs(self, position: jax.Array) -> jax.Array:
        return jnp.stack([position, self.target - position])

    @property
    def observation_size(self) -> int:
        return 2

    @property
    def action_size(self) -> int:
        return 1

    @property
    def backend(self) -> str:
        return "jax"


def toy_config(**overrides):
    """Every test uses these shapes, so the compiled programs are shared."""
    config = training.default_config()
    config.num_envs = 16
    config.episode_length = 20
    config.batch_size = 128
    config.replay_size = 20_000
    config.min_replay_size = CHUNK
    config.hidden_sizes.policy = (32, 32)
    config.hidden_sizes.q = (32, 32)
    config.learning_rate.actor = 1e-3
    config.learning_rate.critic = 1e-3
    config.learning_rate.alpha = 1e-3
    config.discount = 0.9
    config.reward_scaling = 5.0
    config.steps_per_chunk = CHUNK // config.num_envs
    config.num_eval_envs = 32
    config.eval_episode_length = 20
    config.num_timesteps = CHUNK + 4 * CHUNK
    config.eval_interval = CHUNK
    config.checkpoint_interval = 2 * CHUNK
    config.keep_checkpoints = 3
    for name, value in overrides.items():
        config[name] = value
    return config
