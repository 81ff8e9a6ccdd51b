"""The paper's figures from evaluation traces (`quadcos.evaluate --trace`) and training metrics.

Each function returns a matplotlib `Figure` (built without pyplot, so no global state and no
display needed: saving uses Agg) and, given `path`, also writes it as a PNG.

| paper | what | function |
|---|---|---|
| Fig. 7 | reward during training, mean ± CI across seeds | `plot_learning_curves` |
| Figs. 8, 12, 15, 17 | centre-of-gravity x / y / z against time | `plot_cog` |
| Figs. 9, 13, 18 | pitch, yaw, roll and the expected pitch (the slope) | `plot_attitude` |
| Figs. 14, 19 | the eight rhythm-controller outputs | `plot_controller` |
| — | the five rhythm parameters the policy sets | `plot_parameters` |
| Figs. 10, 16 | a course's ground profile | `plot_course` |
| — | SAC's training evaluations against the step-0 gait, the critic's loss | `plot_against_gait` |

Axes: quadcos walks along +x, the paper along its Y; labels say "forward (x)" and "lateral (y)".
"""

import io
import json
import math
import os
import pathlib
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib import ticker
from matplotlib.figure import Figure

from quadcos.robot import constants

TraceLike = Mapping[str, Any] | str | os.PathLike[str]
_LEG_COLOURS = {"hip": "tab:blue", "knee": "tab:red"}  # Fig. 3: blue hip, red knee
_LINE_STYLES = ("-", "--", ":", "-.")


def load_trace(trace: TraceLike) -> dict[str, Any]:
    """A trace dict from a `--trace` JSON path, a dict, or an `Evaluation` (its `.trace`)."""
    if hasattr(trace, "trace") and isinstance(trace.trace, Mapping):
        return dict(trace.trace)
    if isinstance(trace, Mapping):
        return dict(trace)
    content = json.loads(pathlib.Path(trace).read_text(encoding="utf-8"))
    if "series" not in content:
        raise ValueError(f"{trace} is not a quadcos trace (no 'series')")
    return content


