"""Time to walk: train until the deterministic policy succeeds in >= 99 % of evaluation
episodes (`quadcos.evaluation`'s rollout) — walking on flat, or crossing the slope5 course."""

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Any

import jax
import numpy as np
from brax.training.agents.sac import networks as sac_networks

from quadcos import env as env_lib
from quadcos import evaluation, training
from quadcos.benchmarking.timing import log
from quadcos.evaluation import rollout as rollout_lib
from quadcos.training import loop

WALK_SECONDS = 20.0  # s: an evaluation episode on flat
WALK_MIN_SPEED = 0.3  # m/s: mean forward speed over an episode (and over the slope5 course)
WALK_SUCCESS_RATE = 0.99  # fraction of evaluation episodes that must succeed


@dataclasses.dataclass(frozen=True)
class Goal:
    """What an evaluation episode must achieve.

    Attributes:
      num_steps: env steps per episode (its time limit).
      duration_s: the time limit in seconds.
      finish_x: None: survive the whole episode and move >= `min_speed` forward (walking); else:
        the torso passes this x (m) before any fall (crossing a course).
      min_speed: m/s, for walking.
    """

    num_steps: int
    duration_s: float
    finish_x: float | None = None
    min_speed: float = WALK_MIN_SPEED


def terrain_goal(env: env_lib.QuadrupedEnv) -> Goal:
    """Flat: 20-s episodes, no fall and >= 0.3 m/s. A course (`course_end_x` set): episodes as
    long as crossing at 0.3 m/s takes; the torso must pass the course's end before any fall."""
    finish_x = env.terrain.course_end_x
    if finish_x is None:
        duration_s = WALK_SECONDS
    else:
        duration_s = (finish_x - env.terrain.spawn_x) / WALK_MIN_SPEED
    num_steps = math.ceil(duration_s / env.dt - 1e-9)
    return Goal(num_steps=num_steps, duration_s=num_steps * env.dt, finish_x=finish_x)


def episode_success(stats: evaluation.EpisodeStats, goal: Goal) -> np.ndarray:
    """(num_episodes,) bool from host `quadcos.evaluation` episode statistics of episodes run for
    `goal.num_steps` steps: crossed the course (no fall first), or walked the whole time limit
    at >= `goal.min_speed`."""
    if goal.finish_x is not None:
        return np.asarray(stats.finished)
    speed = (np.asarray(stats.x) - np.asarray(stats.start_x)) / goal.duration_s
    whole_episode = np.asarray(stats.steps) >= goal.num_steps
    return ~np.asarray(stats.fell) & whole_episode & (speed >= goal.min_speed)


def rollout_evaluator(
    trainer: training.SACTrainer, goal: Goal, num_episodes: int
) -> Callable[[training.TrainingState], dict[str, float]]:
    """training state -> success_rate, fall_rate, mean_speed (m/s) of `num_episodes`
    deterministic episodes (`quadcos.evaluation.rollout`, the same initial states every time) of
    the trainer's policy (tanh of the Gaussian mean) in the trainer's unwrapped env."""
    env = trainer.eval_env.env  # the VmapWrapper's env
    make_policy = sac_networks.make_inference_fn(trainer.networks)
    key_unused = jax.random.PRNGKey(0)  # a deterministic policy ignores its key

    def act(params: Any, obs: jax.Array) -> jax.Array:
        return make_policy(params, deterministic=True)(obs, key_unused)[0]

    source = evaluation.ActionSource(
        name="bench",
        kind="sac",
        act=act,
        params=None,
        env_overrides={},
        training_terrain=env.terrain.spec,
    )

    def evaluate(state: training.TrainingState) -> dict[str, float]:
        # On the host: as the rollout's own state, placed by JAX; parameters committed to a
        # device make the first chunk's outputs committed, and the next chunk compile anew.
        params = jax.device_get((state.normalizer_params, state.policy_params))
        stats = rollout_lib.rollout(
            env, source, num_envs=num_episodes, num_steps=goal.num_steps, seed=1, act_params=params
        ).stats
        seconds = np.maximum(np.asarray(stats.steps), 1) * env.dt
        return {
            "success_rate": float(episode_success(stats, goal).mean()),
            "fall_rate": float(np.mean(stats.fell)),
            "mean_speed": float(np.mean((stats.x - stats.start_x) / seconds)),
        }

    return evaluate


def time_to_success(
    trainer: training.SACTrainer,
    evaluate: Callable[[training.TrainingState], dict[str, float]],
    *,
    timeout_s: float,
    eval_interval: int,
    section_start: float,
    startup_s: float = 0.0,
    label: str = "",
) -> dict[str, Any]:
    """Trains with `trainer`, in the trainer's own host loop (`quadcos.training.loop.run_chunks`),
    until `evaluate(state)["success_rate"]` >= 99 %.

    Evaluations run every `eval_interval` env steps once the actor learns (after
    `config.actor_warmup_steps` gradient steps: before, the policy is the untrained one, e.g. the
    trot at the action centre, whose evaluation is recorded as the first one).

    Returns:
      seconds (startup_s + section_start -> the successful evaluation done; None if not reached
      within `timeout_s` of section_start), reason (None, or why not), initial_success_rate, and
      the evaluations (env_steps, gradient_steps, seconds and what `evaluate` returned).
    """
    config = trainer.config
    evaluations: list[dict[str, Any]] = []
    result: dict[str, Any] = {"seconds": None, "reason": None}
    next_eval: int | None = None

    def evaluate_now(state: training.TrainingState) -> float:
        row = {
            "env_steps": int(state.env_steps),
            "gradient_steps": int(state.gradient_steps),
            **evaluate(state),
            "seconds": startup_s + time.perf_counter() - section_start,
        }
        evaluations.append(row)
        log(
            f"{label}{row['env_steps']} env steps: "
            + ", ".join(f"{name} {value:.3g}" for name, value in row.items() if name != "env_steps")
        )
        return row["success_rate"]

    def on_chunk(state: training.TrainingState, chunk: loop.Chunk) -> bool:
        nonlocal next_eval
        if next_eval is None:  # the first chunk after the prefill
            next_eval = chunk.previous_step
        actor_learning = loop.actor_has_learned(config, int(state.gradient_steps))
        if actor_learning and chunk.step >= next_eval:
            next_eval = chunk.step + eval_interval
            if evaluate_now(state) >= WALK_SUCCESS_RATE:
                result["seconds"] = evaluations[-1]["seconds"]
                return True
        if time.perf_counter() - section_start > timeout_s:
            best = max((row["success_rate"] for row in evaluations[1:]), default=None)
            result["reason"] = (
                f"not reached in {timeout_s:g} s ({chunk.step} env steps); best success rate"
                f" after the actor's warm-up: {best}"
            )
            return True
        return False

    def on_start(state: training.TrainingState) -> None:
        evaluate_now(state)

    loop.run_chunks(
        trainer, trainer.init(), on_start=on_start, on_chunk=on_chunk, num_timesteps=None
    )
    return {
        **result,
        "initial_success_rate": evaluations[0]["success_rate"],
        "evaluations": evaluations,
    }
