"""Terrains by name: the paper's ("flat", "slope5", "s4") and the user's (`register`)."""

import dataclasses
import re
from collections.abc import Callable

from quadcos.terrain import builders
from quadcos.terrain.ground import Terrain

_NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_.-]*")

_REGISTRY: dict[str, Terrain | Callable[[], Terrain]] = {
    "flat": builders.flat,
    "slope5": builders.slope5,
    "s4": builders.s4,
}


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


class NotATerrain(TypeError, ValueError):
    """A spec's factory or `MODULE:NAME` that gives no Terrain: a TypeError of the value, and a
    bad value where a command line reads the spec (one line, exit status 2)."""


def names() -> list[str]:
    """Registered terrain names, sorted."""
    return sorted(_REGISTRY)


def registered(name: str) -> Terrain | None:
    """The terrain registered as `name`, with `name` and `spec` set to it; None if none is.

    Raises:
      NotATerrain (a TypeError): the registered factory returned no Terrain.
    """
    if name not in _REGISTRY:
        return None
    entry = _REGISTRY[name]
    terrain = entry if isinstance(entry, Terrain) else entry()
    if not isinstance(terrain, Terrain):
        raise NotATerrain(
            f"the factory registered as {name!r} returned {type(terrain).__name__}, not a Terrain"
        )
    return dataclasses.replace(terrain, name=name, spec=name)
