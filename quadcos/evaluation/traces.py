"""One episode's time series as JSON (`--trace`), and rendering a saved one to video."""

import json
import os
import pathlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from quadcos import env as env_lib
from quadcos._util import overrides as overrides_lib
from quadcos.evaluation.rollout import FORMAT_VERSION, Rollout
from quadcos.evaluation.sources import PARAMETER_NAMES
from quadcos.robot import constants
from quadcos.viz import video

TRACE_FORMAT = "quadcos.trace"
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
# Series of an env with velocity commands only: the command followed from each step on.
COMMAND_SERIES = (
    "speed_command",  # m/s, v*
    "yaw_rate_command",  # rad/s, ω*
)


def trace_dict(
    env: env_lib.QuadrupedEnv, result: Rollout, trace_index: int, meta: Mapping[str, Any]
) -> dict[str, Any]:
    """One episode's time series as flat named lists, all of one length (the episode's steps).

    Series: `TRACE_SERIES` (and `COMMAND_SERIES` with velocity commands), then controller/<name> (the 8 oscillator outputs, rad, Eq. 3 order, named LF_hip ... RB_knee;
    the joint controller's targets by joint name;
    sampled at the end of each control step), joint/<joint> (measured joint angles, rad, by the robot's joint names),
    action/<i> (the filtered command in [−1, 1]) and, for the oscillator controller,
    parameter/<name> (A_k, A_h rad, T s, φ1, φ3 rad). Besides the series: "qpos", the positions
    from reset on (one row more than the series), and "env", the env config — enough to render
    the episode elsewhere (`render_trace`).
    """
    steps = int(result.stats.steps[trace_index])
    raw = {key: value[:steps] for key, value in result.trace.items()}
    qpos = np.concatenate([result.start_qpos[None], result.qpos[:steps]])
    names = TRACE_SERIES + (COMMAND_SERIES if "speed_command" in raw else ())
    series: dict[str, list[float]] = {name: raw[name].tolist() for name in names}
    joints = env.robot.description.joint_names
    # The oscillator's eight outputs carry the paper's names (LF_hip, ..., RB_knee) on any robot.
    channels = constants.JOINTS if env.config.controller == "oscillator" else joints
    for index, name in enumerate(channels):
        series[f"controller/{name}"] = raw["controller"][:, index].tolist()
    for index, name in enumerate(joints):
        series[f"joint/{name}"] = raw["joint"][:, index].tolist()
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
    where = "the trace"
    if not isinstance(trace, Mapping):
        where = str(trace)
        try:
            trace = json.loads(pathlib.Path(trace).read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as error:
            raise ValueError(f"cannot read trace {trace}: {error}") from None
    if trace.get("format") != TRACE_FORMAT or "qpos" not in trace or "env" not in trace:
        raise ValueError(f"{where} is not a quadcos trace with positions (qpos) and an env config")
    overrides = overrides_lib.flatten(trace["env"])
    terrain = overrides.pop("terrain")
    env = env_lib.make_env(terrain, **overrides)
    qpos = np.asarray(trace["qpos"], dtype=np.float64)
    return video.render_video(env.mj_model, qpos, path, fps=1.0 / env.dt, **options)

