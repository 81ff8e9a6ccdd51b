"""Training-time evaluation: deterministic episodes of the current policy, with their totals."""

from collections.abc import Callable

import flax
import jax
import jax.numpy as jnp
from brax import envs

from quadcos.env import episodes, randomization
from quadcos.env import tracking as tracking_lib

Metrics = dict[str, jax.Array]
# Step metrics whose per-episode peak, not mean, an evaluation reports (under quadcos.evaluate's
# names): the body's attitude, of which the gait's targets bound the worst moment.
PEAKS = {"abs_roll": "mean_max_abs_roll", "abs_pitch_error": "mean_max_abs_pitch_error"}


@flax.struct.dataclass
class Followed:
    """What command tracking carries from step to step (`quadcos.env.tracking`): the robots' pose
    (x, y, yaw) after the last step, the command (v*, ω*) they follow in the next, and the window
    sums."""

    pose: tuple[jax.Array, jax.Array, jax.Array]
    command: jax.Array
    windows: tracking_lib.Windows


@flax.struct.dataclass
class EvalTotals:
    """Per-episode sums over the alive steps of evaluation episodes."""

    reward: jax.Array
    length: jax.Array
    metrics: dict[str, jax.Array]
    alive: jax.Array
    diverged: jax.Array
    followed: Followed | None  # robots that follow velocity commands; None otherwise


def evaluate(
    eval_env: envs.Env,
    policy: Callable[[jax.Array], jax.Array],
    keys: jax.Array,
    *,
    episode_length: int,
) -> Metrics:
    """Runs one episode per key of `keys` of `policy` (batched obs → actions) on the batched
    `eval_env` for `episode_length` steps each, from the initial states the keys draw (the same
    keys, the same episodes). An episode is alive until the env reports done; steps after that
    are ignored. An episode whose physics diverged (a non-finite reward: the env ends it as a
    fall) counts in `eval/fall_rate` and `eval/diverged_rate`, and its non-finite step is left
    out of the sums, so that one blown-up robot does not turn the mean reward into NaN (as
    `quadcos.evaluation.metrics.aggregate` does for quadcos.evaluate). Robots that follow
    velocity commands (a quadcos env with `commands.spec` set) are measured as quadcos.evaluate
    measures them too: speed and yaw-rate tracking over 0.5-s windows (`quadcos.env.tracking`).

    Returns:
      Averages over the episodes of: `eval/episode_reward` (sum of rewards),
      `eval/episode_length` (alive steps), `eval/fall_rate` (1 if the episode ended with done
      before the time limit), `eval/diverged_rate` (1 if it ended non-finite), and for each key
      of the env's `state.metrics`, `eval/<key>`: the per-episode sum for keys starting with
      `reward/`, the per-episode peak for those of `PEAKS` (as `eval/mean_max_abs_roll`,
      `eval/mean_max_abs_pitch_error`, rad), else the per-episode mean over alive steps; with
      commands `eval/speed_tracking_rms` (m/s) and `eval/yaw_rate_tracking_rms` (rad/s), every
      closed window of every episode pooled (over several devices the trainer averages each
      device's). Where the env's robots take robustness conditions (`randomization.conditions`),
      also each condition's `eval/<condition key>/fall_rate`, its attitude peaks and tracking.
    """
    env_state = eval_env.reset(keys)
    zeros = jnp.zeros((keys.shape[0],))
    commanded = "velocity_command" in env_state.info
    window = tracking_lib.window_steps(eval_env.dt) if commanded else 0
    totals = EvalTotals(
        reward=zeros,
        length=zeros,
        metrics={name: zeros for name in env_state.metrics},
        alive=jnp.ones((keys.shape[0],), bool),
        diverged=jnp.zeros((keys.shape[0],), bool),
        followed=_followed(env_state, tracking_lib.Windows.zeros(keys.shape[0]))
        if commanded
        else None,
    )

    def update(totals: EvalTotals, next_env_state: envs.State, _) -> EvalTotals:
        blown_up = ~jnp.isfinite(next_env_state.reward)
        counted = totals.alive & ~blown_up

        # `where`, not multiplication: a fallen env may produce NaN.
        def alive_sum(total: jax.Array, value: jax.Array) -> jax.Array:
            return total + jnp.where(counted & jnp.isfinite(value), value, 0.0)

        def alive_max(total: jax.Array, value: jax.Array) -> jax.Array:
            return jnp.where(counted & jnp.isfinite(value), jnp.maximum(total, value), total)

        length = alive_sum(totals.length, 1.0)
        step_metrics = next_env_state.metrics
        followed = totals.followed
        if followed is not None:
            pose = tracking_lib.pose(next_env_state.pipeline_state.qpos)
            speed, yaw_rate = tracking_lib.velocity(followed.pose, pose, eval_env.dt)
            steps = length.astype(jnp.int32)
            windows = tracking_lib.advance(
                followed.windows, speed, yaw_rate, followed.command, counted, steps, window
            )
            followed = _followed(next_env_state, windows)
        return EvalTotals(
            reward=alive_sum(totals.reward, next_env_state.reward),
            length=length,
            metrics={
                name: (alive_max if name in PEAKS else alive_sum)(total, step_metrics[name])
                for name, total in totals.metrics.items()
            },
            alive=totals.alive & (next_env_state.done == 0) & ~blown_up,
            diverged=totals.diverged | (totals.alive & blown_up),
            followed=followed,
        )

    _, totals, _ = episodes.run_episodes(
        eval_env.step, policy, env_state, totals, update, episode_length
    )
    metrics = {
        "eval/episode_reward": jnp.mean(totals.reward),
        "eval/episode_length": jnp.mean(totals.length),
        "eval/fall_rate": jnp.mean(~totals.alive),
        "eval/diverged_rate": jnp.mean(totals.diverged),
    }
    for name, per_episode in totals.metrics.items():
        if name in PEAKS:
            metrics[f"eval/{PEAKS[name]}"] = jnp.mean(per_episode)
            continue
        if not name.startswith("reward/"):
            per_episode = per_episode / jnp.maximum(totals.length, 1.0)
        metrics[f"eval/{name}"] = jnp.mean(per_episode)
    if totals.followed is not None:
        speed, yaw_rate = tracking_lib.pooled_rms(totals.followed.windows)
        metrics |= {"eval/speed_tracking_rms": speed, "eval/yaw_rate_tracking_rms": yaw_rate}
    for index, name in enumerate(_conditions(eval_env)):
        metrics |= _condition(totals, env_state.info["condition"] == index, name)
    return metrics


