"""What acts in an evaluation, named once: a `PolicySpec` parsed from a --policy string.

A spec is a run or policy directory, an exported .npz / .onnx (`quadcos.deploy.export`) or fixed
rhythm parameters (`fixed:...`); it knows the env config its policy was trained in (a run's saved
config, `quadcos.training.run_config`; an exported file's `env_config`). `env_config` is the one
builder of an evaluation's env config, for the MJX engine (`build_env`) and the C MuJoCo one
(`quadcos.deploy`). An `ActionSource` is what the MJX rollout calls for actions: a source of
actions, not a controller in the paper's sense (the rhythm controller is the oscillator inside
the env, `quadcos.equations.oscillator`).
"""

import ast
import collections
import dataclasses
import json
import math
import operator
import os
import pathlib
from collections.abc import Callable, Mapping
from typing import Any

import jax
import jax.numpy as jnp
import ml_collections
import numpy as np

from quadcos import env as env_lib
from quadcos import terrain as terrain_lib
from quadcos._util.overrides import apply_overrides, flatten
from quadcos.equations import oscillator
from quadcos.training import run_config as runs

FIXED_PREFIX = "fixed:"
# `gait:DIR`: the zero action in DIR's env: its action centre (the searched gait, where the run
# searched one) under its drive, as the untrained actor acts it (its outputs scaled by
# `sac.policy_output_scale`, 0.01 in the presets that search): the step-0 policy a trained one is
# measured against. Oscillator policies only: a joint controller's zero action stands.
GAIT_PREFIX = "gait:"
PARAMETER_NAMES = oscillator.RhythmParameters._fields


