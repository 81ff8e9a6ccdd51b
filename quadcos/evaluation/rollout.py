"""The one batched deterministic rollout: robots run in parallel until they fall, finish the
course or reach the time limit, with running per-episode statistics (gait quality too:
`GaitEpisodeStats`) and one traced episode; robots of an env with velocity commands follow its
commands, or a schedule given to `rollout`."""

import dataclasses
import functools
import math
from collections.abc import Callable
from typing import Any

import flax.struct
import jax
import jax.numpy as jnp
import numpy as np

from quadcos import env as env_lib
from quadcos.env import episodes
from quadcos.env import tracking as tracking_lib
from quadcos.equations import oscillator, reward, slope
from quadcos.evaluation import sources
from quadcos.robot import constants

FORMAT_VERSION = 1  # of every file quadcos.evaluation writes
CHUNK_STEPS = 20  # control steps per compiled call: the progress granularity
GRAVITY = 9.81  # m/s²
CONTACT_CLEARANCE = 0.01  # m: a foot whose sphere is this close to the ground counts as in contact


@flax.struct.dataclass
class EpisodeStats:
    """Running per-episode statistics, each (n,); updated only while the episode runs."""

    running: jax.Array  # bool: not fallen, not finished, within the time limit
    lane: jax.Array  # int32: the lane (course) of a lane terrain; 0 otherwise
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


@flax.struct.dataclass
class GaitEpisodeStats(EpisodeStats):
    """EpisodeStats with running sums of gait quality, each (n,) unless said; what `rollout`
    returns. Steps count while the episode runs, as EpisodeStats's. Torques and feet are
    sampled at the end of each control step."""

    command: jax.Array  # (n, 2): v* (m/s), ω* (rad/s) the robot follows in its next step
    yaw: jax.Array  # rad, after the last step taken
    foot_xy: jax.Array  # (n, 4, 2) m: the feet after the last step taken
    foot_contact: jax.Array  # (n, 4) bool
    tracking: tracking_lib.Windows  # the command tracking's window sums
    slip_sum: jax.Array  # m/s: Σ over steps of the mean horizontal speed of the feet in contact
    slip_steps: jax.Array  # int32: steps with a foot in contact at both ends
    energy: jax.Array  # J: Σ |τ·q̇| dt over the leg joints
    path: jax.Array  # m: horizontal distance travelled by the torso
    peak_torque_ratio: jax.Array  # max over steps and joints of |τ| / torque limit
    commanded: bool = flax.struct.field(pytree_node=False, default=False)  # v*, ω* followed
    mass: float = flax.struct.field(pytree_node=False, default=math.nan)  # kg, the robot's


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
    drive = None
    if env.commanded:
        drive = env.drive_for(state.info["velocity_command"].driven()[index])
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
        "controller": (
            env.rhythm(command, phase, time_now, drive)
            if env.config.controller == "oscillator"
            else env.joint_targets(command, phase, time_now)
        ),
        "joint": qpos[env.layout.joint_qpos],
        "action": command,
        "qpos": qpos,
    }
    if env.config.controller == "oscillator":
        snapshot["parameter"] = jnp.stack(env.rhythm_parameters(command))
    if env.commanded:  # what the robot follows from this step on
        velocity = state.info["velocity_command"].velocity[index]
        snapshot |= {"speed_command": velocity[0], "yaw_rate_command": velocity[1]}
    return snapshot


