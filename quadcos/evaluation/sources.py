"""What chooses the actions of an evaluation: a trained policy or fixed rhythm parameters.

An `ActionSource` is a source of actions, not a controller in the paper's sense (the rhythm
controller is the oscillator inside the env, `quadcos.oscillator`). `build_env` rebuilds the env a
source must run in: a trained policy's saved env config (`quadcos.runs`), or the default env.
"""

import ast
import dataclasses
import math
import operator
import os
import pathlib
from collections.abc import Callable, Mapping
from typing import Any

import jax
import jax.numpy as jnp

from quadcos import env as env_lib
from quadcos import terrain as terrain_lib
from quadcos.equations import oscillator
from quadcos.training import run_config as runs

FIXED_PREFIX = "fixed:"
PARAMETER_NAMES = oscillator.RhythmParameters._fields


@dataclasses.dataclass(frozen=True)
class ActionSource:
    """What chooses actions, and the env it must run in.

    Attributes:
      name: the --policy string (or a description).
      kind: "sac" or "fixed".
      act: (params, obs (n, obs_size)) -> actions (n, action_size); jit-able.
      params: the first argument of `act` (fixed: the (5,) parameters; sac: None).
      env_overrides: env config overrides (dotted keys) that rebuild the training env.
      training_terrain: the terrain spec the policy was trained on ("flat" for fixed parameters).
      fixed_parameters: the rhythm parameters of a fixed source, else None.
      observation_size, action_size: what the policy expects (None: anything).
    """

    name: str
    kind: str
    act: Callable[[Any, jax.Array], jax.Array]
    params: Any
    env_overrides: dict[str, Any]
    training_terrain: str
    fixed_parameters: oscillator.RhythmParameters | None = None
    observation_size: int | None = None
    action_size: int | None = None


def parse_fixed(text: str) -> oscillator.RhythmParameters:
    """`trot` or `A_k,A_h,T,phi1,phi3` (rad, rad, s, rad, rad; `pi` allowed) as rhythm parameters.

    Raises:
      ValueError: not five numbers (the env checks the ranges: `build_env`).
    """
    body = text.strip()
    if body == "trot":
        return oscillator.FIXED_TROT
    tokens = body.split(",")
    if len(tokens) != len(PARAMETER_NAMES):
        raise ValueError(
            f"bad fixed parameters {text!r}: expected 'trot' or five numbers A_k,A_h,T,phi1,phi3"
        )
    return oscillator.RhythmParameters(*(_number(token, text) for token in tokens))


_OPERATORS = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.USub: operator.neg,
    ast.UAdd: operator.pos,
}


