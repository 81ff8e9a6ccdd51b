"""Dotted-key overrides for ml_collections configs; an unknown key is an error."""

import ast
import copy
import difflib
import math
from collections.abc import Iterable, Mapping
from typing import Any

import ml_collections


def parse_value(text: str) -> Any:
    """A command-line value as a Python literal when it is one (1e-3, (64, 64), True), a bool for
    true / false in any case, a float for nan and inf, else a string."""
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        pass
    try:
        return float(text)
    except ValueError:
        return text


def parse_overrides(
    items: Iterable[str], prefix: str, config: ml_collections.ConfigDict | None = None
) -> dict[str, Any]:
    """Command-line items `--PREFIX.KEY=VALUE` as {"KEY": value} (`parse_value`), every CLI's
    one reading of them; with `config`, each key is checked against it.

    Raises:
      ValueError: an item of another form, or a key that `config` lacks.
    """
    flag = f"--{prefix}."
    overrides = {}
    for item in items:
        key, equals, text = item.removeprefix(flag).partition("=")
        if not (item.startswith(flag) and equals and key):
            raise ValueError(
                f"unrecognised argument {item!r} ({prefix} options look like {flag}KEY=VALUE)"
            )
        overrides[key] = parse_value(text)
    if config is not None:
        known = flat_keys(config)
        for key in overrides:
            _check_known(key, known)
    return overrides


def _check_known(key: str, known: list[str]) -> None:
    if key not in known:
        near = difflib.get_close_matches(key, known, n=3)
        hint = f"; did you mean {', '.join(near)}?" if near else ""
        raise ValueError(f"unknown config key {key!r}{hint}")


def apply_overrides(
    config: ml_collections.ConfigDict, overrides: Mapping[str, Any]
) -> ml_collections.ConfigDict:
    """Return a copy of `config` with `overrides` ({"sac.batch_size": 256, ...}) applied.

    Raises:
      ValueError: a key that is not in the config (with the nearest known keys), a value whose
        type does not fit the field (None fits only fields that default to None), or a float
        that is not finite.
    """
    # A deep copy keeps placeholders (`config_dict.placeholder(float)`) typed; a copy through
    # to_dict() would turn them into plain None fields that accept any value.
    config = copy.deepcopy(config)
    known = flat_keys(config)
    for key, value in overrides.items():
        _check_known(key, known)
        *parents, leaf = key.split(".")
        node = config
        for parent in parents:
            node = node[parent]
        if value is None and not _nullable(node, leaf):
            raise ValueError(f"bad value None for config key {key!r}: it needs a value")
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"bad value {value!r} for config key {key!r}: not finite")
        try:
            node[leaf] = value
        except TypeError:  # ml_collections' words name its internals: say what the field takes
            raise ValueError(
                f"bad value {value!r} for config key {key!r}: it takes a"
                f" {node.get_type(leaf).__name__}, not a {type(value).__name__}"
            ) from None
        except ValueError as error:
            raise ValueError(f"bad value {value!r} for config key {key!r}: {error}") from None
    return config


def _nullable(node: ml_collections.ConfigDict, leaf: str) -> bool:
    field = node.to_dict(preserve_field_references=True)[leaf]
    return field is None or isinstance(field, ml_collections.FieldReference)


def flat_keys(config: ml_collections.ConfigDict, prefix: str = "") -> list[str]:
    """All leaf keys of a nested config, dotted."""
    keys = []
    for name, value in config.items():
        if isinstance(value, ml_collections.ConfigDict):
            keys += flat_keys(value, f"{prefix}{name}.")
        else:
            keys.append(f"{prefix}{name}")
    return keys


def flatten(tree: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """A nested mapping (a config as saved in JSON) as {"dotted.key": value}; lists become tuples
    (JSON has no tuples; the config's fields do)."""
    flat = {}
    for key, value in tree.items():
        if isinstance(value, Mapping):
            flat |= flatten(value, f"{prefix}{key}.")
        else:
            flat[f"{prefix}{key}"] = tuple(value) if isinstance(value, list) else value
    return flat
