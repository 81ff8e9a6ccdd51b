"""Batched deterministic rollouts of a trained policy or fixed oscillator parameters.

    python -m quadcos.evaluate --policy=runs/slope5 --terrain=s4 --num_envs=1024 --seconds=30 \\
        --out=s4.json --trace=s4_trace.json --video=s4.mp4
    python -m quadcos.evaluate --policy=fixed:trot --terrain=slope5 --out=fixed.json   # Fig. 15
    python -m quadcos.evaluate --policy=fixed:0.4,0.15,0.6,pi/2,-pi/2 --out=fixed.json
    python -m quadcos.evaluate --search_fixed --terrain=flat --num_candidates=512 --out=search.json
    python -m quadcos.evaluate --render=s4_trace.json --video=s4.mp4     # a saved trace, here

`--policy` is a run directory, a policy directory (`quadcos.load_policy`), `fixed:trot`
(`oscillator.FIXED_TROT`) or `fixed:A_k,A_h,T,phi1,phi3` (rad, rad, s, rad, rad; `pi` allowed).
A trained policy runs in the env it was trained in (its saved env config), on its training
terrain unless `--terrain` names another; fixed parameters run in the default env.

An episode ends when the robot falls (the env's fall check), when `--seconds` have passed, or, on a
course (a terrain with `course_end_x`), when the torso passes the course end. Success: no fall and,
on a course, the course end reached within `--seconds`. Bad flags, policy paths or terrain specs
exit with one line on stderr and status 2, before anything is written; output files are written
atomically.

--out JSON: aggregates at the top level — num_episodes, success_rate, fall_rate,
course_completion_rate, mean_forward_speed (m/s), std_forward_speed, mean_distance (m),
mean_seconds, mean_max_abs_roll, mean_max_abs_yaw, mean_max_abs_pitch_error (|pitch − slope|,
rad), mean_lateral_drift (|Δy| at the episode's end, m), mean_max_lateral_deviation (m),
slope_error_rms (estimate − ground truth over all steps, rad), mean_episode_reward (Eq. 13 summed),
mean_reward_terms — then "setup" (policy, terrain, sizes, env config, versions) and "episodes"
(one dict per episode: success, fell, fall_time_s, finished_course, finish_time_s, seconds,
distance, forward_speed, lateral_drift, max_abs_roll, ..., episode_reward, reward_terms).
--trace JSON: one episode's series (see `trace_dict`), its positions and env config.
"""

import argparse
import ast
import dataclasses
import functools
import json
import math
import operator
import os
import pathlib
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import flax.struct
import jax
import jax.numpy as jnp
import numpy as np

from quadcos import constants, oscillator, reward, slope, video
from quadcos import overrides as overrides_lib
from quadcos import env as env_lib
from quadcos import terrain as terrain_lib

FORMAT = "quadcos.evaluation"
TRACE_FORMAT = "quadcos.trace"
SEARCH_FORMAT = "quadcos.fixed_search"
FORMAT_VERSION = 1
FIXED_PREFIX = "fixed:"
CHUNK_STEPS = 20  # control steps per compiled call: the progress granularity

# Env options that a saved policy's config may lack because they were added after it was trained,
# with the value that reproduces the env of that time (the default now differs).
LEGACY_ENV_VALUES = {
    "action_filter_tau": 0.0,  # the command filter came later; before it, parameters changed at once
    "action_centre": "midpoint",  # before the trot-centred action map, the zero action was mid-range
}

PARAMETER_NAMES = oscillator.RhythmParameters._fields
# Per-step series of a trace, besides controller/<joint>, joint/<joint>, parameter/<name>, action/<i>.
TRACE_SERIES = (
    "time",  # s, at the end of each control step
    "cog_x",  # m: torso centre (the robot's centre of gravity in the paper's figures)
    "cog_y",
    "cog_z",
    "pitch",  # rad, nose up positive
    "yaw",
    "roll",
    "expected_pitch",  # rad: ground-truth slope under the torso (Eq. 12's target)
    "slope_estimate",  # rad: the Eq. 5 estimate
    "forward_speed",  # m/s over the control step
    "reward",  # Eq. 13, per step
)


# --- what acts: a trained policy or fixed parameters --------------------------------------------


@dataclasses.dataclass(frozen=True)
class Controller:
    """What chooses actions, and the env it must run in.

    Attributes:
      name: the --policy string (or a description).
      kind: "sac" or "fixed".
      act: (params, obs (n, obs_size)) -> actions (n, action_size); jit-able.
      params: the first argument of `act` (fixed: the (5,) parameters; sac: None).
      env_overrides: env config overrides (dotted keys) that rebuild the training env.
      training_terrain: the terrain spec the policy was trained on ("flat" for fixed parameters).
      fixed_parameters: the rhythm parameters of a fixed controller, else None.
      observation_size, action_size: what the policy expects (None: anything).
    """

    name: str
    kind: str
    act: Callable[[Any, jax.Array], jax.Array]
    params: Any
    env_overrides: dict[str, Any]
    training_terrain: str
    fixed_parameters: oscillator.RhythmParameters | None = None
    observation_size: int | None = None
    action_size: int | None = None


def parse_fixed(text: str) -> oscillator.RhythmParameters:
    """`trot` or `A_k,A_h,T,phi1,phi3` (rad, rad, s, rad, rad; `pi` allowed) as rhythm parameters.

    Raises:
      ValueError: not five numbers (the env checks the ranges: `build_env`).
    """
    body = text.strip()
    if body == "trot":
        return oscillator.FIXED_TROT
    tokens = body.split(",")
    if len(tokens) != len(PARAMETER_NAMES):
        raise ValueError(
            f"bad fixed parameters {text!r}: expected 'trot' or five numbers A_k,A_h,T,phi1,phi3"
        )
    return oscillator.RhythmParameters(*(_number(token, text) for token in tokens))


