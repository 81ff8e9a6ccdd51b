"""`evaluate`: batched deterministic rollouts of an action source in MJX -> an `Evaluation`
(aggregates, set-up, episodes, one trace), written as JSON with `write_json`. It is the "mjx"
engine of `quadcos.deploy.engines.evaluate`, whose "mujoco" engine returns an `Evaluation` too."""

import dataclasses
import json
import math
import os
import pathlib
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from quadcos import env as env_lib
from quadcos import terrain as terrain_lib
from quadcos._util import provenance
from quadcos.evaluation.metrics import aggregate, episode_values, per_course
from quadcos.evaluation.rollout import FORMAT_VERSION, rollout
from quadcos.evaluation.sources import PARAMETER_NAMES, ActionSource, PolicySpec, build_env
from quadcos.evaluation.traces import trace_dict
from quadcos.viz import video

FORMAT = "quadcos.evaluation"
_VERSIONED_PACKAGES = ("quadcos", "jax", "mujoco", "mujoco-mjx", "brax")


@dataclasses.dataclass
class Evaluation:
    """The result of `evaluate`.

    Attributes:
      summary: aggregates (see `aggregate`) and the set-up under "setup".
      episodes: one dict of values per episode.
      trace: the traced episode's series, cut where it ended (see `trace_dict`); None from the
        mujoco engine, which traces nothing.
      qpos: (steps, nq) positions of the traced episode, from reset on, for `render_video`.
      env: the MJX env it ran in (None from the mujoco engine).
    """

    summary: dict[str, Any]
    episodes: list[dict[str, Any]]
    trace: dict[str, Any] | None = None
    qpos: np.ndarray | None = None
    env: env_lib.QuadrupedEnv | None = None

    @property
    def success(self) -> float:
        """Fraction of episodes that succeeded (survived; on a course, also crossed it)."""
        return self.summary["success_rate"]

    @property
    def falls(self) -> float:
        """Fraction of episodes that ended in a fall."""
        return self.summary["fall_rate"]

    @property
    def speed(self) -> float:
        """Mean forward speed over the episodes, m/s."""
        return self.summary["mean_forward_speed"]

    def to_json(self) -> dict[str, Any]:
        """The evaluation file's content: aggregates at the top, then setup and episodes."""
        return {**self.summary, "episodes": self.episodes}

    def save_video(self, path: str | os.PathLike[str], **options: Any) -> pathlib.Path:
        """The traced episode as an mp4 at the control rate; options: see `video.render_video`.

        Raises:
          ValueError: no traced episode (the mujoco engine's evaluations).
          video.VideoError: no headless OpenGL or no mp4 writer here.
        """
        if self.env is None or self.qpos is None:
            raise ValueError("this evaluation traced no episode (the mujoco engine traces none)")
        return video.render_video(
            self.env.mj_model, self.qpos, path, fps=1.0 / self.env.dt, **options
        )


