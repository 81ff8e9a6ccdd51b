"""A `Terrain`: an immutable ground description, its ground-truth height and slope, and the MuJoCo
ground geometry it adds to a robot's `mujoco.MjSpec`.

`height_at` / `slope_at` are pure `jax.numpy` functions (jit/vmap-able), used inside the env;
`attach` runs on the host. Building terrains (flat, sections courses, heightfields), naming and
parsing them is `quadcos.terrain`'s, which re-exports what is here.
"""

import dataclasses
import functools
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
_PROFILE_HALF_WIDTH = 3.0  # m; half width in y of the heightfield of a pure x-profile
_PROFILE_Y_CELL = 0.25  # m; a profile does not vary along y, so few rows suffice
_HFIELD_BASE_DEPTH = 1.0  # m of solid below the lowest point of a heightfield
_MIN_ELEVATION_RANGE = 1e-3  # m; MuJoCo needs size[2] > 0 even for a level heightfield
_MAX_HFIELD_CELLS = 1_000_000


class Lane(NamedTuple):
    """One course of a lane terrain: a band along x, centred at `y`, on which the ground depends on
    x only. Robots of lane `i` spawn at y = lanes[i].y."""

    name: str
    y: float  # m: the lane's centre line
    course_end_x: float | None  # m: where its course ends; None for unbounded (flat) ground


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
      y_resolution: y cell size of the MuJoCo heightfield of a 2-D grid, m; None: `resolution`.
      lanes: courses side by side in y (see `Lane`; built by `quadcos.courses.lanes`), each
        robot on one; empty for a single course (one lane at y = 0 ending at `course_end_x`).
    """

    name: str
    spec: str
    x_knots: np.ndarray
    y_knots: np.ndarray
    heights: np.ndarray
    resolution: float = 0.05
    course_end_x: float | None = None
    spawn_x: float = 0.0
    y_resolution: float | None = None
    lanes: tuple[Lane, ...] = ()

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
        if not self.resolution > 0 or not (self.y_resolution is None or self.y_resolution > 0):
            raise ValueError(
                f"{where}: resolution and y_resolution must be > 0, got {self.resolution},"
                f" {self.y_resolution}"
            )
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
    def num_lanes(self) -> int:
        """Courses side by side (1 for a single course)."""
        return max(1, len(self.lanes))

    @property
    def lane_y(self) -> np.ndarray:
        """(num_lanes,) y of each lane's centre line, m."""
        return np.array([lane.y for lane in self.lanes] or [0.0])

    @property
    def lane_end_x(self) -> np.ndarray:
        """(num_lanes,) x where each lane's course ends, m; inf where the ground is unbounded."""
        ends = [lane.course_end_x for lane in self.lanes] or [self.course_end_x]
        return np.array([np.inf if end is None else end for end in ends])

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
        y_cell = self.y_resolution or self.resolution
        if self.y_knots.size == 1:
            y_cell = _PROFILE_Y_CELL
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
