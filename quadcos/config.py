"""Dotted-key overrides for ml_collections configs; an unknown key is an error."""

import difflib
from collections.abc import Mapping
from typing import Any

import ml_collections


def apply_overrides(
    config: ml_collections.ConfigDict, overrides: Mapping[str, Any]
) -> ml_collections.ConfigDict:
    """Return a copy of `config` with `overrides` ({"sac.batch_size": 256, ...}) applied.

    Raises:
      ValueError: a key that is not in the config (with the nearest known keys), or a value whose
        type does not fit the field.
    """
    config = ml_collections.ConfigDict(config.to_dict(), type_safe=True)
    known = flat_keys(config)
    for key, value in overrides.items():
        if key not in known:
            near = difflib.get_close_matches(key, known, n=3)
            hint = f"; did you mean {', '.join(near)}?" if near else ""
            raise ValueError(f"unknown config key {key!r}{hint}")
        *parents, leaf = key.split(".")
        node = config
        for parent in parents:
            node = node[parent]
        try:
            node[leaf] = value
        except (TypeError, ValueError) as error:
            raise ValueError(f"bad value {value!r} for config key {key!r}: {error}") from None
    return config


def flat_keys(config: ml_collections.ConfigDict, prefix: str = "") -> list[str]:
    """All leaf keys of a nested config, dotted."""
    keys = []
    for name, value in config.items():
        if isinstance(value, ml_collections.ConfigDict):
            keys += flat_keys(value, f"{prefix}{name}.")
        else:
            keys.append(f"{prefix}{name}")
    return keys
