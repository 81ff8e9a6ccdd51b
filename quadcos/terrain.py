"""Terrains: ground-truth height and slope, and the MuJoCo ground geometry.

A `Terrain` is an immutable description of the ground. On the host it adds the ground to a robot's
`mujoco.MjSpec` (`Terrain.attach`); inside the env its `height_at` / `slope_at` are pure
`jax.numpy` functions (jit/vmap-able) giving the ground-truth height and pitch under the robot.

World frame (MuJoCo): +x forward (the robot spawns at x = `spawn_x` = 0, y = 0 and walks along
+x), +y left, +z up; the paper's forward axis is its y. Slope angles are radians in code (> 0
uphill along +x) and degrees only in user-facing specs (`sections:ANGLE_DEG@LENGTH_M,...`).

Terrains of the paper (§4), registered by name: "flat"; "slope5" (Fig. 10: 5° up, 0°, 5° down,
3 m each); "s4" (Fig. 16, the unseen course S-4: 5°, 0°, 9°, 0° of 1.4, 1.4, 1.2, 1.4 m).
"""

import dataclasses
import decimal
import functools
import itertools
import math
import re
from collections.abc import Callable, Sequence
from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

FLOOR_GEOM = "floor"  # name of the ground geom (plane or heightfield)
FLOOR_HFIELD = "terrain"  # name of the heightfield asset
GROUND_FRICTION = (1.5, 0.02, 0.01)  # sliding, torsional, rolling
GROUND_CONDIM = 3

_PLANE_HALF_SIZE = 100.0  # m; a plane collides everywhere, this only sets how it is drawn
_BACK_RUN = 2.0  # m of flat ground behind the spawn point of a sections course
_PROFILE_HALF_WIDTH = 3.0  # m; half width in y of the heightfield of a pure x-profile
_PROFILE_Y_CELL = 0.25  # m; a profile does not vary along y, so few rows suffice
_HFIELD_BASE_DEPTH = 1.0  # m of solid below the lowest point of a heightfield
_MIN_ELEVATION_RANGE = 1e-3  # m; MuJoCo needs size[2] > 0 even for a level heightfield
_MAX_HFIELD_CELLS = 1_000_000
_MAX_COURSE_LENGTH = 200.0  # m
_MIN_SECTION_LENGTH = 1e-3  # m
_MAX_SECTION_ANGLE = 45.0  # deg
_SECTIONS_DEFAULTS = {"lead_in": 2.0, "run_out": 3.0, "resolution": 0.05}
_SECTIONS_PREFIX = "sections:"
_SECTIONS_FORMAT = (
    "sections:ANGLE_DEG@LENGTH_M[,ANGLE_DEG@LENGTH_M...][;lead_in=M][;run_out=M][;resolution=M]"
)
_NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_.-]*")