def load_metrics(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The rows of a run's metrics.jsonl (the file or its run directory)."""
    path = pathlib.Path(path)
    if path.is_dir():
        path = path / "metrics.jsonl"
    rows = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.strip():
            rows.append(json.loads(line))
    return rows


def _series(trace: Mapping[str, Any], name: str) -> np.ndarray:
    return np.asarray(trace["series"][name], dtype=float)


def save(figure: Figure, path: str | os.PathLike[str], dpi: int = 120) -> None:
    """Writes `figure` to `path`; a .png in 32 colours (a plot has few: a fraction of the bytes
    of matplotlib's RGBA, the same picture), any other suffix as matplotlib writes it."""
    if pathlib.Path(path).suffix.lower() != ".png":
        figure.savefig(path, dpi=dpi)
        return
    from PIL import Image  # matplotlib's own dependency

    buffer = io.BytesIO()
    figure.savefig(buffer, dpi=dpi, format="png")
    buffer.seek(0)
    Image.open(buffer).convert("RGB").quantize(32).save(path, optimize=True)


def _finish(figure: Figure, path: str | os.PathLike[str] | None) -> Figure:
    figure.tight_layout()
    if path is not None:
        save(figure, path)
    return figure


def _mark_events(axes, trace: Mapping[str, Any]) -> None:
    """A dotted line where the episode ended in a fall."""
    time = _series(trace, "time")
    if trace.get("fell") and time.size:
        for ax in np.ravel(axes):
            ax.axvline(time[-1], color="black", linestyle=":", linewidth=1.0)


def _section_edges(trace: Mapping[str, Any]) -> list[float]:
    """x of the kinks of a course profile between the spawn point and the course end."""
    knots = trace.get("terrain_x_knots") or []
    heights = trace.get("terrain_heights")
    if heights is None or len(knots) < 3:
        return []
    knots, heights = np.asarray(knots), np.asarray(heights)
    gradients = np.diff(heights) / np.diff(knots)
    return [float(x) for x, g0, g1 in zip(knots[1:-1], gradients[:-1], gradients[1:]) if g0 != g1]


def plot_cog(
    trace: TraceLike,
    *,
    title: str | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Centre-of-gravity (torso centre) position against time: Figs. 8, 12, 15 and 17.

    Forward x (the paper's Y), lateral y (its X, "yaw direction") and height z, one panel each.
    On a course, dashed lines mark the section edges in x; a dotted line marks a fall.
    """
    trace = load_trace(trace)
    time = _series(trace, "time")
    figure = Figure(figsize=(7, 6))
    axes = figure.subplots(3, 1, sharex=True)
    labels = (
        ("cog_x", "forward x (m)", "tab:red"),
        ("cog_y", "lateral y (m)", "tab:blue"),
        ("cog_z", "height z (m)", "tab:green"),
    )
    for ax, (name, label, colour) in zip(axes, labels):
        ax.plot(time, _series(trace, name), color=colour)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    for edge in _section_edges(trace):
        axes[0].axhline(edge, color="grey", linestyle="--", linewidth=0.8)
    if trace.get("course_end_x") is not None:
        axes[0].axhline(trace["course_end_x"], color="black", linestyle="--", linewidth=1.0)
    _mark_events(axes, trace)
    axes[-1].set_xlabel("time (s)")
    axes[0].set_title(title or f"centre of gravity — {trace.get('terrain', '')}")
    return _finish(figure, path)


def plot_attitude(
    traces: TraceLike | Mapping[str, TraceLike],
    *,
    title: str | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Pitch, yaw, roll and the expected pitch (the ground slope) against time: Figs. 9, 13, 18.

    `traces` is one trace or {label: trace}; several are drawn with solid, dashed, ... lines, as
    Fig. 9 compares the full reward r (solid) with r_xy (dashed).
    """
    if isinstance(traces, Mapping) and "series" not in traces:
        labelled = {label: load_trace(trace) for label, trace in traces.items()}
    else:
        labelled = {"": load_trace(traces)}
    figure = Figure(figsize=(8, 4.5))
    ax = figure.subplots()
    colours = {"pitch": "tab:blue", "yaw": "tab:red", "roll": "tab:green"}
    for index, (label, trace) in enumerate(labelled.items()):
        style = _LINE_STYLES[index % len(_LINE_STYLES)]
        time = _series(trace, "time")
        for name, colour in colours.items():
            ax.plot(
                time,
                _series(trace, name),
                color=colour,
                linestyle=style,
                label=f"{name} {label}".strip(),
            )
        if index == 0:
            ax.plot(
                time,
                _series(trace, "expected_pitch"),
                color="tab:orange",
                linestyle="--",
                label="expected pitch (slope)",
            )
        _mark_events(ax, trace)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("angle (rad)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small", ncol=2)
    ax.set_title(title or "body attitude")
    return _finish(figure, path)


def plot_controller(
    trace: TraceLike,
    *,
    window: tuple[float, float] | None = None,
    measured: bool = False,
    title: str | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """The eight rhythm-controller outputs (joint targets, rad) against time: Figs. 14 and 19.

    One panel per leg (LF, RF, LB, RB), hip in blue and knee in red as in Fig. 3. `window`
    (t0, t1) in s zooms in; `measured` adds the measured joint angles as thin lines.
    """
    trace = load_trace(trace)
    time = _series(trace, "time")
    keep = np.ones_like(time, bool) if window is None else (time >= window[0]) & (time <= window[1])
    figure = Figure(figsize=(8, 7))
    axes = figure.subplots(len(constants.LEGS), 1, sharex=True, sharey=True)
    for ax, leg in zip(axes, constants.LEGS):
        for joint, colour in _LEG_COLOURS.items():
            name = f"{leg}_{joint}"
            ax.plot(
                time[keep], _series(trace, f"controller/{name}")[keep], color=colour, label=joint
            )
            if measured:
                ax.plot(
                    time[keep],
                    _series(trace, f"joint/{name}")[keep],
                    color=colour,
                    linewidth=0.6,
                    alpha=0.6,
                )
        ax.set_ylabel(f"{leg} (rad)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize="small", loc="upper right")
    axes[-1].set_xlabel("time (s)")
    axes[0].set_title(title or "rhythm controller outputs")
    return _finish(figure, path)


def plot_parameters(
    trace: TraceLike,
    *,
    title: str | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """The rhythm parameters a = (A_k, A_h, T, φ1, φ3) in force (after the command filter)."""
    trace = load_trace(trace)
    time = _series(trace, "time")
    names = (
        ("amplitude_knee", "A_k (rad)"),
        ("amplitude_hip", "A_h (rad)"),
        ("period", "T (s)"),
        ("phi1", "φ1 (rad)"),
        ("phi3", "φ3 (rad)"),
    )
    if f"parameter/{names[0][0]}" not in trace["series"]:
        raise ValueError("this trace has no rhythm parameters (joint controller)")
    figure = Figure(figsize=(7, 8))
    axes = figure.subplots(len(names), 1, sharex=True)
    for ax, (name, label) in zip(axes, names):
        ax.plot(time, _series(trace, f"parameter/{name}"), color="tab:purple")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    axes[0].set_title(title or "rhythm parameters")
    return _finish(figure, path)


def learning_curve(
    runs: Sequence[str | os.PathLike[str] | Sequence[Mapping[str, Any]]],
    metric: str = "eval/episode_reward",
    *,
    points: int = 100,
    confidence: float = 0.95,
) -> dict[str, np.ndarray]:
    """Mean and confidence band of `metric` across runs (seeds), on a common step grid.

    Each run's rows (a run directory, a metrics.jsonl, or the rows themselves) that hold `metric`
    are interpolated linearly onto `points` steps spanning the range all runs cover. The band is
    mean ± t_{(1+confidence)/2, n−1} · sd / √n (Student's t; zero width for one run).

    Returns:
      {"step": (points,), "mean": (points,), "low": (points,), "high": (points,), "runs": n}.

    Raises:
      ValueError: no runs, or a run without `metric`.
    """
    from scipy import stats

    if not runs:
        raise ValueError("no runs given")
    curves = []
    for run in runs:
        rows = load_metrics(run) if isinstance(run, (str, os.PathLike)) else list(run)
        pairs = [(row["step"], row[metric]) for row in rows if row.get(metric) is not None]
        if not pairs:
            raise ValueError(f"run {run} has no {metric!r}")
        steps, values = np.asarray(pairs, dtype=float).T
        curves.append((steps, values))
    start = max(steps[0] for steps, _ in curves)
    stop = min(steps[-1] for steps, _ in curves)
    grid = np.linspace(start, stop, points) if stop > start else np.array([start])
    values = np.stack([np.interp(grid, steps, ys) for steps, ys in curves])
    mean = values.mean(axis=0)
    n = len(curves)
    if n > 1:
        half = stats.t.ppf((1 + confidence) / 2, n - 1) * values.std(axis=0, ddof=1) / math.sqrt(n)
    else:
        half = np.zeros_like(mean)
    return {"step": grid, "mean": mean, "low": mean - half, "high": mean + half, "runs": n}


def plot_learning_curves(
    runs: Mapping[str, Sequence[Any]] | Sequence[Any],
    metric: str = "eval/episode_reward",
    *,
    confidence: float = 0.95,
    title: str | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Fig. 7: `metric` against env steps, mean ± confidence band across seeds.

    `runs` is a list of runs (seeds of one configuration) or {label: list of runs}; a run is a run
    directory, a metrics.jsonl path or its rows. See `learning_curve`.
    """
    groups = dict(runs) if isinstance(runs, Mapping) else {"": list(runs)}
    figure = Figure(figsize=(7, 4.5))
    ax = figure.subplots()
    for label, group in groups.items():
        curve = learning_curve(group, metric, confidence=confidence)
        text = f"{label} (n={curve['runs']})".strip() if label else f"n={curve['runs']}"
        (line,) = ax.plot(curve["step"], curve["mean"], label=text)
        if curve["runs"] > 1:
            ax.fill_between(
                curve["step"],
                curve["low"],
                curve["high"],
                color=line.get_color(),
                alpha=0.25,
                linewidth=0,
            )
    ax.set_xlabel("env steps")
    ax.set_ylabel(metric)
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    ax.set_title(title or f"{metric}: mean ± {confidence:.0%} CI across seeds")
    return _finish(figure, path)


def plot_course(
    terrain: Any,
    *,
    x_range: tuple[float, float] | None = None,
    title: str | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """A terrain's ground profile along +x at y = 0 (Figs. 10 and 16), with the slope in degrees.

    `terrain` is a `quadcos.terrain.Terrain`; `x_range` defaults to its grid (−1..8 m for flat).
    The spawn point and, on a course, the course end are marked.
    """
    x_knots = np.asarray(terrain.x_knots)
    low, high = x_range or ((-1.0, 8.0) if terrain.is_flat else (x_knots[0], x_knots[-1]))
    x = np.linspace(low, high, 500)
    height = np.asarray(terrain.height_at(x, np.zeros_like(x)))
    slope_deg = np.degrees(np.asarray(terrain.slope_at(x, np.zeros_like(x))))
    figure = Figure(figsize=(8, 3.5))
    ax = figure.subplots()
    ax.fill_between(x, height.min() - 0.2, height, color="khaki")
    ax.plot(x, height, color="olive")
    ax.axvline(terrain.spawn_x, color="tab:blue", linestyle=":", label="spawn")
    if terrain.course_end_x is not None:
        ax.axvline(terrain.course_end_x, color="black", linestyle="--", label="course end")
    ax.set_xlabel("forward x (m)")
    ax.set_ylabel("height (m)")
    slope_axis = ax.twinx()
    slope_axis.plot(x, slope_deg, color="grey", linewidth=0.8)
    slope_axis.set_ylabel("slope (°)", color="grey")
    ax.legend(fontsize="small", loc="upper left")
    ax.set_title(title or f"terrain {terrain.name}")
    return _finish(figure, path)


def plot_command_tracking(
    traces: Mapping[str, TraceLike],
    *,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Commanded against achieved velocity, one column per {label: trace} of a commanded policy:
    forward speed against v* (m/s) above, yaw rate (the unwrapped yaw's rate) against ω* (rad/s)
    below."""
    labelled = {label: load_trace(trace) for label, trace in traces.items()}
    figure = Figure(figsize=(4.5 * len(labelled), 5.5))
    axes = figure.subplots(2, len(labelled), squeeze=False, sharex=True)
    for column, (label, trace) in enumerate(labelled.items()):
        if "speed_command" not in trace["series"]:
            raise ValueError(f"trace {label!r} has no velocity command: not a commanded policy")
        time = _series(trace, "time")
        yaw_rate = np.gradient(np.unwrap(_series(trace, "yaw")), time)
        rows = (
            ("forward speed (m/s)", _series(trace, "forward_speed"), "speed_command"),
            ("yaw rate (rad/s)", yaw_rate, "yaw_rate_command"),
        )
        for row, (name, achieved, command) in enumerate(rows):
            ax = axes[row, column]
            ax.plot(time, achieved, color="tab:blue", label="achieved")
            ax.plot(time, _series(trace, command), color="black", linestyle="--", label="command")
            ax.set_ylabel(name)
            ax.grid(alpha=0.3)
        axes[0, column].set_title(label)
        axes[-1, column].set_xlabel("time (s)")
    axes[0, 0].legend(fontsize="small")
    return _finish(figure, path)


def plot_against_gait(
    runs: Mapping[str, Sequence[Mapping[str, Any]]],
    *,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """SAC against the gait it starts from, {label: a run's training evaluations} (rows with
    `env_steps` and, where measured, `to_step0`: the worst cell's tracking RMS over step 0's, and
    `critic_loss`): the ratio above (below 1 beats the gait in every cell), the critic's loss
    below, both against env steps."""
    figure = Figure(figsize=(7, 6))
    ratio_ax, critic_ax = figure.subplots(2, 1, sharex=True)
    for index, (label, rows) in enumerate(runs.items()):
        line_style = _LINE_STYLES[index // 10 % len(_LINE_STYLES)]  # 10 colours, then a new style
        style = dict(label=label, color=f"C{index % 10}", linestyle=line_style, marker=".")
        for ax, key in ((ratio_ax, "to_step0"), (critic_ax, "critic_loss")):
            points = [(row["env_steps"] / 1e6, row[key]) for row in rows if key in row]
            if points:
                ax.plot(*zip(*points), **style)
    ratio_ax.axhline(1.0, color="black", linewidth=1, label="step 0's gait")
    ratio_ax.set_yscale("log")  # a ratio: 2x worse as far from 1 as 2x better
    ratio_ax.yaxis.set_major_locator(ticker.FixedLocator([0.5, 0.75, 1, 1.5, 2, 3, 4, 6, 8]))
    ratio_ax.yaxis.set_major_formatter(ticker.FormatStrFormatter("%g"))
    ratio_ax.yaxis.set_minor_locator(ticker.NullLocator())
    ratio_ax.set_ylabel("worst cell's RMS / step 0's")
    critic_ax.set_ylabel("critic loss")
    critic_ax.set_xlabel("env steps (M)")
    for ax in (ratio_ax, critic_ax):
        ax.grid(alpha=0.3)
    ratio_ax.legend(fontsize="x-small", loc="upper right")
    return _finish(figure, path)
