"""A trained policy as a JAX-free file (`python -m quadcos.export --policy DIR --out policy.npz`).

The .npz holds everything `quadcos.deploy.numpy_policy.NumpyPolicy` (NumPy only, one file to copy into a
robot stack) needs to give the same deterministic actions as `quadcos.load_policy(DIR).act`:

- `normalizer_mean`, `normalizer_std`: (obs,) observation statistics (std 1, mean 0 when the
  policy was trained without normalisation); Brax's `running_statistics.normalize` does not clip;
- `kernel_i` (in, out), `bias_i` (out,) of each Dense layer, `num_layers`, `activation` ("relu",
  between layers, not after the last);
- `action_size`: the last layer gives (loc, scale) of a tanh-Gaussian; the action is tanh(loc);
- `env_config`: JSON of the full quadcos env config the policy expects (observation layout:
  `observe_slope`, `observe_phase`, the command when `action_filter_tau` > 0; `control_dt`, the
  action map `action_centre` / `period_min`; its training terrain as `terrain`);
- `format`, `observation_size`.

ONNX is not offered: no maintained JAX-to-ONNX converter is among quadcos's dependencies, and
the forward pass above is a handful of matrix products.
"""

import json
import os
import pathlib

import numpy as np

from quadcos import env as env_lib
from quadcos import evaluation
from quadcos._util import overrides as config_lib
from quadcos.deploy.numpy_policy import FORMAT, NumpyPolicy
from quadcos.training import policy as policy_lib

ACTIVATION = "relu"  # quadcos.training.sac.make_networks: Brax's default, linen.relu


def policy_arrays(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """The .npz contents (see the module docstring) of the run or policy directory `path`.

    Raises:
      FileNotFoundError, ValueError: no loadable policy there, no saved env config, or env
        options this quadcos does not know (see `evaluation.policy_source`).
    """
    source = evaluation.policy_source(path)  # checks the files and the saved env config
    policy = policy_lib.load_policy(path)
    config = config_lib.apply_overrides(env_lib.default_config(), source.env_overrides)
    config.terrain = source.training_terrain
    layers = policy.params["policy"]["params"]
    names = sorted(layers, key=lambda name: int(name.rsplit("_", 1)[1]))  # hidden_0, hidden_1, ...
    arrays = {
        "format": np.asarray(FORMAT),
        "observation_size": np.asarray(policy.spec.observation_size),
        "action_size": np.asarray(policy.spec.action_size),
        "activation": np.asarray(ACTIVATION),
        "num_layers": np.asarray(len(names)),
        "normalizer_mean": np.asarray(policy.params["normalizer"]["mean"], np.float32),
        "normalizer_std": np.asarray(policy.params["normalizer"]["std"], np.float32),
        "env_config": np.asarray(json.dumps(config.to_dict())),
    }
    for index, name in enumerate(names):
        arrays[f"kernel_{index}"] = np.asarray(layers[name]["kernel"], np.float32)
        arrays[f"bias_{index}"] = np.asarray(layers[name]["bias"], np.float32)
    return arrays


def numpy_policy(path: str | os.PathLike[str]) -> NumpyPolicy:
    """A policy directory (or an exported .npz) as a NumpyPolicy, without writing a file."""
    if str(path).endswith(".npz"):
        return NumpyPolicy.load(path)
    return NumpyPolicy.from_arrays(policy_arrays(path), source=str(path))


def export_policy(
    path: str | os.PathLike[str], out: str | os.PathLike[str], robot: str | None = None
) -> pathlib.Path:
    """Writes the policy (run or policy directory) at `path` to the .npz `out`, atomically;
    `robot`, when given, must be the robot the policy was trained on (its env config names it).

    Raises:
      FileNotFoundError, ValueError: no loadable policy at `path`, `out` is not a .npz path, or
        the policy drives another robot.
    """
    out = pathlib.Path(out)
    if out.suffix != ".npz":
        raise ValueError(f"--out must end in .npz; got {out}")
    arrays = policy_arrays(path)
    trained_on = json.loads(str(arrays["env_config"]))["robot"]
    if robot is not None and robot != trained_on:
        raise ValueError(f"the policy {path} was trained on robot {trained_on!r}, not {robot!r}")
    temporary = out.with_name(f".{out.name}.tmp-{os.getpid()}.npz")
    np.savez(temporary, **arrays)
    os.replace(temporary, out)
    return out