class Section(NamedTuple):
    """One straight section of a course, in the order of the CLI's `sections:ANGLE@LENGTH`."""

    angle_deg: float  # > 0 uphill along +x
    length_m: float


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Terrain:
    """An immutable ground description: heights on a grid, interpolated bilinearly.

    The ground height is the bilinear interpolant of `heights` over the knots `x_knots` ×
    `y_knots`, held at the edge values outside them. With one y knot the height depends on x only
    (a profile, piecewise linear in x: exact for sections courses). Knots need not be evenly
    spaced. The arrays are copied and made read-only.

    Attributes:
      name: display name for logs.
      spec: the string `parse` turns back into this terrain (built-ins, registered terrains and
        sections courses; for an unregistered `heightfield` it is just its name).
      x_knots: (nx,) strictly increasing x of the grid, m; nx >= 2.
      y_knots: (ny,) strictly increasing y of the grid, m; ny == 1 for a pure x-profile.
      heights: (ny, nx) ground height at the knots, m; rows are y, columns x.
      resolution: x cell size of the MuJoCo heightfield, m (also its y cell for 2-D grids).
      course_end_x: x where the course ends, m; None for unbounded terrains such as flat.
      spawn_x: x of the robot's spawn point, m.
    """

    name: str
    spec: str
    x_knots: np.ndarray
    y_knots: np.ndarray
    heights: np.ndarray
    resolution: float = 0.05
    course_end_x: float | None = None
    spawn_x: float = 0.0

    def __post_init__(self) -> None:
        for field in ("x_knots", "y_knots", "heights"):
            array = np.array(getattr(self, field), dtype=np.float64)
            array.flags.writeable = False
            object.__setattr__(self, field, array)
        x_knots, y_knots, heights = self.x_knots, self.y_knots, self.heights
        where = f"terrain {self.name!r}"
        if x_knots.ndim != 1 or x_knots.size < 2 or np.any(np.diff(x_knots) <= 0):
            raise ValueError(f"{where}: x_knots must be 1-D, strictly increasing, >= 2 knots")
        if y_knots.ndim != 1 or y_knots.size < 1 or np.any(np.diff(y_knots) <= 0):
            raise ValueError(f"{where}: y_knots must be 1-D, strictly increasing, >= 1 knot")
        if heights.shape != (y_knots.size, x_knots.size):
            raise ValueError(
                f"{where}: heights has shape {heights.shape}, expected"
                f" (len(y_knots), len(x_knots)) = {(y_knots.size, x_knots.size)}"
            )
        course_end_x = 0.0 if self.course_end_x is None else self.course_end_x
        scalars = np.array([self.resolution, self.spawn_x, course_end_x])
        if not all(np.isfinite(array).all() for array in (x_knots, y_knots, heights, scalars)):
            raise ValueError(
                f"{where}: knots, heights, resolution, spawn_x and course_end_x must be finite"
            )
        if self.resolution <= 0:
            raise ValueError(f"{where}: resolution must be > 0, got {self.resolution}")
        if not self.is_flat:
            nrow, ncol = self._hfield_shape_float()
            if not nrow * ncol <= _MAX_HFIELD_CELLS:
                raise ValueError(
                    f"{where}: heightfield would have {nrow:.3g} x {ncol:.3g} cells, more than"
                    f" {_MAX_HFIELD_CELLS}; use a coarser resolution (got {self.resolution} m)"
                )

    def __repr__(self) -> str:
        return f"Terrain({self.name!r}, spec={self.spec!r}, course_end_x={self.course_end_x})"

    @property
    def is_flat(self) -> bool:
        """True when the ground is the plane z = 0: `attach` adds a plane, not a heightfield."""
        return not np.any(self.heights)

    @property
    def extent(self) -> tuple[float, float, float, float] | None:
        """(x_min, x_max, y_min, y_max) of the MuJoCo heightfield, m; None for the plane."""
        if self.is_flat:
            return None
        if self.y_knots.size == 1:
            y_min, y_max = -_PROFILE_HALF_WIDTH, _PROFILE_HALF_WIDTH
        else:
            y_min, y_max = float(self.y_knots[0]), float(self.y_knots[-1])
        return float(self.x_knots[0]), float(self.x_knots[-1]), y_min, y_max

    @property
    def hfield_shape(self) -> tuple[int, int] | None:
        """(nrow, ncol) = vertices (along y, along x) of the MuJoCo heightfield; None if flat."""
        if self.is_flat:
            return None
        nrow, ncol = self._hfield_shape_float()
        return int(nrow), int(ncol)

    def _hfield_shape_float(self) -> tuple[float, float]:
        x_min, x_max, y_min, y_max = self.extent
        y_cell = _PROFILE_Y_CELL if self.y_knots.size == 1 else self.resolution
        return _vertex_count(y_max - y_min, y_cell), _vertex_count(x_max - x_min, self.resolution)

    @functools.partial(jax.jit, static_argnums=0)
    def height_at(self, x: jax.typing.ArrayLike, y: jax.typing.ArrayLike) -> jax.Array:
        """Ground height at (x, y).

        Args:
          x: (...) forward position, m.
          y: (...) lateral position, m; broadcast against x.

        Returns:
          (...) ground height, m. Jit/vmap-able; compiled once per terrain object and input shape.
        """
        x, y = jnp.broadcast_arrays(jnp.asarray(x, dtype=float), jnp.asarray(y, dtype=float))
        heights = jnp.asarray(self.heights)
        ix, tx = _cell(jnp.asarray(self.x_knots), x)
        row, next_row, ty = self._rows(y)

        def along_x(r: jax.Array) -> jax.Array:
            return heights[r, ix] * (1.0 - tx) + heights[r, ix + 1] * tx

        return along_x(row) * (1.0 - ty) + along_x(next_row) * ty

    @functools.partial(jax.jit, static_argnums=0)
    def slope_at(self, x: jax.typing.ArrayLike, y: jax.typing.ArrayLike) -> jax.Array:
        """Pitch of the ground along +x at (x, y): arctan(∂h/∂x), > 0 uphill.

        Right-continuous in x: at a kink it is the slope of the section being entered, so on a
        sections course it is the section angle everywhere. 0 outside the grid (level ground).

        Args:
          x: (...) forward position, m.
          y: (...) lateral position, m; broadcast against x.

        Returns:
          (...) slope angle, rad. Jit/vmap-able; compiled once per terrain object and input shape.
        """
        x, y = jnp.broadcast_arrays(jnp.asarray(x, dtype=float), jnp.asarray(y, dtype=float))
        x_knots = jnp.asarray(self.x_knots)
        heights = jnp.asarray(self.heights)
        ix, _ = _cell(x_knots, x)
        row, next_row, ty = self._rows(y)

        def gradient_x(r: jax.Array) -> jax.Array:
            return (heights[r, ix + 1] - heights[r, ix]) / (x_knots[ix + 1] - x_knots[ix])

        gradient = gradient_x(row) * (1.0 - ty) + gradient_x(next_row) * ty
        inside = (x >= x_knots[0]) & (x < x_knots[-1])
        return jnp.where(inside, jnp.arctan(gradient), 0.0)

    def _rows(self, y: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
        """The grid rows around y and y's fraction between them (row 0 twice for a profile)."""
        if self.y_knots.size == 1:
            zero = jnp.zeros(y.shape, dtype=int)
            return zero, zero, jnp.zeros_like(y)
        row, ty = _cell(jnp.asarray(self.y_knots), y)
        return row, row + 1, ty

    def attach(self, spec: mujoco.MjSpec) -> None:
        """Adds the ground to `spec`'s worldbody as a geom named "floor".

        Flat terrains get a plane at z = 0. Others get a heightfield (asset "terrain") sampled from
        `height_at` on a regular grid over `extent` (x cells of `resolution`), placed so that its
        vertices lie at the absolute heights `height_at` gives. Between vertices MuJoCo's surface
        is linear over triangles: a kink between vertices is cut by at most
        |Δtan(angle)| · resolution / 4 (for the paper's courses every kink is on a vertex).

        The ground has contype 0, conaffinity 1 (the robot's colliding geoms, its foot
        spheres: contype 1, conaffinity 0), friction GROUND_FRICTION and condim GROUND_CONDIM.

        Args:
          spec: the robot's model spec; modified in place.

        Raises:
          ValueError: `spec` already has a geom "floor" or a heightfield "terrain".
        """
        if spec.geom(FLOOR_GEOM) is not None:
            raise ValueError(f"spec already has a geom named {FLOOR_GEOM!r}")
        ground = dict(
            name=FLOOR_GEOM,
            contype=0,
            conaffinity=1,
            condim=GROUND_CONDIM,
            friction=list(GROUND_FRICTION),
        )
        if self.is_flat:
            spec.worldbody.add_geom(
                type=mujoco.mjtGeom.mjGEOM_PLANE,
                size=[_PLANE_HALF_SIZE, _PLANE_HALF_SIZE, 0.1],
                **ground,
            )
            return
        if spec.hfield(FLOOR_HFIELD) is not None:
            raise ValueError(f"spec already has a heightfield named {FLOOR_HFIELD!r}")
        x_min, x_max, y_min, y_max = self.extent
        nrow, ncol = self.hfield_shape
        xs = np.linspace(x_min, x_max, ncol)
        ys = np.linspace(y_min, y_max, nrow)
        z = np.asarray(self.height_at(xs[None, :], ys[:, None]), dtype=np.float64)  # (nrow, ncol)
        z_min = float(z.min())
        # MJX reads the data as given, so normalise it to [0, 1]: surface = pos_z + data * size[2].
        elevation_range = max(float(z.max()) - z_min, _MIN_ELEVATION_RANGE)
        spec.add_hfield(
            name=FLOOR_HFIELD,
            nrow=nrow,
            ncol=ncol,
            size=[(x_max - x_min) / 2, (y_max - y_min) / 2, elevation_range, _HFIELD_BASE_DEPTH],
            userdata=((z - z_min) / elevation_range).ravel().tolist(),
        )
        spec.worldbody.add_geom(
            type=mujoco.mjtGeom.mjGEOM_HFIELD,
            hfieldname=FLOOR_HFIELD,
            pos=[(x_min + x_max) / 2, (y_min + y_max) / 2, z_min],
            **ground,
        )


def _cell(knots: jax.Array, q: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Index i of the cell [knots[i], knots[i+1]) holding q, clipped to the grid, and q's
    fraction of the way through it, clipped to [0, 1]."""
    i = jnp.clip(jnp.searchsorted(knots, q, side="right") - 1, 0, knots.shape[0] - 2)
    t = jnp.clip((q - knots[i]) / (knots[i + 1] - knots[i]), 0.0, 1.0)
    return i, t


def _vertex_count(length: float, cell: float) -> float:
    """Grid vertices spanning `length` m in cells of about `cell` m (>= 2); a float, possibly inf,
    so that absurd sizes reach the cell limit check instead of overflowing an int."""
    return max(2.0, float(np.round(length / cell)) + 1.0)


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


def _slope5() -> Terrain:
    """Paper Fig. 10: 5° uphill, 0°, 5° downhill, 3 m each."""
    return sections([Section(5.0, 3.0), Section(0.0, 3.0), Section(-5.0, 3.0)])


def _s4() -> Terrain:
    """Paper Fig. 16, the unseen course S-4: 5°, 0°, 9°, 0° of 1.4, 1.4, 1.2, 1.4 m."""
    return sections([Section(5.0, 1.4), Section(0.0, 1.4), Section(9.0, 1.2), Section(0.0, 1.4)])


_REGISTRY: dict[str, Terrain | Callable[[], Terrain]] = {"flat": flat, "slope5": _slope5, "s4": _s4}


def register(
    name: str, terrain: Terrain | Callable[[], Terrain], *, overwrite: bool = False
) -> None:
    """Makes a terrain available to `get` / `parse` (and so to the CLI) under `name`.

    Args:
      name: a letter, then letters, digits, '_', '.' or '-'; not "sections".
      terrain: the terrain, or a zero-argument factory called on each `get`.
      overwrite: replace an existing entry (built-ins included) instead of raising.

    Raises:
      ValueError: bad name, or the name is taken and not `overwrite`.
      TypeError: `terrain` is neither a Terrain nor callable.
    """
    if not isinstance(name, str) or not _NAME_PATTERN.fullmatch(name) or name == "sections":
        raise ValueError(
            f"bad terrain name {name!r}: expected a letter, then letters, digits, '_', '.', '-'"
            " (and not 'sections')"
        )
    if not (isinstance(terrain, Terrain) or callable(terrain)):
        raise TypeError(
            f"terrain must be a Terrain or a callable returning one, got {type(terrain).__name__}"
        )
    if name in _REGISTRY and not overwrite:
        raise ValueError(f"terrain {name!r} is already registered; pass overwrite=True to replace")
    _REGISTRY[name] = terrain


def names() -> list[str]:
    """Registered terrain names, sorted."""
    return sorted(_REGISTRY)


def parse(spec: str) -> Terrain:
    """Builds a terrain from a spec string (the CLI's --terrain).

    Accepted, surrounding whitespace ignored:
      - a registered name (`flat`, `slope5`, `s4`, ...); the terrain comes back with `name` and
        `spec` set to that name;
      - `sections:ANGLE_DEG@LENGTH_M,...` with optional `;lead_in=M`, `;run_out=M`,
        `;resolution=M` (see `sections`), e.g. `sections:5@1.4,0@1.4,9@1.2,0@1.4`;
      - `MODULE:NAME` (a terrain from the user's module) and `heightfield:FILE.npy;...` (heights
        from a NumPy file): see `quadcos.terrain_spec`.

    Raises:
      ValueError: unknown name or malformed sections spec, naming the bad token.
      TypeError: `spec` is not a string, or a registered factory returned no Terrain.
    """
    if not isinstance(spec, str):
        raise TypeError(f"terrain spec must be a string, got {type(spec).__name__}")
    text = spec.strip()
    if text.startswith(_SECTIONS_PREFIX):
        return _parse_sections(text)
    from quadcos import terrain_spec  # pylint: disable=g-import-not-at-top  (it imports this)

    if (external := terrain_spec.parse_external(text)) is not None:
        return external
    if text not in _REGISTRY:
        raise ValueError(
            f"unknown terrain {spec!r}; known: {', '.join(names())}, {_SECTIONS_FORMAT},"
            f" {terrain_spec.HEIGHTFIELD_FORMAT} or {terrain_spec.MODULE_FORMAT}"
        )
    entry = _REGISTRY[text]
    terrain = entry if isinstance(entry, Terrain) else entry()
    if not isinstance(terrain, Terrain):
        raise TypeError(
            f"the factory registered as {text!r} returned {type(terrain).__name__}, not a Terrain"
        )
    return dataclasses.replace(terrain, name=text, spec=text)


def get(name_or_spec: str) -> Terrain:
    """The terrain for a registered name or a spec string; see `parse`."""
    return parse(name_or_spec)


def _parse_sections(spec: str) -> Terrain:
    body, *option_tokens = spec.removeprefix(_SECTIONS_PREFIX).split(";")
    if not body.strip():
        raise ValueError(f"no sections in {spec!r}: expected {_SECTIONS_FORMAT}")
    segments = []
    for token in body.split(","):
        angle_deg, at, length = token.partition("@")
        try:
            if not at:
                raise ValueError
            segments.append(Section(float(angle_deg), float(length)))
        except ValueError:
            raise ValueError(
                f"bad section {token!r} in {spec!r}: expected ANGLE_DEG@LENGTH_M"
            ) from None
    options: dict[str, float] = {}
    for token in option_tokens:
        key, equals, value = (part.strip() for part in token.partition("="))
        if not equals or key not in _SECTIONS_DEFAULTS or key in options:
            raise ValueError(
                f"bad option {token!r} in {spec!r}: expected at most one each of"
                " lead_in=M, run_out=M, resolution=M"
            )
        try:
            options[key] = float(value)
        except ValueError:
            raise ValueError(
                f"bad option {token!r} in {spec!r}: {value!r} is not a number"
            ) from None
    try:
        return sections(segments, **options)
    except ValueError as error:
        raise ValueError(f"bad terrain spec {spec!r}: {error}") from None