@dataclasses.dataclass(frozen=True)
class ActionSource:
    """What chooses actions, and the env it must run in.

    Attributes:
      name: the --policy string (or a description).
      kind: "sac", "fixed" or "gait" (the zero action, `GAIT_PREFIX`).
      act: (params, obs (n, obs_size)) -> actions (n, action_size); jit-able.
      params: the first argument of `act` (fixed: the (5,) parameters; gait: (action_size,)
        zeros; sac: the network's).
      env_overrides: env config overrides (dotted keys) that rebuild the training env.
      training_terrain: the terrain spec the policy was trained on ("flat" for fixed parameters).
      fixed_parameters: the rhythm parameters of a fixed source, else None.
      observation_size, action_size: what the policy expects (None: anything).
      env_steps: the env steps of training behind the policy (`PolicySpec.env_steps`).
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
    env_steps: int | None = None


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


def zero_action(zeros: jax.Array, obs: jax.Array) -> jax.Array:
    """(n, action_size) zeros: the action centre for each of the n observations."""
    return jnp.broadcast_to(zeros, (obs.shape[0], zeros.shape[-1]))


def _constant_action(actions: jax.Array, obs: jax.Array) -> jax.Array:
    """The (n, action_size) actions that `rollout` computed from the fixed parameters for its
    env (`QuadrupedEnv.action_for`)."""
    del obs
    return actions



@dataclasses.dataclass(frozen=True)
class PolicySpec:
    """A --policy value, parsed once (`PolicySpec.parse`): what acts, and the env it was trained in.

    Attributes:
      text: the --policy string.
      kind: "directory" (a run or policy directory), "npz" or "onnx" (an exported policy,
        `quadcos.deploy.export`), "fixed" (rhythm parameters) or "gait" (a directory's zero
        action, `GAIT_PREFIX`).
      env_options: the env config options (dotted keys) the policy was trained with, terrain
        excluded; {} for fixed parameters (the default env).
      training_terrain: the terrain spec it was trained on ("flat" for fixed parameters).
      path: the directory or file; None for fixed parameters.
      fixed_parameters: the rhythm parameters of a fixed spec, else None.
      observation_size, action_size: what the policy expects (None for fixed parameters).
      env_steps: the env steps of training behind the policy (0: the gait search's gait under
        the untrained actor); None where unknown (fixed parameters, a file or a policy saved
        without it). A policy directory records it in its policy.json's config: `env_steps` (a
        run's last policy) or `best_of_run.step` (its best, policy_best/).
      policy: the loaded `quadcos.training.Policy` of a directory, else None.
    """

    text: str
    kind: str
    env_options: Mapping[str, Any]
    training_terrain: str
    path: pathlib.Path | None = None
    fixed_parameters: oscillator.RhythmParameters | None = None
    observation_size: int | None = None
    action_size: int | None = None
    env_steps: int | None = None
    policy: Any = dataclasses.field(default=None, compare=False, repr=False)

    @classmethod
    def parse(cls, text: str | os.PathLike[str]) -> "PolicySpec":
        """`fixed:trot`, `fixed:A_k,A_h,T,phi1,phi3`, a run or policy directory, `gait:` and
        one (its zero action), or an exported .npz / .onnx.

        Raises:
          FileNotFoundError: no such file or directory.
          ValueError: anything else that is not a policy, naming `text`.
        """
        text = os.fspath(text)
        if text.startswith(FIXED_PREFIX):
            parameters = parse_fixed(text[len(FIXED_PREFIX) :])
            return cls(text, "fixed", {}, "flat", fixed_parameters=parameters)
        if text.startswith(GAIT_PREFIX):
            return _gait_spec(text)
        if not text.strip():
            raise ValueError(f"bad policy {text!r}: expected {POLICY_FORMS}")
        path = pathlib.Path(text)
        if not path.exists():
            raise FileNotFoundError(f"no policy at {text}: no such file or directory")
        if path.is_dir():
            return _directory_spec(text, path)
        kind = path.suffix.lower().removeprefix(".")
        if kind not in EXPORTED_KINDS:
            raise ValueError(f"bad policy {text!r}: a file that is not {POLICY_FORMS}")
        saved = dict(_exported_env(text, path, kind))
        observation_size, action_size = (int(saved.pop(key)) for key in _SIZES)
        env_steps = saved.pop(ENV_STEPS, None)
        terrain = str(saved.pop("terrain", "flat"))
        return cls(
            text,
            kind,
            flatten(saved),
            terrain,
            path,
            None,
            observation_size,
            action_size,
            None if env_steps is None else int(env_steps),
        )

    @property
    def source_kind(self) -> str:
        """What acts, as an evaluation's setup records it: "fixed", "gait" or "sac" (a trained
        network: a directory or an exported file)."""
        return self.kind if self.kind in ("fixed", "gait") else "sac"

    @property
    def robot(self) -> str:
        """The robot spec the policy was trained on (fixed parameters: the default robot's)."""
        return str(self.env_options.get("robot", env_lib.default_config().robot))

    def env_config(self, overrides: Mapping[str, Any] | None = None) -> ml_collections.ConfigDict:
        """The config of the env this policy is evaluated in (`env_config` with its trained
        options); fixed parameters: checked against the config's ranges.

        Raises:
          ValueError: a bad override, another robot than a trained policy's, fixed parameters
            out of range, or options this quadcos cannot build (naming the policy).
        """
        try:
            config = env_config(overrides, self.env_options, keep_robot=self.kind != "fixed")
        except ValueError as error:
            raise ValueError(f"the policy {self.text}: {error}") from None
        if self.kind == "fixed":
            _check_fixed(self.text, self.fixed_parameters, config)
        return config

    def action_source(self) -> ActionSource:
        """The JAX action source of a directory, gait or fixed spec (the MJX engine's).

        Raises:
          ValueError: an exported policy (.npz, .onnx), which runs only in C MuJoCo.
        """
        if self.kind == "fixed":
            return fixed_source(self.fixed_parameters, name=self.text)
        if self.kind == "gait":
            return ActionSource(
                name=self.text,
                kind=self.source_kind,
                act=zero_action,
                params=jnp.zeros(self.action_size, jnp.float32),
                env_overrides=dict(self.env_options),
                training_terrain=self.training_terrain,
                observation_size=self.observation_size,
                action_size=self.action_size,
                env_steps=0,
            )
        if self.kind != "directory":
            raise ValueError(
                f"the policy {self.text} is an exported .{self.kind}: the mjx engine runs run or"
                " policy directories and fixed:...; run it with the mujoco engine"
            )
        from quadcos.training import policy as policy_lib

        return ActionSource(
            name=self.text,
            kind=self.source_kind,
            act=policy_lib.action_function(self.policy.spec),
            params=self.policy.params,
            env_overrides=dict(self.env_options),
            training_terrain=self.training_terrain,
            observation_size=self.observation_size,
            action_size=self.action_size,
            env_steps=self.env_steps,
        )


POLICY_FORMS = (
    "a run or policy directory, gait:DIRECTORY (its zero action), an exported .npz or .onnx,"
    " fixed:trot or fixed:A_k,A_h,T,phi1,phi3"
)
EXPORTED_KINDS = ("npz", "onnx")
_SIZES = ("observation_size", "action_size")
ENV_STEPS = "env_steps"  # an exported policy's record of `PolicySpec.env_steps`, when known


def _directory_spec(text: str, path: pathlib.Path) -> PolicySpec:
    from quadcos.training import load_policy

    try:
        policy = load_policy(path)
    except (FileNotFoundError, ValueError):
        raise
    except Exception as error:  # noqa: BLE001 -- msgpack, flax and JSON readers raise many types
        raise ValueError(
            f"cannot load the policy at {text}: {type(error).__name__}: {error}"
        ) from None
    try:
        options, terrain = trained_env(policy.config)
    except ValueError as error:
        raise ValueError(f"the policy at {text}: {error}") from None
    sizes = policy.spec.observation_size, policy.spec.action_size
    steps = _trained_env_steps(policy.config)
    return PolicySpec(
        text, "directory", options, terrain, path, None, *sizes, steps, policy=policy
    )


def _gait_spec(text: str) -> PolicySpec:
    """The spec of `gait:DIR`: DIR's env and sizes, the zero action, 0 env steps of training.

    Raises:
      FileNotFoundError: no DIR. ValueError: DIR is no directory, or drives joints directly.
    """
    inner = text[len(GAIT_PREFIX) :]
    if not inner.strip():
        raise ValueError(f"bad policy {text!r}: {GAIT_PREFIX} takes a run or policy directory")
    directory = PolicySpec.parse(inner)
    if directory.kind != "directory":
        raise ValueError(f"bad policy {text!r}: {GAIT_PREFIX} takes a run or policy directory")
    controller = directory.env_options.get("controller", env_lib.default_config().controller)
    if controller != "oscillator":
        raise ValueError(
            f"bad policy {text!r}: its env's controller is {controller!r}, whose zero action"
            " stands: a gait needs the oscillator"
        )
    return dataclasses.replace(directory, text=text, kind="gait", env_steps=0, policy=None)


def _trained_env_steps(saved: Mapping[str, Any]) -> int | None:
    """The env steps of training a policy.json's config records: `env_steps` (a run's last
    policy), else `best_of_run.step` (policy_best/); None where it records neither."""
    steps = saved.get(ENV_STEPS, saved.get("best_of_run", {}).get("step"))
    return None if steps is None else int(steps)


def _exported_env(text: str, path: pathlib.Path, kind: str) -> dict[str, Any]:
    """The env config (terrain included) and sizes an exported policy records: the .npz arrays
    `env_config`, `observation_size`, `action_size` (and `env_steps` where recorded), or the .onnx
    metadata of the same names."""
    try:
        if kind == "npz":
            with np.load(path, allow_pickle=False) as arrays:
                keys = ("env_config", *_SIZES) + ((ENV_STEPS,) if ENV_STEPS in arrays else ())
                fields = {key: str(arrays[key]) for key in keys}
        else:
            import onnx  # the export extra: only needed for .onnx files

            model = onnx.load(path, load_external_data=False)
            metadata = {prop.key: prop.value for prop in model.metadata_props}
            keys = ("env_config", *_SIZES) + ((ENV_STEPS,) if ENV_STEPS in metadata else ())
            fields = {key: metadata[key] for key in keys}
        return json.loads(fields.pop("env_config")) | fields
    except Exception as error:  # noqa: BLE001 -- zip, protobuf and JSON readers raise many types
        detail = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise ValueError(f"{text} is not an exported quadcos policy (.{kind}): {detail}") from None


def trained_env(saved: Mapping[str, Any]) -> tuple[dict[str, Any], str]:
    """The env overrides (terrain excluded) and the terrain of the env a run was trained in, from
    its saved config (a config.json's content, `quadcos.runs.migrate`).

    Raises:
      ValueError: not a quadcos run config, or options this quadcos does not know.
    """
    env_overrides = runs.env_overrides(runs.migrate(saved))
    return env_overrides, str(env_overrides.pop("terrain", "flat"))


def policy_source(path: str | os.PathLike[str]) -> ActionSource:
    """The action source of the run or policy directory `path` (`PolicySpec.parse`)."""
    return PolicySpec.parse(path).action_source()


def resolve_source(text: str) -> PolicySpec:
    """`PolicySpec.parse(text)`: the spec of a --policy value."""
    return PolicySpec.parse(text)


def env_config(
    overrides: Mapping[str, Any] | None = None,
    trained: Mapping[str, Any] | None = None,
    *,
    keep_robot: bool = False,
) -> ml_collections.ConfigDict:
    """The config of an evaluation's env, for both engines: `quadcos.env.default_config()` with
    the options a policy was `trained` with, spawning at x = 0 (an evaluation episode starts at
    the spawn point, wherever training spawned), then `overrides` (dotted keys; "terrain" is not
    one: the terrain is the evaluation's argument). `keep_robot`: refuse an override of the
    trained robot.

    Raises:
      ValueError: an unknown key, a value the env cannot run with, or another robot.
    """
    trained, overrides = dict(trained or {}), dict(overrides or {})
    trained.pop("terrain", None)
    if "terrain" in overrides:
        raise ValueError("the terrain is not an env option here: give it as the terrain")
    trained_on = trained.get("robot", env_lib.default_config().robot)
    if keep_robot and overrides.get("robot", trained_on) != trained_on:
        raise ValueError(f"it was trained on robot {trained_on!r}, not {overrides['robot']!r}")
    config = apply_overrides(env_lib.default_config(), trained | {"spawn_x_max": 0.0} | overrides)
    env_lib.validate_config(config)
    return config


def build_env(
    source: ActionSource,
    terrain: terrain_lib.Terrain | str | None = None,
    env_overrides: Mapping[str, Any] | None = None,
) -> env_lib.QuadrupedEnv:
    """The MJX env `source` runs in (`env_config`), on `terrain` (default: its training terrain).

    Raises:
      ValueError: bad terrain or override, or an env whose observation / action sizes differ from
        the policy's.
    """
    try:
        config = env_config(env_overrides, source.env_overrides, keep_robot=source.kind != "fixed")
    except ValueError as error:
        raise ValueError(f"the policy {source.name}: {error}") from None
    if source.kind == "fixed":
        _check_fixed(source.name, source.fixed_parameters, config)
    env = _env(terrain if terrain is not None else source.training_terrain, config)
    expected = source.observation_size, source.action_size
    check_sizes(source.name, expected, (env.observation_size, env.action_size))
    return env


# The envs build_env made last, by terrain (a spec, or a Terrain by identity) and config.
_ENVS: collections.OrderedDict[tuple[Any, str], env_lib.QuadrupedEnv] = collections.OrderedDict()


def _env(
    terrain: terrain_lib.Terrain | str, config: ml_collections.ConfigDict
) -> env_lib.QuadrupedEnv:
    """One env per terrain and config (the last 8): an evaluation or search that runs again in
    the same env reuses its compiled programs (`rollout`'s caches are keyed on the env) instead
    of tracing them anew."""
    key = (terrain, json.dumps(config.to_dict(), sort_keys=True, default=repr))
    if key not in _ENVS:
        _ENVS[key] = env_lib.QuadrupedEnv(terrain, config)
        while len(_ENVS) > 8:
            _ENVS.popitem(last=False)
    _ENVS.move_to_end(key)
    return _ENVS[key]


def check_sizes(
    name: str, expected: tuple[int | None, int | None], actual: tuple[int, int]
) -> None:
    """Raises ValueError when an env's (observation, action) sizes `actual` are not those the
    policy `name` expects (None: any)."""
    for what, want, got in zip(("observations of size", "actions of size"), expected, actual):
        if want is not None and want != got:
            raise ValueError(
                f"the policy {name} expects {what} {want}, the env has {got}: its env config"
                " does not match the one it was trained with"
            )


def _check_fixed(
    name: str, parameters: oscillator.RhythmParameters | None, config: ml_collections.ConfigDict
) -> None:
    """Raises ValueError unless `config` runs the oscillator and `parameters` (None: a search's,
    checked by it) lie in its ranges."""
    if config.controller != "oscillator":
        raise ValueError("fixed rhythm parameters need the env option controller='oscillator'")
    if parameters is None:
        return
    lower, upper = oscillator.parameter_bounds(config.period_min)
    for parameter, value, low, high in zip(PARAMETER_NAMES, parameters, lower, upper):
        if not low <= value <= high:
            raise ValueError(
                f"bad fixed parameters {name!r}: {parameter}={value:g} is outside"
                f" [{low:g}, {high:g}] (§3.3 ranges, T >= period_min)"
            )
