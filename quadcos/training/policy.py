"""A trained SAC policy as a standalone, loadable object.

On disk a policy is a directory with `params.msgpack` (flax msgpack of the
observation statistics and the policy network parameters) and `policy.json`
(sizes, hidden sizes, normalisation flag and a copy of the run config).
"""

import dataclasses
import functools
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import flax.serialization
import jax
import jax.numpy as jnp
import numpy as np
from brax.training.acme import running_statistics
from brax.training.agents.sac import networks as sac_networks

from quadcos._util import files
from quadcos.training import sac

_FORMAT = "quadcos.sac_policy"
_FORMAT_VERSION = 1
_PARAMS_FILE = "params.msgpack"
_SPEC_FILE = "policy.json"


class PolicyPart(NamedTuple):
    """The part of a training state a policy is made of; `Policy.from_training_state` takes it
    as it takes the whole state."""

    normalizer_params: running_statistics.RunningStatisticsState
    policy_params: Any

    @classmethod
    def copy_of(cls, state: sac.TrainingState) -> "PolicyPart":
        """A copy on the device (dispatched, not awaited) that outlives `state` when the state
        is donated to a compiled program."""
        return _copied(cls(state.normalizer_params, state.policy_params))


@jax.jit
def _copied(part: PolicyPart) -> PolicyPart:
    """`part` copied leaf by leaf, one program for all of them (not one per leaf's shape)."""
    return jax.tree.map(jnp.copy, part)


@dataclasses.dataclass(frozen=True)
class PolicySpec:
    """What it takes to rebuild the policy network."""

    observation_size: int
    action_size: int
    hidden_sizes: tuple[int, ...]
    normalize_observations: bool


def _deterministic_action(
    networks: sac_networks.SACNetworks,
    params: dict[str, Any],
    observation: jax.Array,
) -> jax.Array:
    normalizer = running_statistics.NestedMeanStd(
        mean=params["normalizer"]["mean"], std=params["normalizer"]["std"]
    )
    logits = networks.policy_network.apply(normalizer, params["policy"], observation)
    return networks.parametric_action_distribution.mode(logits)


class Policy:
    """Deterministic SAC policy: the tanh of the Gaussian mean."""

    def __init__(
        self,
        spec: PolicySpec,
        params: dict[str, Any],
        config: dict[str, Any] | None = None,
    ):
        """Wraps trained parameters.

        Args:
          spec: sizes and options of the network.
          params: {'normalizer': {'mean', 'std'}, 'policy': flax params}.
          config: the run config to keep with the policy (JSON-serialisable).
        """
        self.spec = spec
        self.params = jax.device_put(params)
        self.config = dict(config or {})
        self._apply = jax.jit(action_function(spec))

    @classmethod
    def from_training_state(
        cls,
        state: sac.TrainingState | PolicyPart,
        spec: PolicySpec,
        config: dict[str, Any] | None = None,
    ) -> "Policy":
        """Copies the policy part of a training state (or a `PolicyPart`) to the host: the
        normaliser's first `spec.observation_size` entries (beyond them a privileged critic's)."""
        own = slice(spec.observation_size)
        params = jax.device_get(
            {
                "normalizer": {
                    "mean": state.normalizer_params.mean[own],
                    "std": state.normalizer_params.std[own],
                },
                "policy": state.policy_params,
            }
        )
        return cls(spec, params, config)

    def act(self, observation: jax.Array) -> jax.Array:
        """Actions in [-1, 1] for observations of shape (..., observation_size)."""
        return self._apply(self.params, jnp.asarray(observation))


def save_policy(path: str | os.PathLike[str], policy: Policy) -> Path:
    """Writes `policy` to the directory `path` (replaced atomically)."""
    spec_json = {
        "format": _FORMAT,
        "format_version": _FORMAT_VERSION,
        **dataclasses.asdict(policy.spec),
        "distribution": "tanh_normal",
        "activation": "relu",
        "config": policy.config,
    }

    def fill(directory: Path) -> None:
        (directory / _PARAMS_FILE).write_bytes(flax.serialization.to_bytes(policy.params))
        (directory / _SPEC_FILE).write_text(json.dumps(spec_json, indent=2), encoding="utf-8")

    files.atomic_replace_dir(path, fill)
    return Path(path)


def load_policy(path: str | os.PathLike[str]) -> Policy:
    """Loads a policy from a policy directory or a run directory.

    Raises:
      FileNotFoundError: no policy.json in `path` or `path`/policy.
      ValueError: a policy file that cannot be read, naming it and the likely cause.
    """
    path = Path(path)
    if not (path / _SPEC_FILE).exists() and (path / "policy" / _SPEC_FILE).exists():
        path = path / "policy"
    spec_path, params_path = path / _SPEC_FILE, path / _PARAMS_FILE
    if not spec_path.exists():
        raise FileNotFoundError(f"no policy in {path}: expected {_SPEC_FILE} there or in policy/")
    try:
        spec_json = json.loads(spec_path.read_text(encoding="utf-8"))
        if spec_json.get("format") != _FORMAT:
            raise ValueError(f"its format is not {_FORMAT!r}")
        spec = PolicySpec(
            observation_size=spec_json["observation_size"],
            action_size=spec_json["action_size"],
            hidden_sizes=tuple(spec_json["hidden_sizes"]),
            normalize_observations=spec_json["normalize_observations"],
        )
        template = _params_template(spec)
    except (ValueError, KeyError, TypeError, AttributeError) as error:
        raise _unreadable(spec_path, "truncated, damaged or not a quadcos policy", error) from None
    try:
        params = flax.serialization.from_bytes(template, params_path.read_bytes())
    except OSError as error:
        raise _unreadable(params_path, "missing or unreadable", error) from None
    except Exception as error:  # msgpack and flax raise many types
        raise _unreadable(
            params_path, f"truncated, damaged or not the network {_SPEC_FILE} describes", error
        ) from None
    return Policy(spec, params, spec_json.get("config"))


def _unreadable(path: Path, cause: str, error: Exception) -> ValueError:
    detail = str(error).splitlines()[0] if str(error) else ""
    return ValueError(
        f"policy file {path} cannot be read, likely {cause}"
        f" ({type(error).__name__}: {detail:.200});"
        " copy it again from its run directory"
    )


@functools.lru_cache(maxsize=8)
def action_function(spec: PolicySpec) -> Callable[[dict[str, Any], jax.Array], jax.Array]:
    """(params, observation) -> the deterministic action of any policy of `spec`: one function
    per network shape, so that programs compiled for one policy (an evaluation's rollout) run
    every other policy of that shape, its parameters an argument."""
    return functools.partial(_deterministic_action, _networks(spec))


def _networks(spec: PolicySpec) -> sac_networks.SACNetworks:
    """The SAC networks a policy of `spec` was trained with (only the policy is used)."""
    return sac.make_networks(
        spec.observation_size,
        spec.action_size,
        spec.hidden_sizes,
        spec.hidden_sizes,
        spec.normalize_observations,
    )


def _params_template(spec: PolicySpec) -> dict[str, Any]:
    networks = _networks(spec)
    policy_params = jax.eval_shape(networks.policy_network.init, jax.random.PRNGKey(0))
    zeros = lambda x: np.zeros(x.shape, x.dtype)
    return {
        "normalizer": {
            "mean": np.zeros((spec.observation_size,), np.float32),
            "std": np.ones((spec.observation_size,), np.float32),
        },
        "policy": jax.tree.map(zeros, policy_params),
    }
