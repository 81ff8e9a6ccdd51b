"""Terrains built from a profile: `flat`, `sections` (the paper's courses), `heightfield`.

A `Terrain` (`quadcos.terrain.ground`) is an immutable description of the ground. On the
host it adds the ground to a robot's `mujoco.MjSpec` (`Terrain.attach`); inside the env its
`height_at` / `slope_at` are pure `jax.numpy` functions giving the ground-truth height and pitch.

World frame (MuJoCo): +x forward (the robot spawns at x = `spawn_x` = 0, y = 0 and walks along
+x), +y left, +z up; the paper's forward axis is its y. Slope angles are radians in code (> 0
uphill along +x) and degrees only in user-facing specs (`sections:ANGLE_DEG@LENGTH_M,...`).

Terrains of the paper (§4), registered by name: "flat"; "slope5" (Fig. 10: 5° up, 0°, 5° down,
3 m each); "s4" (Fig. 16, the unseen course S-4: 5°, 0°, 9°, 0° of 1.4, 1.4, 1.2, 1.4 m).
"""

import decimal
import itertools
import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np

from quadcos.terrain.ground import (  # noqa: F401 -- part of this module's API
    _MAX_HFIELD_CELLS,
    FLOOR_GEOM,
    FLOOR_HFIELD,
    GROUND_CONDIM,
    GROUND_FRICTION,
    Lane,
    Terrain,
    _vertex_count,
)

_BACK_RUN = 2.0  # m of flat ground behind the spawn point of a sections course
_MAX_COURSE_LENGTH = 200.0  # m
_MIN_SECTION_LENGTH = 1e-3  # m
_MAX_SECTION_ANGLE = 45.0  # deg
_SECTIONS_DEFAULTS = {"lead_in": 2.0, "run_out": 3.0, "resolution": 0.05}
_SECTIONS_PREFIX = "sections:"


class Section(NamedTuple):
    """One straight section of a course, in the order of the CLI's `sections:ANGLE@LENGTH`."""

    angle_deg: float  # > 0 uphill along +x
    length_m: float


def _format_number(value: float) -> str:
    """The shortest string that parses back to the same float, without a trailing '.0'."""
    text = repr(float(value))
    return text.removesuffix(".0")


def _decimal(value: float) -> decimal.Decimal:
    """The decimal number that `value`'s shortest repr writes."""
    return decimal.Decimal(repr(value))


def _finite(label: str, value: object) -> float:
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{label} must be a number, got {value!r}") from None
    except OverflowError:  # an int beyond float's range
        raise ValueError(
            f"{label} must be finite, got an integer of {len(str(value))} digits"
        ) from None
    if not math.isfinite(number):
        raise ValueError(f"{label} must be finite, got {number}")
    return number


def _finite_pair(label: str, pair: Sequence[float]) -> tuple[float, float]:
    try:
        low, high = pair
    except (TypeError, ValueError):
        raise ValueError(f"{label} must be a (min, max) pair, got {pair!r}") from None
    return _finite(f"{label}[0]", low), _finite(f"{label}[1]", high)


def flat() -> Terrain:
    """Level ground at z = 0 everywhere, unbounded."""
    return Terrain(
        name="flat",
        spec="flat",
        x_knots=np.array([-1.0, 1.0]),
        y_knots=np.array([0.0]),
        heights=np.zeros((1, 2)),
    )


