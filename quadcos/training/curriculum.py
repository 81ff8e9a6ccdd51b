"""What grows harder as a run trains: the course curriculum of a lane terrain
(`quadcos.courses`), whose robots move up the lanes as they succeed and down as they fail, and
the randomisation ramp.

Brax's `AutoResetWrapper` restarts every finished episode from that env's first state, so a robot
would stay on one lane (and one spawn point) for the whole run. `CourseCurriculum` takes its place
on lane terrains: each env keeps a level, the lane it runs on (the lanes of a `random:` family are
in order of slope), and an env whose episode ends restarts on the lane its new level names:

- up `promote_lanes` lanes (default one) when the episode ended without a fall, having crossed its
  course or walked `promote_m` m; past the top lane to a lane drawn uniformly from the top
  `restart_fraction` of the lanes (default all of them, so that no lane is forgotten);
- down one lane when it fell, or timed out having walked less than promote_m / 2 m;
- otherwise on the same lane, at a new spawn point.

Its cost is a fresh reset of every env in each step where some episode ended (one MJX forward
beside `substeps` MJX steps), selected where an episode ended.

The randomisation ramp (`RandomizationRamp`): a training robot's physics perturbations grow from
none to the full ranges over its first `env.randomization.ramp_s` seconds.

A randomised robot's draw acts at a level (`quadcos.randomization`: 0 is the nominal robot, 1 the
draw). `RandomizationRamp` counts each env's control steps across its episodes and, before every
step, sets its draw's level to min(1, steps · dt / ramp_s): a policy first learns on the nominal
robot and meets friction, mass, gains, latency and pushes as they grow. Only training is ramped:
evaluations draw at level 1.
"""

from typing import Any

import jax
import jax.numpy as jnp
import ml_collections
from brax import envs
from brax.envs.wrappers import training as training_wrappers


def wrap(env: envs.Env, episode_length: int, config: ml_collections.ConfigDict) -> envs.Env:
    """The training wrappers of `env`: Brax's (Vmap, Episode, AutoReset), with `CourseCurriculum`
    in AutoReset's place on a lane terrain when `config.enabled`, and around them the
    randomisation ramp where the env's config asks for one (`env.randomization.ramp_s`)."""
    lanes = getattr(getattr(env, "terrain", None), "num_lanes", 1)
    if lanes == 1 or not config.enabled:
        wrapped = training_wrappers.wrap(env, episode_length=episode_length)
    else:
        batched = training_wrappers.EpisodeWrapper(
            training_wrappers.VmapWrapper(env), episode_length, action_repeat=1
        )
        wrapped = CourseCurriculum(batched, env, config)
    if getattr(env, "randomized", False) and env.config.randomization.ramp_s > 0:
        return RandomizationRamp(
            wrapped, env.dt, env.config.randomization.ramp_s
        )
    return wrapped


def next_level(
    level: jax.Array,
    fell: jax.Array,
    crossed: jax.Array,
    walked: jax.Array,
    key: jax.Array,
    num_levels: int,
    promote_m: float,
    promote_lanes: int = 1,
    restart_from: int = 0,
) -> jax.Array:
    """The level (lane) of an env's next episode after one that ended (see the module doc).

    Args:
      level: (n,) int32 lanes of the episodes that ended.
      fell: (n,) bool, the episode ended in a fall.
      crossed: (n,) bool, the torso passed its lane's course end.
      walked: (n,) m along x from the spawn point.
      key: PRNG key for the lanes of envs that leave the top lane.
      num_levels: number of lanes.
      promote_m: m walked that count as success where the course was not crossed.
      promote_lanes: lanes climbed after a success.
      restart_from: the lowest lane an env that leaves the top lane restarts on.
    """
    up = ~fell & (crossed | (walked >= promote_m))
    down = fell | (~up & (walked < promote_m / 2))
    level = jnp.where(up, level + promote_lanes, jnp.where(down, level - 1, level))
    restart = jax.random.randint(key, level.shape, restart_from, num_levels, dtype=level.dtype)
    return jnp.clip(jnp.where(level >= num_levels, restart, level), 0, num_levels - 1)