def evaluate(
    policy: str | PolicySpec | ActionSource,
    terrain: terrain_lib.Terrain | str | None = None,
    *,
    num_envs: int = 64,
    seconds: float = 20.0,
    seed: int = 0,
    trace_episode: int = 0,
    env_overrides: Mapping[str, Any] | None = None,
    env: env_lib.QuadrupedEnv | None = None,
    progress: Callable[[int, int], None] | None = None,
    commands: str | None = None,
) -> Evaluation:
    """Batched deterministic rollouts of `policy` (a --policy string, a `PolicySpec` or an
    `ActionSource`) in MJX.

    Args:
      terrain: a Terrain or spec; default: the policy's training terrain (flat for fixed ones).
      num_envs: robots = episodes, all run at once.
      seconds: time limit of an episode, s (rounded up to whole control steps).
      seed: seed of the reset noise.
      trace_episode: the episode whose time series `trace` holds.
      env_overrides: env config overrides on top of the policy's.
      env: an env from `build_env(source, ...)` to run in instead of building one (then
        `terrain` and `env_overrides` are not used).
      progress: called as progress(steps_done, num_steps) as the rollout advances.
      commands: velocity commands the robots follow ("random" or a schedule "v,ω@s;...",
        `quadcos.env.commands.parse_commands`) instead of the env's own; a policy trained with
        commands only. None: the env's.

    Raises:
      ValueError, FileNotFoundError: bad policy, terrain, overrides or sizes.
    """
    spec = PolicySpec.parse(policy) if isinstance(policy, str) else policy
    source = spec.action_source() if isinstance(spec, PolicySpec) else spec
    if not (math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"seconds must be finite and > 0; got {seconds}")
    if env is None:
        env = build_env(source, terrain, env_overrides)
    num_steps = math.ceil(seconds / env.dt - 1e-9)
    started = time.monotonic()
    result = rollout(
        env,
        source,
        num_envs=num_envs,
        num_steps=num_steps,
        seed=seed,
        trace_index=trace_episode,
        progress=progress,
        commands=commands,
    )
    episodes = episode_values(result.stats, env.dt, num_steps)
    has_course = np.isfinite(env.terrain.lane_end_x)
    for episode in episodes:
        course = has_course[episode["lane"]]
        episode["success"] = episode["finished_course"] if course else not episode["fell"]
    setup = _setup(source, env, num_envs, num_steps, seed, trace_episode, commands)
    setup["wall_time_s"] = time.monotonic() - started
    summary = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        **aggregate(episodes, result.stats),
        **(
            per_course(episodes, result.stats, [lane.name for lane in env.terrain.lanes])
            if env.terrain.lanes
            else {}
        ),
        "setup": setup,
    }
    traced = episodes[trace_episode]
    meta = {
        "policy": source.name,
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


def _setup(
    source: ActionSource,
    env: env_lib.QuadrupedEnv,
    num_envs: int,
    num_steps: int,
    seed: int,
    trace_episode: int,
    commands: str | None,
) -> dict[str, Any]:
    """An evaluation's "setup": what ran (policy, robot, terrain, commands, env, versions)."""
    return {
        "policy": source.name,
        "policy_kind": source.kind,
        "policy_env_steps": source.env_steps,
        "fixed_parameters": None
        if source.fixed_parameters is None
        else dict(zip(PARAMETER_NAMES, map(float, source.fixed_parameters))),
        "robot": env.robot.provenance(),
        "terrain": env.terrain.spec,
        "course_end_x": env.terrain.course_end_x,
        "num_envs": num_envs,
        "seconds": num_steps * env.dt,
        "num_steps": num_steps,
        "control_dt": env.dt,
        "impl": env.impl,  # the MJX physics that ran: `env.impl` "auto" resolved
        "seed": seed,
        "trace_episode": trace_episode,
        "commands": commands if commands is not None else env.config.commands.spec,
        "env": env.config.to_dict() | {"terrain": env.terrain.spec},
        "versions": provenance.versions(_VERSIONED_PACKAGES),
    }


def course_table(summary: Mapping[str, Any]) -> str:
    """The per-course table of a lane-terrain evaluation (markdown), then the overall figures."""
    columns = (
        ("episodes", "num_episodes", "d"),
        ("success", "success_rate", ".3f"),
        ("falls", "fall_rate", ".3f"),
        ("speed (m/s)", "mean_forward_speed", ".3f"),
        ("max pitch err (rad)", "mean_max_abs_pitch_error", ".3f"),
        ("max yaw (rad)", "mean_max_abs_yaw", ".3f"),
        ("max roll (rad)", "mean_max_abs_roll", ".3f"),
        ("slope est. RMS (rad)", "slope_error_rms", ".3f"),
    )
    lines = [
        "| course | " + " | ".join(title for title, _, _ in columns) + " |",
        "|---|" + "---:|" * len(columns),
    ]
    for name, course in summary["courses"].items():
        cells = (
            "—" if course[key] is None else format(course[key], spec) for _, key, spec in columns
        )
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    walked, lanes = len(summary["courses"]), summary.get("lanes", len(summary["courses"]))
    of = f" of {lanes} (--num_envs={lanes} or more walks each)" if walked < lanes else ""
    lines.append(
        f"courses: {walked}{of}, mean success"
        f" {summary['mean_course_success_rate']:.3f}, worst {summary['worst_course']}"
        f" {summary['worst_course_success_rate']:.3f}"
    )
    return "\n".join(lines)


def write_json(path: str | os.PathLike[str], content: Any) -> pathlib.Path:
    """Writes `content` as JSON, atomically; non-finite floats become null."""
    from quadcos._util.files import atomic_write_text

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