def sections(
    segments: Sequence[Section],
    *,
    lead_in: float = _SECTIONS_DEFAULTS["lead_in"],
    run_out: float = _SECTIONS_DEFAULTS["run_out"],
    resolution: float = _SECTIONS_DEFAULTS["resolution"],
    name: str | None = None,
) -> Terrain:
    """A course of straight sections along +x, constant across y.

    The ground is flat at height 0 behind the spawn point (x = 0) and for `lead_in` m in front of
    it, then follows the sections, then stays flat at the final height for `run_out` m. The MuJoCo
    heightfield spans x from -2 m to `course_end_x + run_out` and y from -3 to 3 m.

    Args:
      segments: a `Section(angle_deg, length_m)` per section, in order; angle > 0 is uphill
        along +x. Each length >= 1 mm, each |angle| <= 45°, total length <= 200 m. Plain tuples
        are refused: this function took (length_m, angle_deg) before Section existed.
      lead_in: flat ground between the spawn point and the first section, m; in [0, 200].
      run_out: flat ground after the last section, m; in (0, 200].
      resolution: x cell size of the MuJoCo heightfield, m; > 0.
      name: display name; defaults to the spec string.

    Returns:
      The terrain; `course_end_x = lead_in + sum(lengths)` (summed as decimals: 2 + 1.4 = 3.4).

    Raises:
      ValueError: naming the bad segment (index and value) or argument.
    """
    if len(segments) == 0:
        raise ValueError("segments is empty; expected at least one Section(angle_deg, length_m)")
    lengths, angles_deg = [], []
    for index, segment in enumerate(segments):
        if not isinstance(segment, Section):
            raise ValueError(
                f"segment {index}: expected a terrain.Section(angle_deg, length_m), got"
                f" {segment!r} (plain tuples are refused: sections took (length_m, angle_deg)"
                " before)"
            )
        length = _finite(f"segment {index} length_m", segment.length_m)
        angle_deg = _finite(f"segment {index} angle_deg", segment.angle_deg)
        if length < _MIN_SECTION_LENGTH:
            raise ValueError(
                f"segment {index} length_m must be >= {_MIN_SECTION_LENGTH:g}, got {length}"
            )
        if abs(angle_deg) > _MAX_SECTION_ANGLE:
            raise ValueError(
                f"segment {index} angle_deg must be within ±{_MAX_SECTION_ANGLE:g}, got {angle_deg}"
            )
        lengths.append(length)
        angles_deg.append(angle_deg)
    if (total := math.fsum(lengths)) > _MAX_COURSE_LENGTH:
        raise ValueError(f"total section length {total:g} m exceeds {_MAX_COURSE_LENGTH:g} m")
    lead_in, run_out, resolution = (
        _finite(key, value)
        for key, value in (("lead_in", lead_in), ("run_out", run_out), ("resolution", resolution))
    )
    if not 0 <= lead_in <= _MAX_COURSE_LENGTH:
        raise ValueError(f"lead_in must be in [0, {_MAX_COURSE_LENGTH:g}] m, got {lead_in}")
    if not 0 < run_out <= _MAX_COURSE_LENGTH:
        raise ValueError(f"run_out must be in (0, {_MAX_COURSE_LENGTH:g}] m, got {run_out}")
    if resolution <= 0:
        raise ValueError(f"resolution must be > 0, got {resolution}")

    edges = itertools.accumulate(map(_decimal, lengths), initial=_decimal(lead_in))
    section_edges = [float(edge) for edge in edges]  # lead_in, ..., course_end_x
    course_end_x = section_edges[-1]
    run_out_end = float(_decimal(course_end_x) + _decimal(run_out))
    rises = np.asarray(lengths) * np.tan(np.deg2rad(angles_deg))
    section_heights = np.cumsum([0.0, *rises])

    spec = _SECTIONS_PREFIX + ",".join(
        f"{_format_number(angle)}@{_format_number(length)}"
        for length, angle in zip(lengths, angles_deg)
    )
    options = {"lead_in": lead_in, "run_out": run_out, "resolution": resolution}
    for key, value in options.items():
        if value != _SECTIONS_DEFAULTS[key]:
            spec += f";{key}={_format_number(value)}"
    return Terrain(
        name=spec if name is None else name,
        spec=spec,
        x_knots=np.array([-_BACK_RUN, *section_edges, run_out_end]),
        y_knots=np.array([0.0]),
        heights=np.array([[0.0, *section_heights, section_heights[-1]]]),
        resolution=resolution,
        course_end_x=course_end_x,
    )