class CourseCurriculum(envs.Wrapper):
    """Auto-reset onto the lane of each env's curriculum level (see the module doc).

    `env` is the batched, episode-wrapped env; `lane_env` the unbatched `QuadrupedEnv` whose
    `reset_on_lane` starts a robot on a given lane. The state's info holds per env
    "course_level" (int32), "course_start_x" (m) and "course_key".
    """

    def __init__(self, env: envs.Env, lane_env: Any, config: ml_collections.ConfigDict):
        super().__init__(env)
        self._lane_env = lane_env
        self._num_levels = lane_env.terrain.num_lanes
        self._lane_end_x = jnp.asarray(lane_env.terrain.lane_end_x, jnp.float32)
        self._promote_m = float(config.promote_m)
        self._promote_lanes = int(config.promote_lanes)
        self._start_levels = max(1, round(config.start_fraction * self._num_levels))
        self._restart_from = min(
            round((1 - config.restart_fraction) * self._num_levels), self._num_levels - 1
        )

    def reset(self, rng: jax.Array) -> envs.State:
        state = self.env.reset(rng)
        keys = jax.vmap(lambda key: jax.random.split(key, 3))(rng)
        level = jax.vmap(lambda key: jax.random.randint(key, (), 0, self._start_levels))(keys[:, 0])
        fresh = jax.vmap(self._lane_env.reset_on_lane)(keys[:, 1], level)
        state.info["course_level"] = level
        state.info["course_start_x"] = fresh.pipeline_state.qpos[:, 0]
        state.info["course_key"] = keys[:, 2]
        return state.replace(pipeline_state=fresh.pipeline_state, obs=fresh.obs)

    def step(self, state: envs.State, action: jax.Array) -> envs.State:
        steps = jnp.where(state.done, jnp.zeros_like(state.info["steps"]), state.info["steps"])
        state.info.update(steps=steps)
        state = self.env.step(state.replace(done=jnp.zeros_like(state.done)), action)
        done = state.done > 0
        level, x = state.info["course_level"], state.pipeline_state.qpos[:, 0]
        keys = jax.vmap(lambda key: jax.random.split(key, 3))(state.info["course_key"])
        new_level = next_level(
            level,
            fell=done & (state.info["truncation"] == 0),
            crossed=x >= self._lane_end_x[level],
            walked=x - state.info["course_start_x"],
            key=keys[0, 0],
            num_levels=self._num_levels,
            promote_m=self._promote_m,
            promote_lanes=self._promote_lanes,
            restart_from=self._restart_from,
        )
        level = jnp.where(done, new_level, level)
        # A reset costs about an MJX step: skip it in the steps where no episode ended.
        def reset_all() -> tuple[Any, jax.Array]:
            fresh = jax.vmap(self._lane_env.reset_on_lane)(keys[:, 1], level)
            return fresh.pipeline_state, fresh.obs

        fresh_pipeline, fresh_obs = jax.lax.cond(
            jnp.any(done), reset_all, lambda: (state.pipeline_state, state.obs)
        )

        def where_done(new: jax.Array, old: jax.Array) -> jax.Array:
            if old.ndim == 0 or old.shape[0] != done.shape[0]:  # not per env (MJX-Warp has some)
                return old
            return jnp.where(done.reshape((-1,) + (1,) * (old.ndim - 1)), new, old)

        pipeline_state = jax.tree.map(where_done, fresh_pipeline, state.pipeline_state)
        state.info["course_level"] = level
        state.info["course_start_x"] = where_done(
            fresh_pipeline.qpos[:, 0], state.info["course_start_x"]
        )
        state.info["course_key"] = keys[:, 2]
        return state.replace(pipeline_state=pipeline_state, obs=where_done(fresh_obs, state.obs))


class RandomizationRamp(envs.Wrapper):
    """The level ramp over the batched, auto-resetting training env `env` (see the module doc);
    `dt` is the control period (s). The state's info holds per env "ramp_steps" (int32)."""

    def __init__(self, env: envs.Env, dt: float, ramp_s: float):
        super().__init__(env)
        self._dt = float(dt)
        self._ramp_s = float(ramp_s)

    def level(self, steps: jax.Array) -> jax.Array:
        return jnp.minimum(1.0, steps * (self._dt / self._ramp_s))

    def _at_level(self, state: envs.State, steps: jax.Array) -> envs.State:
        physics = state.info["physics"]._replace(level=self.level(steps))
        return state.replace(info={**state.info, "physics": physics, "ramp_steps": steps})

    def reset(self, rng: jax.Array) -> envs.State:
        state = self.env.reset(rng)
        return self._at_level(state, jnp.zeros(state.done.shape, jnp.int32))

    def step(self, state: envs.State, action: jax.Array) -> envs.State:
        steps = state.info["ramp_steps"]
        state = self.env.step(self._at_level(state, steps), action)
        return state.replace(info={**state.info, "ramp_steps": steps + 1})