def _initial_stats(state: Any, lanes: jax.Array) -> EpisodeStats:
    qpos = state.pipeline_state.qpos
    num_envs = lanes.shape[0]
    zeros = jnp.zeros(num_envs)
    return EpisodeStats(
        running=jnp.ones(num_envs, bool),
        lane=lanes,
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


def _feet(env: env_lib.QuadrupedEnv, data: Any) -> tuple[jax.Array, jax.Array]:
    """(n, 4, 2) m the feet's horizontal positions, (n, 4) whether each touches the ground.
    Batched data is indexed, not vmapped: MJX-Warp's Data has fields without a batch axis."""
    feet = data.geom_xpos[:, env.layout.foot_geoms]
    ground = env.terrain.height_at(feet[..., 0], feet[..., 1])
    touching = feet[..., 2] - env.layout.foot_radius - ground < CONTACT_CLEARANCE
    return feet[..., :2], touching


def _initial_gait_stats(
    env: env_lib.QuadrupedEnv, state: Any, stats: EpisodeStats
) -> GaitEpisodeStats:
    data = state.pipeline_state
    num_envs = stats.steps.shape[0]
    zeros = jnp.zeros(num_envs)
    feet, touching = _feet(env, data)
    command = (
        state.info["velocity_command"].velocity if env.commanded else jnp.zeros((num_envs, 2))
    )
    return GaitEpisodeStats(
        **{field.name: getattr(stats, field.name) for field in dataclasses.fields(EpisodeStats)},
        command=command,
        yaw=tracking_lib.pose(data.qpos)[2],
        foot_xy=feet,
        foot_contact=touching,
        tracking=tracking_lib.Windows.zeros(num_envs),
        slip_sum=zeros,
        slip_steps=jnp.zeros(num_envs, jnp.int32),
        energy=zeros,
        path=zeros,
        peak_torque_ratio=zeros,
        commanded=env.commanded,
        mass=env.layout.mass,
    )


def _update_gait_stats(
    env: env_lib.QuadrupedEnv,
    gait: GaitEpisodeStats,
    stats: EpisodeStats,
    state: Any,
    counts: jax.Array,
) -> GaitEpisodeStats:
    """`stats` (the step's EpisodeStats update) with the gait sums of `gait` advanced by one step
    for the episodes that were running before it (`counts`)."""
    data, dt, layout = state.pipeline_state, env.dt, env.layout

    def unless_blown_up(value):  # a step whose physics blew up leaves the episode's sums NaN
        return jnp.where(jnp.isfinite(state.reward), value, jnp.nan)

    x, y, yaw = tracking_lib.pose(data.qpos)
    step_x, step_y = x - gait.x, y - gait.y
    speed, yaw_rate = tracking_lib.velocity((gait.x, gait.y, gait.yaw), (x, y, yaw), dt)
    speed, yaw_rate = unless_blown_up(speed), unless_blown_up(yaw_rate)
    feet, touching = _feet(env, data)
    slipping = touching & gait.foot_contact
    foot_speed = jnp.linalg.norm(feet - gait.foot_xy, axis=-1) / dt
    slip = unless_blown_up((foot_speed * slipping).sum(-1) / jnp.maximum(slipping.sum(-1), 1))
    torque = data.qfrc_actuator[:, layout.joint_qvel]  # N m
    power = unless_blown_up(jnp.abs(torque * data.qvel[:, layout.joint_qvel]).sum(-1))
    ratio = unless_blown_up((jnp.abs(torque) / layout.torque_limit).max(-1))
    if not np.isfinite(np.asarray(layout.torque_limit)).any():
        ratio = jnp.full_like(ratio, jnp.nan)  # no limit to compare with

    def add(total, value):
        return jnp.where(counts, total + value, total)

    window = tracking_lib.window_steps(dt)
    windows = tracking_lib.advance(
        gait.tracking, speed, yaw_rate, gait.command, counts, stats.steps, window
    )
    return GaitEpisodeStats(
        **{field.name: getattr(stats, field.name) for field in dataclasses.fields(EpisodeStats)},
        command=state.info["velocity_command"].velocity if env.commanded else gait.command,
        yaw=yaw,
        foot_xy=feet,
        foot_contact=touching,
        tracking=windows,
        slip_sum=add(gait.slip_sum, slip),
        slip_steps=add(gait.slip_steps, slipping.any(-1).astype(jnp.int32)),
        energy=add(gait.energy, power * dt),
        path=add(gait.path, unless_blown_up(jnp.hypot(step_x, step_y))),
        peak_torque_ratio=jnp.where(
            counts, jnp.maximum(gait.peak_torque_ratio, ratio), gait.peak_torque_ratio
        ),
        commanded=gait.commanded,
        mass=gait.mass,
    )


def _update_stats(
    stats: EpisodeStats, state: Any, counts: jax.Array, lane_end_x: jax.Array
) -> EpisodeStats:
    """Adds one step to the episodes that were running before it (`counts`); `lane_end_x`:
    (lanes,) where each lane's course ends (inf: no course)."""
    qpos = state.pipeline_state.qpos
    body = slope.attitude(qpos[:, constants.QPOS_QUATERNION])
    # A step whose physics blew up (the env's NaN reward: non-finite or beyond
    # `env.layout.MAX_SPEED`) leaves the position NaN, so that the episode counts as diverged.
    blown_up = ~jnp.isfinite(state.reward)
    x = jnp.where(blown_up, jnp.nan, qpos[:, 0])
    y = jnp.where(blown_up, jnp.nan, qpos[:, 1])
    metrics = state.metrics

    def accumulate(old, new):
        return jnp.where(counts, new, old)

    fell = counts & (state.done > 0)
    at_end = x >= lane_end_x[stats.lane]
    finished = counts & ~fell & at_end
    slope_error = metrics["slope_estimate"] - metrics["slope_truth"]
    return EpisodeStats(
        running=stats.running & ~fell & ~finished,
        lane=stats.lane,
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
            stats.max_abs_roll, jnp.maximum(stats.max_abs_roll, metrics["abs_roll"])
        ),
        max_abs_yaw=accumulate(
            stats.max_abs_yaw, jnp.maximum(stats.max_abs_yaw, jnp.abs(body.yaw))
        ),
        max_abs_pitch_error=accumulate(
            stats.max_abs_pitch_error,
            jnp.maximum(stats.max_abs_pitch_error, metrics["abs_pitch_error"]),
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
    """jit(chunk of `chunk_steps` control steps for all robots); cached per env and source."""
    lane_end_x = jnp.asarray(env.terrain.lane_end_x, jnp.float32)

    def chunk(state, stats, act_params, first_step, num_steps, trace_index):
        def update(gait: GaitEpisodeStats, state: Any, offset: jax.Array) -> GaitEpisodeStats:
            counts = gait.running & (first_step + offset < num_steps)
            stats = _update_stats(gait, state, counts, lane_end_x)
            return _update_gait_stats(env, gait, stats, state, counts)

        return episodes.run_episodes(
            jax.vmap(env.step),
            lambda obs: act(act_params, obs),
            state,
            stats,
            update,
            chunk_steps,
            observe=lambda state: _snapshot(env, state, trace_index),
        )

    return jax.jit(chunk)


@functools.lru_cache(maxsize=16)
def _env_with_commands(env: env_lib.QuadrupedEnv, spec: str) -> env_lib.QuadrupedEnv:
    """`env.with_commands(spec)`, one per env and spec, so that its compiled programs are reused."""
    return env.with_commands(spec)


@functools.lru_cache(maxsize=16)
def _compiled_reset(env: env_lib.QuadrupedEnv) -> Callable:
    """jit((keys, lanes) -> the robots' first states); robot i runs on lane lanes[i]."""
    return jax.jit(jax.vmap(env.reset_on_lane))


def rollout(
    env: env_lib.QuadrupedEnv,
    source: sources.ActionSource,
    *,
    num_envs: int,
    num_steps: int,
    seed: int = 0,
    trace_index: int = 0,
    act_params: Any = None,
    progress: Callable[[int, int], None] | None = None,
    chunk_steps: int = CHUNK_STEPS,
    lanes: np.ndarray | None = None,
    commands: str | None = None,
    gaits: dict[str, np.ndarray] | None = None,
    keys: jax.Array | None = None,
) -> Rollout:
    """Runs `num_envs` robots for at most `num_steps` control steps each, deterministically;
    on a lane terrain, robot i on lane i mod num_lanes unless `lanes` says otherwise.

    Args:
      commands: a command spec ("random" or a schedule "v,ω@s;...",
        `quadcos.env.commands.parse_commands`) the robots follow instead of the env's own (an env
        with commands only: `QuadrupedEnv.with_commands`); None: the env's.
      act_params: overrides `source.params` (e.g. (num_envs, 5) fixed parameters, one row per
        robot, for a search).
      lanes: (num_envs,) the lane of each robot (a lane terrain's course; 0 elsewhere).
      gaits: each robot's gait maps ((num_envs, ...) each, `QuadrupedEnv.gait`'s keys) instead of
        the env's, as data (`GAIT_KEY`, as a trainer passes them): one program for every gait.
      keys: (num_envs, 2) each robot's episode key (its reset draws, commands, randomisation);
        default: `seed`'s, split.
      progress: called as progress(0, num_steps) once the inputs are checked, before anything
        compiles, then as progress(steps_done, num_steps) after each compiled chunk.
    """
    if num_envs < 1 or num_steps < 1:
        raise ValueError(f"num_envs and num_steps must be >= 1; got {num_envs}, {num_steps}")
    if not 0 <= trace_index < num_envs:
        raise ValueError(f"trace episode {trace_index} is not in 0..{num_envs - 1}")
    if commands is not None:
        env = _env_with_commands(env, commands)
    params = source.params if act_params is None else act_params
    if source.kind == "fixed":  # parameters -> the constant actions that command them here
        params = jnp.broadcast_to(jnp.asarray(params, jnp.float32), (num_envs, 5))
        params = env.action_for(oscillator.RhythmParameters(*jnp.moveaxis(params, -1, 0)))
    if lanes is None:
        lanes = np.arange(num_envs) % env.terrain.num_lanes  # evenly over lanes
    lanes = np.asarray(lanes)
    if lanes.shape != (num_envs,) or lanes.min() < 0 or lanes.max() >= env.terrain.num_lanes:
        raise ValueError(f"lanes must be {num_envs} lanes in 0..{env.terrain.num_lanes - 1}")
    lanes = jnp.asarray(lanes, jnp.int32)
    if progress is not None:
        progress(0, num_steps)
    chunk = _compiled_chunk(env, source.act, chunk_steps)
    if keys is None:
        keys = jax.random.split(jax.random.PRNGKey(seed), num_envs)
    state = _compiled_reset(env)(keys, lanes)
    if gaits is not None:
        batched = {name: jnp.asarray(value) for name, value in gaits.items()}
        if any(value.shape[:1] != (num_envs,) for value in batched.values()):
            raise ValueError(f"gaits must hold one row per robot ({num_envs})")
        state = state.replace(info={**state.info, env_lib.quadruped.GAIT_KEY: batched})
    start_qpos = np.asarray(state.pipeline_state.qpos[trace_index])
    stats = _initial_gait_stats(env, state, _initial_stats(state, lanes))
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