def _number(token: str, text: str) -> float:
    """A float from '0.4', '-pi/2', '3*pi/4' (arithmetic on numbers and pi only)."""

    def value(node: ast.AST) -> float:
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id == "pi":
            return math.pi
        if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](value(node.left), value(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](value(node.operand))
        raise ValueError

    try:
        number = value(ast.parse(token.strip(), mode="eval").body)
    except (ValueError, SyntaxError, ZeroDivisionError, RecursionError):
        raise ValueError(
            f"bad fixed parameters {text!r}: {token.strip()!r} is not a number"
        ) from None
    if not math.isfinite(number):
        raise ValueError(f"bad fixed parameters {text!r}: {token.strip()!r} is not finite")
    return number


def fixed_source(params: oscillator.RhythmParameters, name: str | None = None) -> ActionSource:
    """Constant rhythm parameters through the same rollout path as a policy (Fig. 15's baseline)."""
    name = name or FIXED_PREFIX + ",".join(f"{float(p):.6g}" for p in params)
    return ActionSource(
        name=name,
        kind="fixed",
        act=_constant_action,
        params=jnp.asarray([float(p) for p in params], jnp.float32),
        env_overrides={},
        training_terrain="flat",
        fixed_parameters=oscillator.RhythmParameters(*(float(p) for p in params)),
    )


def _constant_action(actions: jax.Array, obs: jax.Array) -> jax.Array:
    """The (n, action_size) actions that `rollout` computed from the fixed parameters for its
    env (`QuadrupedEnv.action_for`)."""
    del obs
    return actions


def policy_source(path: str | os.PathLike[str]) -> ActionSource:
    """A trained policy (run or policy directory) and the env config it was trained with.

    Raises:
      FileNotFoundError: no policy at `path`.
      ValueError: the policy's saved run config is missing or names options this quadcos lacks
        (`quadcos.runs.migrate`).
    """
    from quadcos.training import load_policy

    if not pathlib.Path(path).exists():
        raise FileNotFoundError(f"no policy at {path}: no such file or directory")
    try:
        policy = load_policy(path)
    except (FileNotFoundError, ValueError):
        raise
    except Exception as error:  # noqa: BLE001 -- msgpack, flax and JSON readers raise many types
        raise ValueError(
            f"cannot load the policy at {path}: {type(error).__name__}: {error}"
        ) from None
    try:
        env_overrides, training_terrain = trained_env(policy.config)
    except ValueError as error:
        raise ValueError(f"the policy at {path}: {error}") from None
    return ActionSource(
        name=str(path),
        kind="sac",
        act=lambda _, obs: policy.act(obs),
        params=None,
        env_overrides=env_overrides,
        training_terrain=training_terrain,
        observation_size=policy.spec.observation_size,
        action_size=policy.spec.action_size,
    )


def trained_env(saved: Mapping[str, Any]) -> tuple[dict[str, Any], str]:
    """The env overrides (terrain excluded) and the terrain of the env a run was trained in, from
    its saved config (a config.json's content, `quadcos.runs.migrate`).

    Raises:
      ValueError: not a quadcos run config, or options this quadcos does not know.
    """
    env_overrides = runs.env_overrides(runs.migrate(saved))
    return env_overrides, str(env_overrides.pop("terrain", "flat"))


def resolve_source(spec: str) -> ActionSource:
    """The source for a --policy value: `fixed:...` or a policy / run directory."""
    if spec.startswith(FIXED_PREFIX):
        body = spec[len(FIXED_PREFIX) :]
        return fixed_source(parse_fixed(body), name=spec)
    return policy_source(spec)



def build_env(
    source: ActionSource,
    terrain: terrain_lib.Terrain | str | None = None,
    env_overrides: Mapping[str, Any] | None = None,
) -> env_lib.QuadrupedEnv:
    """The env `source` runs in, on `terrain` (default: its training terrain).

    Raises:
      ValueError: bad terrain or override, or an env whose observation / action sizes differ from
        the policy's.
    """
    # An evaluation episode starts at the spawn point, wherever training spawned.
    overrides = {**source.env_overrides, "spawn_x_max": 0.0, **(env_overrides or {})}
    overrides.pop("terrain", None)
    trained_on = source.env_overrides.get("robot", "quadcos")
    if source.kind != "fixed" and overrides.get("robot", trained_on) != trained_on:
        raise ValueError(
            f"the policy was trained on robot {trained_on!r}, not {overrides['robot']!r}"
        )
    env = env_lib.make_env(
        terrain if terrain is not None else source.training_terrain, **overrides
    )
    if source.kind == "fixed":
        _check_fixed(source, env)
    if source.action_size is not None and env.action_size != source.action_size:
        raise ValueError(
            f"the policy acts with {source.action_size} values, the env expects {env.action_size}"
        )
    if source.observation_size is not None:
        size = env.observation_size
        if size != source.observation_size:
            raise ValueError(
                f"the policy expects observations of size {source.observation_size}, the env"
                f" gives {size}: its env config does not match the one it was trained with"
            )
    return env


def _check_fixed(source: ActionSource, env: env_lib.QuadrupedEnv) -> None:
    if env.config.controller != "oscillator":
        raise ValueError("fixed rhythm parameters need the env option controller='oscillator'")
    if source.fixed_parameters is None:
        return
    lower, upper = oscillator.parameter_bounds(env.config.period_min)
    for name, value, low, high in zip(PARAMETER_NAMES, source.fixed_parameters, lower, upper):
        if not low <= value <= high:
            raise ValueError(
                f"bad fixed parameters {source.name!r}: {name}={value:g} is outside"
                f" [{low:g}, {high:g}] (§3.3 ranges, T >= period_min)"
            )