def _conditions(eval_env: envs.Env) -> tuple[str, ...]:
    """The robustness conditions the env's robots take (`randomization.conditions`), or ()."""
    config = getattr(getattr(eval_env, "unwrapped", eval_env), "config", None)
    if config is None or "randomization" not in config or not config.randomization.enabled:
        return ()
    return randomization.condition_names(config.randomization.conditions)


def _condition(totals: EvalTotals, member: jax.Array, name: str) -> Metrics:
    """The falls, attitude peaks and tracking of the episodes `member` ((n,) bool) under the
    condition `name`, under `eval/<its key>/`."""
    prefix = f"eval/{randomization.condition_key(name)}/"
    count = jnp.maximum(jnp.sum(member), 1)

    def mean(per_episode: jax.Array) -> jax.Array:
        return jnp.sum(jnp.where(member, per_episode, 0.0)) / count

    metrics = {prefix + "fall_rate": mean(~totals.alive)}
    for step_name, key in PEAKS.items():
        if step_name in totals.metrics:
            metrics[prefix + key] = mean(totals.metrics[step_name])
    if totals.followed is not None:
        windows = jax.tree.map(lambda a: jnp.where(member, a, 0), totals.followed.windows)
        speed, yaw_rate = tracking_lib.pooled_rms(windows)
        metrics |= {
            prefix + "speed_tracking_rms": speed,
            prefix + "yaw_rate_tracking_rms": yaw_rate,
        }
    return metrics


def _followed(state: envs.State, windows: tracking_lib.Windows) -> Followed:
    """The robots' pose after `state`'s step and the command they follow next."""
    command = state.info["velocity_command"].velocity
    return Followed(tracking_lib.pose(state.pipeline_state.qpos), command, windows)
