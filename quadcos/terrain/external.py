"""Terrain specs that name ground from outside quadcos: a user's module or a heightfield file.

`terrain.parse` (and so `--terrain`) hands these two forms here:

- `MODULE:NAME` imports MODULE (a dotted module name, found on `sys.path`: `python -m` puts the
  current directory there) and takes its attribute NAME, a `Terrain` or a zero-argument function
  returning one; when MODULE has no attribute NAME, the terrain that importing it registered as
  NAME (`terrain.register`). E.g. `--terrain=my_courses:hills` for `hills` in ./my_courses.py.
- `heightfield:FILE.npy[;x_range=MIN,MAX][;y_range=MIN,MAX][;course_end_x=X]`: ground heights
  in m from a NumPy file (a relative FILE from the current directory), a (ny, nx) array (rows along y, columns along x) or an (nx,) profile
  along x, spread evenly over the ranges (m; defaults as `terrain.heightfield`'s: x from -2 to
  20, y from -2 to 2). Heights are absolute; the robot spawns at x = 0, y = 0.
"""

import dataclasses
import importlib
import pathlib
import re

import numpy as np

from quadcos.terrain import registry
from quadcos.terrain.ground import Terrain

HEIGHTFIELD_PREFIX = "heightfield:"
HEIGHTFIELD_FORMAT = (
    "heightfield:FILE.npy[;x_range=MIN,MAX][;y_range=MIN,MAX][;course_end_x=X]"
)
MODULE_FORMAT = "MODULE:NAME"
_MODULE_SPEC = re.compile(r"(?P<module>[A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*):(?P<name>[A-Za-z_]\w*)")
_HEIGHTFIELD_OPTIONS = {"x_range": (-2.0, 20.0), "y_range": (-2.0, 2.0), "course_end_x": None}


def parse_external(spec: str) -> Terrain | None:
    """The terrain of a `MODULE:NAME` or `heightfield:...` spec; None for other specs.

    The terrain's `spec` is `spec`, so that `terrain.parse(terrain.spec)` builds it again.

    Raises:
      ValueError: a module that cannot be imported or lacks NAME, an unreadable or unfit
        heights file, or a malformed option, naming the spec and the cause.
      registry.NotATerrain (a TypeError): NAME is neither a Terrain nor a function returning one.
    """
    if spec.startswith(HEIGHTFIELD_PREFIX):
        return _heightfield(spec)
    match = _MODULE_SPEC.fullmatch(spec)
    if match is None or match["module"] == "sections":
        return None
    return _from_module(spec, match["module"], match["name"])


def _from_module(spec: str, module_name: str, name: str) -> Terrain:
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as error:
        raise ValueError(
            f"terrain spec {spec!r}: cannot import module {module_name!r} ({error}); run from the"
            " directory that holds it or add that directory to PYTHONPATH"
        ) from None
    except Exception as error:  # the user's module failed; say so in one line
        raise ValueError(
            f"terrain spec {spec!r}: importing {module_name!r} raised"
            f" {type(error).__name__}: {error}"
        ) from None
    if hasattr(module, name):
        entry = getattr(module, name)
        found = entry if isinstance(entry, Terrain) else None
        if found is None and callable(entry):
            found = entry()
        if not isinstance(found, Terrain):
            raise registry.NotATerrain(
                f"terrain spec {spec!r}: {module_name}.{name} is {type(entry).__name__}, not a"
                " Terrain or a function returning one"
            )
    elif name in registry.names():
        found = registry.registered(name)
    else:
        raise ValueError(
            f"terrain spec {spec!r}: module {module_name!r} has no attribute {name!r} and"
            f" registered no terrain of that name"
        )
    return dataclasses.replace(found, spec=spec)


def _heightfield(spec: str) -> Terrain:
    file_text, *option_tokens = spec.removeprefix(HEIGHTFIELD_PREFIX).split(";")
    options = dict(_HEIGHTFIELD_OPTIONS)
    given = set()
    for token in option_tokens:
        key, equals, value = (part.strip() for part in token.partition("="))
        if not equals or key not in options or key in given:
            raise ValueError(
                f"bad option {token!r} in {spec!r}: expected {HEIGHTFIELD_FORMAT}"
            )
        given.add(key)
        try:
            numbers = tuple(float(number) for number in value.split(","))
        except ValueError:
            raise ValueError(f"bad option {token!r} in {spec!r}: not numbers") from None
        if len(numbers) != (1 if key == "course_end_x" else 2):
            raise ValueError(f"bad option {token!r} in {spec!r}: expected {HEIGHTFIELD_FORMAT}")
        options[key] = numbers[0] if key == "course_end_x" else numbers
    path = pathlib.Path(file_text.strip())
    try:
        heights = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as error:
        raise ValueError(
            f"terrain spec {spec!r}: {path} cannot be read as a NumPy .npy array, likely"
            f" missing, truncated or another format ({type(error).__name__}: {error})"
        ) from None
    return _grid_terrain(spec, path.stem, heights, **options)


def _grid_terrain(
    spec: str,
    name: str,
    heights: np.ndarray,
    x_range: tuple[float, float],
    y_range: tuple[float, float],
    course_end_x: float | None,
) -> Terrain:
    """A Terrain from heights spread evenly over the ranges (a 1-D array is an x-profile)."""
    where = f"terrain spec {spec!r}"
    if heights.ndim not in (1, 2) or heights.shape[-1] < 2 or heights.dtype.kind not in "iuf":
        raise ValueError(
            f"{where}: expected a (ny, nx) or (nx,) array of heights in m with nx >= 2, got"
            f" {heights.dtype} of shape {heights.shape}"
        )
    (x_min, x_max), (y_min, y_max) = x_range, y_range
    if not x_min < 0.0 < x_max:
        raise ValueError(f"{where}: x_range {x_range} must contain the spawn x = 0 strictly inside")
    profile = heights.ndim == 1 or heights.shape[0] == 1
    if not profile and not y_min < 0.0 < y_max:
        raise ValueError(f"{where}: y_range {y_range} must contain y = 0 strictly inside")
    if course_end_x is not None and not x_min < course_end_x <= x_max:
        raise ValueError(f"{where}: course_end_x {course_end_x} must lie in x_range {x_range}")
    grid = heights.reshape(1, -1) if profile else heights
    try:
        return Terrain(
            name=name,
            spec=spec,
            x_knots=np.linspace(x_min, x_max, grid.shape[1]),
            y_knots=np.zeros(1) if profile else np.linspace(y_min, y_max, grid.shape[0]),
            heights=grid,
            resolution=(x_max - x_min) / (grid.shape[1] - 1),
            course_end_x=course_end_x,
        )
    except ValueError as error:
        raise ValueError(f"{where}: {error}") from None