_OPERATORS = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.USub: operator.neg,
    ast.UAdd: operator.pos,
}


def _number(token: str, text: str) -> float:
    """A float from '0.4', '-pi/2', '3*pi/4' (arithmetic on numbers and pi only)."""

    def value(node: ast.AST) -> float:
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id == "pi":
            return math.pi
        if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](value(node.left), value(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](value(node.operand))
        raise ValueError

    try:
        number = value(ast.parse(token.strip(), mode="eval").body)
    except (ValueError, SyntaxError, ZeroDivisionError, RecursionError):
        raise ValueError(
            f"bad fixed parameters {text!r}: {token.strip()!r} is not a number"
        ) from None
    if not math.isfinite(number):
        raise ValueError(f"bad fixed parameters {text!r}: {token.strip()!r} is not finite")
    return number


def fixed_controller(params: oscillator.RhythmParameters, name: str | None = None) -> Controller:
    """Constant rhythm parameters through the same rollout path as a policy (Fig. 15's baseline)."""
    name = name or FIXED_PREFIX + ",".join(f"{float(p):.6g}" for p in params)
    return Controller(
        name=name,
        kind="fixed",
        act=_constant_action,
        params=jnp.asarray([float(p) for p in params], jnp.float32),
        env_overrides={},
        training_terrain="flat",
        fixed_parameters=oscillator.RhythmParameters(*(float(p) for p in params)),
        action_size=5,
    )


def _constant_action(actions: jax.Array, obs: jax.Array) -> jax.Array:
    """The (n, 5) actions that `rollout` computed from the fixed parameters for its env."""
    del obs
    return actions


def policy_controller(path: str | os.PathLike[str]) -> Controller:
    """A trained policy (run or policy directory) and the env config it was trained with.

    Raises:
      FileNotFoundError: no policy at `path`.
      ValueError: the policy's saved env config is missing or names options this quadcos lacks.
    """
    from quadcos.training import load_policy

    if not pathlib.Path(path).exists():
        raise FileNotFoundError(f"no policy at {path}: no such file or directory")
    try:
        policy = load_policy(path)
    except (FileNotFoundError, ValueError):
        raise
    except Exception as error:  # noqa: BLE001 -- msgpack, flax and JSON readers raise many types
        raise ValueError(
            f"cannot load the policy at {path}: {type(error).__name__}: {error}"
        ) from None
    try:
        env_config = dict(policy.config["run_info"]["env"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"the policy at {path} has no saved env config (run_info.env)") from None
    return Controller(
        name=str(path),
        kind="sac",
        act=lambda _, obs: policy.act(obs),
        params=None,
        env_overrides=env_overrides_from_saved(env_config),
        training_terrain=str(env_config.get("terrain", "flat")),
        observation_size=policy.spec.observation_size,
        action_size=policy.spec.action_size,
    )


def resolve_controller(spec: str) -> Controller:
    """The controller for a --policy value: `fixed:...` or a policy / run directory."""
    if spec.startswith(FIXED_PREFIX):
        body = spec[len(FIXED_PREFIX) :]
        return fixed_controller(parse_fixed(body), name=spec)
    return policy_controller(spec)


def env_overrides_from_saved(saved: Mapping[str, Any]) -> dict[str, Any]:
    """Dotted env overrides that rebuild the env of a saved env config (terrain excluded).

    Options the saved config lacks take `LEGACY_ENV_VALUES` (or today's default when the option has
    no legacy value).

    Raises:
      ValueError: the saved config has options this version of the env does not know.
    """
    saved_flat = {
        key: value for key, value in overrides_lib.flatten(saved).items() if key != "terrain"
    }
    known = set(overrides_lib.flat_keys(env_lib.default_config()))
    unknown = sorted(set(saved_flat) - known)
    if unknown:
        raise ValueError(
            f"the policy was trained with env options this quadcos does not know: {', '.join(unknown)}"
        )
    overrides = {key: value for key, value in LEGACY_ENV_VALUES.items() if key not in saved_flat}
    return overrides | saved_flat


def build_env(
    controller: Controller,
    terrain: terrain_lib.Terrain | str | None = None,
    env_overrides: Mapping[str, Any] | None = None,
) -> env_lib.QuadrupedEnv:
    """The env `controller` runs in, on `terrain` (default: its training terrain).

    Raises:
      ValueError: bad terrain or override, or an env whose observation / action sizes differ from
        the policy's.
    """
    # An evaluation episode starts at the spawn point, wherever training spawned.
    overrides = {**controller.env_overrides, "spawn_x_max": 0.0, **(env_overrides or {})}
    overrides.pop("terrain", None)
    env = env_lib.make_env(
        terrain if terrain is not None else controller.training_terrain, **overrides
    )
    if controller.kind == "fixed":
        _check_fixed(controller, env)
    if controller.action_size is not None and env.action_size != controller.action_size:
        raise ValueError(
            f"the policy acts with {controller.action_size} values, the env expects {env.action_size}"
        )
    if controller.observation_size is not None:
        size = env.observation_size
        if size != controller.observation_size:
            raise ValueError(
                f"the policy expects observations of size {controller.observation_size}, the env"
                f" gives {size}: its env config does not match the one it was trained with"
            )
    return env


def _check_fixed(controller: Controller, env: env_lib.QuadrupedEnv) -> None:
    if env.config.controller != "oscillator":
        raise ValueError("fixed rhythm parameters need the env option controller='oscillator'")
    if controller.fixed_parameters is None:
        return
    lower, upper = oscillator.parameter_bounds(env.config.period_min)
    for name, value, low, high in zip(PARAMETER_NAMES, controller.fixed_parameters, lower, upper):
        if not low <= value <= high:
            raise ValueError(
                f"bad fixed parameters {controller.name!r}: {name}={value:g} is outside"
                f" [{low:g}, {high:g}] (§3.3 ranges, T >= period_min)"
            )


# --- rollouts ------------------------------------------------------------------------------------


@flax.struct.dataclass
class EpisodeStats:
    """Running per-episode statistics, each (n,); updated only while the episode runs."""

    running: jax.Array  # bool: not fallen, not finished, within the time limit
    fell: jax.Array  # bool
    finished: jax.Array  # bool: the torso passed the course end
    steps: jax.Array  # int32: control steps taken, the fall step included
    start_x: jax.Array  # m
    start_y: jax.Array
    x: jax.Array  # m, at the last step taken
    y: jax.Array
    max_lateral_deviation: jax.Array  # m: max |y − start_y|
    max_abs_roll: jax.Array  # rad
    max_abs_yaw: jax.Array
    max_abs_pitch_error: jax.Array  # rad: max |pitch − true slope|
    slope_sq_error: jax.Array  # rad²: Σ (estimate − truth)²
    episode_reward: jax.Array  # Σ Eq. 13
    reward_terms: dict[str, jax.Array]  # Σ of each term


@dataclasses.dataclass
class Rollout:
    """Host copies of a finished batched rollout.

    Attributes:
      stats: EpisodeStats of numpy arrays, (num_envs,) each.
      trace: series of the traced episode, (num_steps,) or (num_steps, k) numpy arrays, covering the
        whole time limit (use `stats.steps[trace_index]` to cut it where the episode ended).
      qpos: (num_steps, nq) positions of the traced episode, for rendering.
      start_qpos: (nq,) its positions after reset.
    """

    stats: EpisodeStats
    trace: dict[str, np.ndarray]
    qpos: np.ndarray
    start_qpos: np.ndarray


def _snapshot(env: env_lib.QuadrupedEnv, state: Any, index: jax.Array) -> dict[str, jax.Array]:
    """The trace series of robot `index` after a step."""
    data = state.pipeline_state
    qpos, time_now = data.qpos[index], data.time[index]
    body = slope.attitude(qpos[constants.QPOS_QUATERNION])
    command, phase = state.info["command"][index], state.info["phase"][index]
    snapshot = {
        "time": time_now,
        "cog_x": qpos[0],
        "cog_y": qpos[1],
        "cog_z": qpos[2],
        "pitch": body.pitch,
        "yaw": body.yaw,
        "roll": body.roll,
        "expected_pitch": state.metrics["slope_truth"][index],
        "slope_estimate": state.metrics["slope_estimate"][index],
        "forward_speed": state.metrics["forward_speed"][index],
        "reward": state.reward[index],
        "controller": env.joint_targets(command, phase, time_now),
        "joint": qpos[constants.QPOS_JOINTS],
        "action": command,
        "qpos": qpos,
    }
    if env.config.controller == "oscillator":
        params = oscillator.action_to_parameters(command, env.config.period_min, env.action_centre)
        snapshot["parameter"] = jnp.stack(params)
    return snapshot


def _initial_stats(state: Any, num_envs: int) -> EpisodeStats:
    qpos = state.pipeline_state.qpos
    zeros = jnp.zeros(num_envs)
    return EpisodeStats(
        running=jnp.ones(num_envs, bool),
        fell=jnp.zeros(num_envs, bool),
        finished=jnp.zeros(num_envs, bool),
        steps=jnp.zeros(num_envs, jnp.int32),
        start_x=qpos[:, 0],
        start_y=qpos[:, 1],
        x=qpos[:, 0],
        y=qpos[:, 1],
        max_lateral_deviation=zeros,
        max_abs_roll=zeros,
        max_abs_yaw=zeros,
        max_abs_pitch_error=zeros,
        slope_sq_error=zeros,
        episode_reward=zeros,
        reward_terms={term: zeros for term in reward.TERM_NAMES},
    )


def _update_stats(
    stats: EpisodeStats, state: Any, counts: jax.Array, course_end_x: float | None
) -> EpisodeStats:
    """Adds one step to the episodes that were running before it (`counts`)."""
    qpos = state.pipeline_state.qpos
    body = slope.attitude(qpos[:, constants.QPOS_QUATERNION])
    x, y = qpos[:, 0], qpos[:, 1]
    metrics = state.metrics

    def accumulate(old, new):
        return jnp.where(counts, new, old)

    fell = counts & (state.done > 0)
    at_end = jnp.zeros_like(fell) if course_end_x is None else x >= course_end_x
    finished = counts & ~fell & at_end
    slope_error = metrics["slope_estimate"] - metrics["slope_truth"]
    return EpisodeStats(
        running=stats.running & ~fell & ~finished,
        fell=stats.fell | fell,
        finished=stats.finished | finished,
        steps=stats.steps + counts.astype(jnp.int32),
        start_x=stats.start_x,
        start_y=stats.start_y,
        x=accumulate(stats.x, x),
        y=accumulate(stats.y, y),
        max_lateral_deviation=accumulate(
            stats.max_lateral_deviation,
            jnp.maximum(stats.max_lateral_deviation, jnp.abs(y - stats.start_y)),
        ),
        max_abs_roll=accumulate(
            stats.max_abs_roll, jnp.maximum(stats.max_abs_roll, jnp.abs(body.roll))
        ),
        max_abs_yaw=accumulate(
            stats.max_abs_yaw, jnp.maximum(stats.max_abs_yaw, jnp.abs(body.yaw))
        ),
        max_abs_pitch_error=accumulate(
            stats.max_abs_pitch_error,
            jnp.maximum(stats.max_abs_pitch_error, jnp.abs(body.pitch - metrics["slope_truth"])),
        ),
        slope_sq_error=accumulate(stats.slope_sq_error, stats.slope_sq_error + slope_error**2),
        episode_reward=accumulate(stats.episode_reward, stats.episode_reward + state.reward),
        reward_terms={
            term: accumulate(total, total + metrics[f"reward/{term}"])
            for term, total in stats.reward_terms.items()
        },
    )


@functools.lru_cache(maxsize=16)
def _compiled_chunk(env: env_lib.QuadrupedEnv, act: Callable, chunk_steps: int) -> Callable:
    """jit(chunk of `chunk_steps` control steps for all robots); cached per env and controller."""
    course_end_x = env.terrain.course_end_x

    def chunk(state, stats, act_params, first_step, num_steps, trace_index):
        def body(carry, offset):
            state, stats = carry
            action = act(act_params, state.obs)
            state = jax.vmap(env.step)(state, action)
            counts = stats.running & (first_step + offset < num_steps)
            stats = _update_stats(stats, state, counts, course_end_x)
            return (state, stats), _snapshot(env, state, trace_index)

        (state, stats), trace = jax.lax.scan(body, (state, stats), jnp.arange(chunk_steps))
        return state, stats, trace

    return jax.jit(chunk)


@functools.lru_cache(maxsize=16)
def _compiled_reset(env: env_lib.QuadrupedEnv) -> Callable:
    return jax.jit(jax.vmap(env.reset))


def rollout(
    env: env_lib.QuadrupedEnv,
    controller: Controller,
    *,
    num_envs: int,
    num_steps: int,
    seed: int = 0,
    trace_index: int = 0,
    act_params: Any = None,
    progress: Callable[[int, int], None] | None = None,
    chunk_steps: int = CHUNK_STEPS,
) -> Rollout:
    """Runs `num_envs` robots for at most `num_steps` control steps each, deterministically.

    Args:
      act_params: overrides `controller.params` (e.g. (num_envs, 5) fixed parameters, one row per
        robot, for a search).
      progress: called as progress(steps_done, num_steps) after each compiled chunk.
    """
    if num_envs < 1 or num_steps < 1:
        raise ValueError(f"num_envs and num_steps must be >= 1; got {num_envs}, {num_steps}")
    if not 0 <= trace_index < num_envs:
        raise ValueError(f"trace episode {trace_index} is not in 0..{num_envs - 1}")
    params = controller.params if act_params is None else act_params
    if controller.kind == "fixed":  # parameters -> the constant actions that command them here
        params = jnp.broadcast_to(jnp.asarray(params, jnp.float32), (num_envs, 5))
        params = env.action_for(oscillator.RhythmParameters(*jnp.moveaxis(params, -1, 0)))
    chunk = _compiled_chunk(env, controller.act, chunk_steps)
    state = _compiled_reset(env)(jax.random.split(jax.random.PRNGKey(seed), num_envs))
    start_qpos = np.asarray(state.pipeline_state.qpos[trace_index])
    stats = _initial_stats(state, num_envs)
    traces = []
    done = 0
    while done < num_steps:
        state, stats, trace = chunk(
            state, stats, params, jnp.int32(done), jnp.int32(num_steps), jnp.int32(trace_index)
        )
        traces.append(jax.device_get(trace))
        done = min(done + chunk_steps, num_steps)
        if progress is not None:
            progress(done, num_steps)
        if not bool(stats.running.any()):
            break
    trace = {key: np.concatenate([t[key] for t in traces])[:num_steps] for key in traces[0]}
    qpos = trace.pop("qpos")
    return Rollout(stats=jax.device_get(stats), trace=trace, qpos=qpos, start_qpos=start_qpos)


# --- evaluation: per-episode values, aggregates, trace --------------------------------------------


@dataclasses.dataclass
class Evaluation:
    """The result of `evaluate`.

    Attributes:
      summary: aggregates (see `aggregate`) and the set-up under "setup".
      episodes: one dict of values per episode.
      trace: the traced episode's series, cut where it ended (see `trace_dict`).
      qpos: (steps, nq) positions of the traced episode, from reset on, for `render_video`.
      env: the env it ran in.
    """

    summary: dict[str, Any]
    episodes: list[dict[str, Any]]
    trace: dict[str, Any]
    qpos: np.ndarray
    env: env_lib.QuadrupedEnv

    def to_json(self) -> dict[str, Any]:
        """The evaluation file's content: aggregates at the top, then setup and episodes."""
        return {**self.summary, "episodes": self.episodes}

    def save_video(self, path: str | os.PathLike[str], **options: Any) -> pathlib.Path:
        """The traced episode as an mp4 at the control rate; options: see `video.render_video`.

        Raises:
          video.VideoError: no headless OpenGL or no mp4 writer here.
        """
        return video.render_video(
            self.env.mj_model, self.qpos, path, fps=1.0 / self.env.dt, **options
        )


def episode_values(stats: EpisodeStats, dt: float, num_steps: int) -> list[dict[str, Any]]:
    """Per-episode values from host EpisodeStats; times in s, lengths in m, angles in rad."""
    episodes = []
    for i in range(len(stats.steps)):
        steps = int(stats.steps[i])
        seconds = steps * dt
        distance = float(stats.x[i] - stats.start_x[i])
        fell, finished = bool(stats.fell[i]), bool(stats.finished[i])
        episodes.append(
            {
                "index": i,
                "success": None,  # filled by evaluate (depends on the terrain)
                "fell": fell,
                "fall_time_s": seconds if fell else None,
                "finished_course": finished,
                "finish_time_s": seconds if finished else None,
                "seconds": seconds,
                "timed_out": steps >= num_steps and not fell and not finished,
                "distance": distance,
                "forward_speed": distance / seconds if steps else 0.0,
                "lateral_drift": float(abs(stats.y[i] - stats.start_y[i])),
                "max_lateral_deviation": float(stats.max_lateral_deviation[i]),
                "max_abs_roll": float(stats.max_abs_roll[i]),
                "max_abs_yaw": float(stats.max_abs_yaw[i]),
                "max_abs_pitch_error": float(stats.max_abs_pitch_error[i]),
                "slope_error_rms": math.sqrt(float(stats.slope_sq_error[i]) / steps)
                if steps
                else None,
                "episode_reward": float(stats.episode_reward[i]),
                "reward_terms": {k: float(v[i]) for k, v in stats.reward_terms.items()},
                "final_x": float(stats.x[i]),
                "final_y": float(stats.y[i]),
            }
        )
    return episodes


def aggregate(episodes: Sequence[Mapping[str, Any]], stats: EpisodeStats) -> dict[str, Any]:
    """Aggregates over episodes (means of per-episode values unless said otherwise).

    `slope_error_rms` pools every step of every episode: sqrt(Σ squared errors / Σ steps).
    """

    def mean(key: str) -> float:
        return float(np.mean([float(e[key]) for e in episodes]))

    total_steps = int(np.sum(stats.steps))
    speeds = np.array([e["forward_speed"] for e in episodes])
    return {
        "num_episodes": len(episodes),
        "success_rate": mean("success"),
        "fall_rate": mean("fell"),
        "course_completion_rate": mean("finished_course"),
        "mean_forward_speed": float(speeds.mean()),
        "std_forward_speed": float(speeds.std()),
        "mean_distance": mean("distance"),
        "mean_seconds": mean("seconds"),
        "mean_max_abs_roll": mean("max_abs_roll"),
        "mean_max_abs_yaw": mean("max_abs_yaw"),
        "mean_max_abs_pitch_error": mean("max_abs_pitch_error"),
        "mean_lateral_drift": mean("lateral_drift"),
        "mean_max_lateral_deviation": mean("max_lateral_deviation"),
        "slope_error_rms": math.sqrt(float(np.sum(stats.slope_sq_error)) / total_steps)
        if total_steps
        else None,
        "mean_episode_reward": mean("episode_reward"),
        "mean_reward_terms": {
            term: float(np.mean([e["reward_terms"][term] for e in episodes]))
            for term in reward.TERM_NAMES
        },
    }


def trace_dict(
    env: env_lib.QuadrupedEnv, result: Rollout, trace_index: int, meta: Mapping[str, Any]
) -> dict[str, Any]:
    """One episode's time series as flat named lists, all of one length (the episode's steps).

    Series: `TRACE_SERIES`, then controller/<joint> (the 8 controller outputs, rad, Eq. 3 order,
    sampled at the end of each control step), joint/<joint> (measured joint angles, rad),
    action/<i> (the filtered command in [−1, 1]) and, for the oscillator controller,
    parameter/<name> (A_k, A_h rad, T s, φ1, φ3 rad). Besides the series: "qpos", the positions
    from reset on (one row more than the series), and "env", the env config — enough to render
    the episode elsewhere (`render_trace`).
    """
    steps = int(result.stats.steps[trace_index])
    raw = {key: value[:steps] for key, value in result.trace.items()}
    qpos = np.concatenate([result.start_qpos[None], result.qpos[:steps]])
    series: dict[str, list[float]] = {name: raw[name].tolist() for name in TRACE_SERIES}
    for joint_index, joint in enumerate(constants.JOINTS):
        series[f"controller/{joint}"] = raw["controller"][:, joint_index].tolist()
    for joint_index, joint in enumerate(constants.JOINTS):
        series[f"joint/{joint}"] = raw["joint"][:, joint_index].tolist()
    for i in range(raw["action"].shape[1]):
        series[f"action/{i}"] = raw["action"][:, i].tolist()
    if "parameter" in raw:
        for i, name in enumerate(PARAMETER_NAMES):
            series[f"parameter/{name}"] = raw["parameter"][:, i].tolist()
    terrain = env.terrain
    return {
        "format": TRACE_FORMAT,
        "format_version": FORMAT_VERSION,
        **meta,
        "episode": trace_index,
        "terrain_x_knots": terrain.x_knots.tolist(),
        "terrain_heights": terrain.heights[0].tolist() if terrain.y_knots.size == 1 else None,
        "env": env.config.to_dict() | {"terrain": terrain.spec},
        "series": series,
        "qpos": qpos.tolist(),
    }


def render_trace(
    trace: Mapping[str, Any] | str | os.PathLike[str],
    path: str | os.PathLike[str],
    **options: Any,
) -> pathlib.Path:
    """Renders a saved trace (e.g. one written on a GPU machine) to an mp4, here.

    The env is rebuilt from the trace's env config, so its terrain must be a built-in name or a
    `sections:` spec (or registered in this process). Options: see `video.render_video`.

    Raises:
      ValueError: not a trace, or its terrain / env config cannot be rebuilt.
      video.VideoError: no headless OpenGL or no mp4 writer here.
    """
    if not isinstance(trace, Mapping):
        try:
            trace = json.loads(pathlib.Path(trace).read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as error:
            raise ValueError(f"cannot read trace {trace}: {error}") from None
    if trace.get("format") != TRACE_FORMAT or "qpos" not in trace or "env" not in trace:
        raise ValueError("not a quadcos trace with positions (qpos) and an env config")
    overrides = overrides_lib.flatten(trace["env"])
    terrain = overrides.pop("terrain")
    env = env_lib.make_env(terrain, **overrides)
    qpos = np.asarray(trace["qpos"], dtype=np.float64)
    return video.render_video(env.mj_model, qpos, path, fps=1.0 / env.dt, **options)


def evaluate(
    policy: str | Controller,
    terrain: terrain_lib.Terrain | str | None = None,
    *,
    num_envs: int = 64,
    seconds: float = 20.0,
    seed: int = 0,
    trace_episode: int = 0,
    env_overrides: Mapping[str, Any] | None = None,
    env: env_lib.QuadrupedEnv | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Evaluation:
    """Batched deterministic rollouts of `policy` (a --policy string or a Controller).

    Args:
      terrain: a Terrain or spec; default: the policy's training terrain (flat for fixed ones).
      num_envs: robots = episodes, all run at once.
      seconds: time limit of an episode, s (rounded up to whole control steps).
      seed: seed of the reset noise.
      trace_episode: the episode whose time series `trace` holds.
      env_overrides: env config overrides on top of the policy's.
      env: an env from `build_env(controller, ...)` to run in instead of building one (then
        `terrain` and `env_overrides` are not used).
      progress: called as progress(steps_done, num_steps) as the rollout advances.

    Raises:
      ValueError, FileNotFoundError: bad policy, terrain, overrides or sizes.
    """
    controller = resolve_controller(policy) if isinstance(policy, str) else policy
    if not (math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"seconds must be finite and > 0; got {seconds}")
    if env is None:
        env = build_env(controller, terrain, env_overrides)
    num_steps = math.ceil(seconds / env.dt - 1e-9)
    started = time.monotonic()
    result = rollout(
        env,
        controller,
        num_envs=num_envs,
        num_steps=num_steps,
        seed=seed,
        trace_index=trace_episode,
        progress=progress,
    )
    episodes = episode_values(result.stats, env.dt, num_steps)
    course = env.terrain.course_end_x is not None
    for episode in episodes:
        episode["success"] = episode["finished_course"] if course else not episode["fell"]
    setup = {
        "policy": controller.name,
        "policy_kind": controller.kind,
        "fixed_parameters": None
        if controller.fixed_parameters is None
        else dict(zip(PARAMETER_NAMES, map(float, controller.fixed_parameters))),
        "terrain": env.terrain.spec,
        "course_end_x": env.terrain.course_end_x,
        "num_envs": num_envs,
        "seconds": num_steps * env.dt,
        "num_steps": num_steps,
        "control_dt": env.dt,
        "seed": seed,
        "trace_episode": trace_episode,
        "env": env.config.to_dict() | {"terrain": env.terrain.spec},
        "wall_time_s": time.monotonic() - started,
        "versions": _versions(),
    }
    summary = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        **aggregate(episodes, result.stats),
        "setup": setup,
    }
    traced = episodes[trace_episode]
    meta = {
        "policy": controller.name,
        "terrain": env.terrain.spec,
        "course_end_x": env.terrain.course_end_x,
        "control_dt": env.dt,
        **{key: traced[key] for key in ("success", "fell", "finished_course")},
    }
    trace = trace_dict(env, result, trace_episode, meta)
    return Evaluation(
        summary=summary,
        episodes=episodes,
        trace=trace,
        qpos=np.asarray(trace["qpos"]),
        env=env,
    )


def _versions() -> dict[str, str]:
    from importlib import metadata

    versions = {}
    for package in ("quadcos", "jax", "mujoco", "mujoco-mjx", "brax"):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            pass
    return versions


# --- the best fixed parameters -------------------------------------------------------------------


def search_fixed(
    terrain: terrain_lib.Terrain | str = "flat",
    *,
    num_candidates: int = 256,
    robots_per_candidate: int = 4,
    rounds: int = 3,
    elite: int = 8,
    seconds: float = 20.0,
    seed: int = 0,
    top: int = 10,
    env_overrides: Mapping[str, Any] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Searches constant rhythm parameters (A_k, A_h, T, φ1, φ3) for the best fixed gait.

    Each round evaluates `num_candidates` parameter sets on `robots_per_candidate` robots each, all
    in one batch (the same compiled rollout every round). Round 1 draws candidates uniformly from
    the §3.3 ranges (`oscillator.parameter_bounds`), with `oscillator.FIXED_TROT` as candidate 0;
    each later round keeps the `elite` best so far and draws the rest around them (Gaussian, std
    10 % of each range in round 2, halved every round after). A candidate's score is its robots'
    mean episode reward (Eq. 13 summed over the episode) when none of them fell, else −inf: the
    ranking is the paper's reward among gaits with zero falls.

    Returns:
      {"format", "ranking": the `top` best candidates (parameters, `policy` spec for --policy,
      score, fall_rate, mean_forward_speed, mean_max_abs_yaw, mean_lateral_drift, ...), "setup"}.
    """
    if num_candidates < 1 or robots_per_candidate < 1 or rounds < 1:
        raise ValueError("num_candidates, robots_per_candidate and rounds must be >= 1")
    if not (math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"seconds must be finite and > 0; got {seconds}")
    controller = fixed_controller(oscillator.FIXED_TROT, name="search")
    env = build_env(controller, terrain, env_overrides)
    num_steps = math.ceil(seconds / env.dt - 1e-9)
    lower, upper = oscillator.parameter_bounds(env.config.period_min)
    rng = np.random.default_rng(seed)
    num_envs = num_candidates * robots_per_candidate
    evaluated: list[dict[str, Any]] = []
    started = time.monotonic()
    for round_index in range(rounds):
        if round_index == 0:
            candidates = rng.uniform(lower, upper, size=(num_candidates, 5))
            candidates[0] = np.asarray(oscillator.FIXED_TROT)
        else:
            ranked = sorted(evaluated, key=lambda c: c["score"], reverse=True)
            elites = np.array([c["parameters_array"] for c in ranked[: min(elite, num_candidates)]])
            std = 0.1 * (upper - lower) / 2 ** (round_index - 1)
            parents = elites[rng.integers(len(elites), size=num_candidates)]
            candidates = np.clip(parents + rng.normal(size=parents.shape) * std, lower, upper)
            candidates[: len(elites)] = elites
        per_robot = np.repeat(candidates, robots_per_candidate, axis=0).astype(np.float32)

        def round_progress(done: int, total: int, round_index: int = round_index) -> None:
            if progress is not None:
                progress(round_index * total + done, rounds * total)

        result = rollout(
            env,
            controller,
            num_envs=num_envs,
            num_steps=num_steps,
            seed=seed + round_index,
            act_params=per_robot,
            progress=round_progress,
        )
        episodes = episode_values(result.stats, env.dt, num_steps)
        for c, params in enumerate(candidates):
            group = episodes[c * robots_per_candidate : (c + 1) * robots_per_candidate]
            fall_rate = float(np.mean([e["fell"] for e in group]))
            mean_reward = float(np.mean([e["episode_reward"] for e in group]))
            evaluated.append(
                {
                    "round": round_index + 1,
                    "parameters": dict(zip(PARAMETER_NAMES, map(float, params))),
                    "parameters_array": params,
                    "policy": FIXED_PREFIX + ",".join(f"{float(p):.6g}" for p in params),
                    "score": mean_reward if fall_rate == 0.0 else -math.inf,
                    "mean_episode_reward": mean_reward,
                    "fall_rate": fall_rate,
                    "mean_forward_speed": float(np.mean([e["forward_speed"] for e in group])),
                    "mean_max_abs_yaw": float(np.mean([e["max_abs_yaw"] for e in group])),
                    "mean_max_abs_roll": float(np.mean([e["max_abs_roll"] for e in group])),
                    "mean_lateral_drift": float(np.mean([e["lateral_drift"] for e in group])),
                }
            )
    ranked = sorted(evaluated, key=lambda c: c["score"], reverse=True)
    ranking = [
        {key: value for key, value in c.items() if key != "parameters_array"}
        | {"score": c["score"] if math.isfinite(c["score"]) else None}
        for c in ranked[:top]
    ]
    return {
        "format": SEARCH_FORMAT,
        "format_version": FORMAT_VERSION,
        "ranking": ranking,
        "num_without_falls": sum(math.isfinite(c["score"]) for c in evaluated),
        "num_evaluated": len(evaluated),
        "setup": {
            "terrain": env.terrain.spec,
            "num_candidates": num_candidates,
            "robots_per_candidate": robots_per_candidate,
            "rounds": rounds,
            "elite": elite,
            "seconds": num_steps * env.dt,
            "seed": seed,
            "env": env.config.to_dict() | {"terrain": env.terrain.spec},
            "wall_time_s": time.monotonic() - started,
        },
    }


# --- files ---------------------------------------------------------------------------------------


def write_json(path: str | os.PathLike[str], content: Any) -> pathlib.Path:
    """Writes `content` as JSON, atomically; non-finite floats become null."""
    from quadcos.training.files import atomic_write_text

    path = pathlib.Path(path)
    atomic_write_text(path, json.dumps(_finite_json(content), indent=1, allow_nan=False) + "\n")
    return path


def _finite_json(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _finite_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_json(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


# --- CLI -----------------------------------------------------------------------------------------


class UsageError(ValueError):
    """A user error on the command line: reported as one line, exit status 2."""


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m quadcos.evaluate",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Env options: --env.KEY=VALUE (e.g. --env.fall_max_roll=1.0); see quadcos.env.default_config().",
    )
    parser.add_argument(
        "--policy", help="run or policy directory, fixed:trot or fixed:A_k,A_h,T,phi1,phi3"
    )
    parser.add_argument(
        "--terrain", help="terrain name or spec (default: the policy's training terrain; flat)"
    )
    parser.add_argument("--num_envs", type=int, default=64, help="episodes, all run at once")
    parser.add_argument("--seconds", type=float, default=20.0, help="time limit of an episode, s")
    parser.add_argument("--seed", type=int, default=0, help="seed of the reset noise")
    parser.add_argument("--out", help="evaluation (or search) JSON to write")
    parser.add_argument("--trace", help="JSON of one episode's time series to write")
    parser.add_argument("--trace_episode", type=int, default=0, help="which episode to trace")
    parser.add_argument("--video", help="mp4 of the traced episode (headless: EGL or OSMesa)")
    parser.add_argument("--video_size", default="640x360", help="WIDTHxHEIGHT in pixels")
    parser.add_argument(
        "--render",
        metavar="TRACE",
        help="render a saved --trace JSON to --video (e.g. a trace written on a GPU machine)",
    )
    parser.add_argument(
        "--search_fixed",
        action="store_true",
        help="search the best fixed rhythm parameters instead of evaluating --policy",
    )
    parser.add_argument("--num_candidates", type=int, default=256, help="search: per round")
    parser.add_argument("--robots_per_candidate", type=int, default=4, help="search")
    parser.add_argument("--rounds", type=int, default=3, help="search: rounds of refinement")
    parser.add_argument("--no_progress", action="store_true", help="no progress on stderr")
    return parser


def _raise_usage_error(message: str):
    raise UsageError(message)


def _parse_args(argv: Sequence[str]) -> tuple[argparse.Namespace, dict[str, Any]]:
    parser = _parser()
    parser.error = _raise_usage_error
    args, rest = parser.parse_known_args(argv)
    overrides = {}
    for item in rest:
        if not item.startswith("--env.") or "=" not in item:
            raise UsageError(
                f"unrecognised argument {item!r} (env options look like --env.KEY=VALUE)"
            )
        key, text = item[len("--env.") :].split("=", 1)
        try:
            overrides[key] = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            overrides[key] = text
    modes = [args.policy is not None, args.search_fixed, args.render is not None]
    if sum(modes) != 1:
        raise UsageError("give exactly one of --policy, --search_fixed and --render")
    if args.render is not None:
        if args.video is None or args.out or args.trace:
            raise UsageError("--render TRACE.json takes --video OUT.mp4 (and no --out, --trace)")
        if not pathlib.Path(args.render).is_file():
            raise UsageError(f"--render {args.render}: no such file")
    elif args.out is None:
        raise UsageError("--out is required")
    if args.search_fixed and (args.trace or args.video):
        raise UsageError("--trace and --video go with --policy, not --search_fixed")
    if args.num_envs < 1:
        raise UsageError(f"--num_envs must be >= 1; got {args.num_envs}")
    if not (math.isfinite(args.seconds) and args.seconds > 0):
        raise UsageError(f"--seconds must be > 0; got {args.seconds}")
    if not 0 <= args.trace_episode < args.num_envs:
        raise UsageError(
            f"--trace_episode must be in 0..{args.num_envs - 1}; got {args.trace_episode}"
        )
    width, x, height = args.video_size.partition("x")
    if not (x and width.isdigit() and height.isdigit()) or any(
        int(side) < 16 or int(side) % 2 for side in (width, height)
    ):
        raise UsageError(
            f"--video_size must be WIDTHxHEIGHT, each even and >= 16; got {args.video_size!r}"
        )
    args.video_size = (int(width), int(height))
    for flag, suffix in (("out", ".json"), ("trace", ".json"), ("video", ".mp4")):
        value = getattr(args, flag)
        if value is None:
            continue
        path = pathlib.Path(value)
        if path.suffix.lower() != suffix:
            raise UsageError(f"--{flag} must end in {suffix}; got {value}")
        if path.is_dir():
            raise UsageError(f"--{flag} {value} is a directory")
        parent = path.absolute().parent
        if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
            raise UsageError(f"--{flag} {value}: {parent} is not a writable directory")
    return args, overrides


class _Progress:
    """Steps done on stderr: one updating line on a terminal, else a line every 10 %."""

    def __init__(self, label: str, enabled: bool):
        self.label, self.enabled = label, enabled
        self.terminal = sys.stderr.isatty()
        self.started = time.monotonic()
        self.last_tenth = -1

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        line = f"{self.label}: {done}/{total} steps ({100 * done / total:.0f} %), {time.monotonic() - self.started:.0f} s"
        if self.terminal:
            print("\r" + line, end="\n" if done >= total else "", file=sys.stderr, flush=True)
        elif (tenth := 10 * done // total) > self.last_tenth:
            self.last_tenth = tenth
            print(line, file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args, overrides = _parse_args(argv)
        if args.render:
            width, height = args.video_size
            render_trace(args.render, args.video, width=width, height=height)
            print(f"{args.render} -> {args.video}")
            return 0
        if args.search_fixed:
            result = search_fixed(
                args.terrain or "flat",
                num_candidates=args.num_candidates,
                robots_per_candidate=args.robots_per_candidate,
                rounds=args.rounds,
                seconds=args.seconds,
                seed=args.seed,
                env_overrides=overrides,
                progress=_Progress("search", not args.no_progress),
            )
            write_json(args.out, result)
            best = result["ranking"][0]
            print(
                f"best: --policy={best['policy']} (score {best['score']}, fall rate {best['fall_rate']})"
            )
            return 0
        controller = resolve_controller(args.policy)
        env = build_env(controller, args.terrain, overrides)  # checks the terrain and sizes early
        if args.video:
            video.check_video_support()
        evaluation = evaluate(
            controller,
            num_envs=args.num_envs,
            seconds=args.seconds,
            seed=args.seed,
            trace_episode=args.trace_episode,
            env=env,
            progress=_Progress("evaluate", not args.no_progress),
        )
    except (ValueError, FileNotFoundError, video.VideoError) as error:
        _print_error(error)
        return 2
    write_json(args.out, evaluation.to_json())
    if args.trace:
        write_json(args.trace, evaluation.trace)
    try:
        if args.video:
            width, height = args.video_size
            evaluation.save_video(args.video, width=width, height=height)
    except video.VideoError as error:  # checked up front; seen only if rendering breaks midway
        _print_error(error)
        return 1
    summary = evaluation.summary
    print(
        f"{summary['num_episodes']} episodes on {summary['setup']['terrain']}: success"
        f" {summary['success_rate']:.3f}, falls {summary['fall_rate']:.3f}, speed"
        f" {summary['mean_forward_speed']:.3f} m/s -> {args.out}"
    )
    return 0


def _print_error(error: Exception) -> None:
    lines = (line.strip() for line in str(error).splitlines())
    print(f"quadcos.evaluate: error: {'; '.join(filter(None, lines))}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