def heightfield(
    fn: Callable[[np.ndarray, np.ndarray], np.ndarray],
    *,
    x_range: tuple[float, float] = (-2.0, 20.0),
    y_range: tuple[float, float] = (-2.0, 2.0),
    resolution: float = 0.05,
    name: str = "heightfield",
    course_end_x: float | None = None,
) -> Terrain:
    """Any terrain from a height function, sampled on a regular grid.

    Heights are absolute (nothing is shifted): the ground under the spawn point is fn(0, 0).

    Args:
      fn: vectorised numpy function (x, y) -> z, m; called once with (ny, nx) arrays of x and y
        and must return finite heights of that shape.
      x_range: (x_min, x_max) of the grid, m; the spawn point x = 0 strictly inside.
      y_range: (y_min, y_max) of the grid, m; y = 0 strictly inside.
      resolution: grid spacing in x and y, m (adjusted so the grid spans the ranges exactly).
      name: display name, also the spec (`parse` finds it once registered under this name).
      course_end_x: x where the course ends, m, in (x_min, x_max]; None if unbounded.

    Returns:
      The terrain; `height_at` interpolates the samples bilinearly.

    Raises:
      ValueError: bad ranges or resolution, more than 1e6 grid cells, or fn output of the wrong
        shape or not finite.
    """
    x_min, x_max = _finite_pair("x_range", x_range)
    y_min, y_max = _finite_pair("y_range", y_range)
    resolution = _finite("resolution", resolution)
    if not x_min < 0.0 < x_max:
        raise ValueError(f"x_range {tuple(x_range)} must contain the spawn x = 0 strictly inside")
    if not y_min < 0.0 < y_max:
        raise ValueError(f"y_range {tuple(y_range)} must contain y = 0 strictly inside")
    if resolution <= 0:
        raise ValueError(f"resolution must be > 0, got {resolution}")
    if course_end_x is not None:
        course_end_x = _finite("course_end_x", course_end_x)
        if not x_min < course_end_x <= x_max:
            raise ValueError(f"course_end_x {course_end_x} must lie in x_range {tuple(x_range)}")
    ncol = _vertex_count(x_max - x_min, resolution)
    nrow = _vertex_count(y_max - y_min, resolution)
    if not nrow * ncol <= _MAX_HFIELD_CELLS:
        raise ValueError(
            f"grid of {nrow:.3g} x {ncol:.3g} cells exceeds {_MAX_HFIELD_CELLS};"
            f" use a coarser resolution (got {resolution} m)"
        )
    x_knots = np.linspace(x_min, x_max, int(ncol))
    y_knots = np.linspace(y_min, y_max, int(nrow))
    grid_x, grid_y = np.meshgrid(x_knots, y_knots)
    heights = np.asarray(fn(grid_x, grid_y), dtype=np.float64)
    if heights.shape != grid_x.shape:
        raise ValueError(
            f"fn returned shape {heights.shape} for x, y of shape {grid_x.shape};"
            " it must be vectorised"
        )
    if not np.isfinite(heights).all():
        raise ValueError(f"fn returned non-finite heights for terrain {name!r}")
    return Terrain(
        name=name,
        spec=name,
        x_knots=x_knots,
        y_knots=y_knots,
        heights=heights,
        resolution=resolution,
        course_end_x=course_end_x,
    )


def slope5() -> Terrain:
    """Paper Fig. 10: 5° uphill, 0°, 5° downhill, 3 m each."""
    return sections([Section(5.0, 3.0), Section(0.0, 3.0), Section(-5.0, 3.0)])


def s4() -> Terrain:
    """Paper Fig. 16, the unseen course S-4: 5°, 0°, 9°, 0° of 1.4, 1.4, 1.2, 1.4 m."""
    return sections([Section(5.0, 1.4), Section(0.0, 1.4), Section(9.0, 1.2), Section(0.0, 1.4)])
