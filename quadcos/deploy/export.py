"""A trained policy as a JAX-free file: `python -m quadcos.export --policy DIR --out policy.npz`
(NumPy) or `--out policy.onnx` (ONNX, for ONNX Runtime); the format follows the extension.

The .npz holds everything `quadcos.deploy.numpy_policy.NumpyPolicy` (NumPy only, one file to copy into a
robot stack) needs to give the same deterministic actions as `quadcos.load_policy(DIR).act`:

- `normalizer_mean`, `normalizer_std`: (obs,) observation statistics (std 1, mean 0 when the
  policy was trained without normalisation); Brax's `running_statistics.normalize` does not clip;
- `kernel_i` (in, out), `bias_i` (out,) of each Dense layer, `num_layers`, `activation` ("relu",
  between layers, not after the last);
- `action_size`: the last layer gives (loc, scale) of a tanh-Gaussian; the action is tanh(loc);
- `env_config`: JSON of the full quadcos env config the policy expects (observation layout:
  `observe_slope`, `observe_phase`, the command when `action_filter_tau` > 0, the torso's angular
  velocity with `observe_angular_velocity`, the observed speed with `commands.observed_speed_tau`
  > 0, the drive's state with `commands.observe_drive`, then (v*, ω*) last; `control_dt`, the
  action map `action_centre` / `period_min`; its training terrain as `terrain`);
- `format`, `observation_size` (the whole observation, the command included);
- `env_steps`: the env steps of training behind the policy, where its directory records them
  (`PolicySpec.env_steps`);
- for a policy trained with velocity commands, its command ranges (the robot's, resolved):
  `command_speed_min`, `command_speed_max` (m/s), `command_yaw_rate_max` (rad/s),
  `command_resample_seconds` (s).

The .onnx (opset 17, built with `onnx.helper`; run by `quadcos.deploy.onnx_policy.OnnxPolicy`)
is the same forward pass as a graph: input "observation" float32 (batch, observation_size), Sub
mean, Div std, MatMul + Add with Relu between the layers, the last layer's loc columns only (the
scale half does not touch the deterministic action), Tanh; output "action" float32 (batch,
action_size). `metadata_props` hold `format` ("quadcos.onnx_policy"), `env_config` (the JSON
above), `observation_size` and `action_size`, and `env_steps` where known.

A policy trained with velocity commands takes its command as a second input, "command" float32
(batch, 2): one (v* m/s, ω* rad/s) per observation row; "observation" is then (batch,
observation_size − 2), the observation without its last two values, and the graph concatenates
the two (the policy's observation ends with the command). Its metadata adds the command ranges
above (`command_speed_min`, ...) as decimal strings.
"""

import json
import os
import pathlib

import numpy as np

from quadcos import env as env_lib
from quadcos.deploy.host_commands import COMMAND_SIZE
from quadcos.env import commands as env_commands
from quadcos._util import overrides as config_lib
from quadcos.deploy import onnx_policy
from quadcos.deploy.numpy_policy import FORMAT, NumpyPolicy
from quadcos.evaluation.sources import PolicySpec

ACTIVATION = "relu"  # quadcos.training.sac.make_networks: Brax's default, linen.relu
ONNX_OPSET = 17
ONNX_IR_VERSION = 8  # the IR of opset 17, so that older ONNX Runtimes load the file too
SUFFIXES = (".npz", ".onnx")
# The command ranges an export records (the resolved env `commands` config's keys).
COMMAND_RANGES = ("speed_min", "speed_max", "yaw_rate_max", "resample_seconds")


def policy_arrays(spec: PolicySpec | str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """The .npz contents (see the module docstring) of a run or policy directory (a
    `PolicySpec`, or its path).

    Raises:
      FileNotFoundError, ValueError: no loadable policy there, no saved env config, env options
        this quadcos does not know, or a spec that is not a directory (`PolicySpec.parse`).
    """
    spec = spec if isinstance(spec, PolicySpec) else PolicySpec.parse(spec)
    if spec.kind != "directory":
        raise ValueError(
            f"the policy {spec.text} is not a run or policy directory: only those export"
        )
    policy = spec.policy
    config = config_lib.apply_overrides(env_lib.default_config(), spec.env_options)
    config.terrain = spec.training_terrain
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
    if spec.env_steps is not None:
        arrays["env_steps"] = np.asarray(spec.env_steps)
    if env_commands.parse_commands(config.commands.spec).enabled:
        ranges = env_lib.resolve(config).commands
        arrays |= {f"command_{key}": np.asarray(float(ranges[key])) for key in COMMAND_RANGES}
    for index, name in enumerate(names):
        arrays[f"kernel_{index}"] = np.asarray(layers[name]["kernel"], np.float32)
        arrays[f"bias_{index}"] = np.asarray(layers[name]["bias"], np.float32)
    return arrays


def numpy_policy(spec: PolicySpec) -> NumpyPolicy:
    """The NumpyPolicy of a directory (without writing a file) or an exported .npz spec."""
    if spec.kind == "npz":
        return NumpyPolicy.load(spec.path)
    return NumpyPolicy.from_arrays(policy_arrays(spec), source=spec.text)


def onnx_model(arrays: dict[str, np.ndarray]):
    """The `onnx.ModelProto` of the .npz contents `arrays` (see the module docstring)."""
    import onnx  # the export extra: only needed for .onnx files
    from onnx import TensorProto, helper, numpy_helper

    count, action_size = int(arrays["num_layers"]), int(arrays["action_size"])
    observation_size = int(arrays["observation_size"])
    ranges = {f"command_{key}": arrays.get(f"command_{key}") for key in COMMAND_RANGES}
    commanded = ranges["command_speed_max"] is not None
    weights = {"mean": arrays["normalizer_mean"], "std": arrays["normalizer_std"]}
    inputs = [(onnx_policy.INPUT, observation_size - COMMAND_SIZE * commanded)]
    nodes = []
    if commanded:  # the policy's observation ends with the command
        inputs.append((onnx_policy.COMMAND, COMMAND_SIZE))
        names = [name for name, _ in inputs]
        nodes.append(helper.make_node("Concat", names, ["observed"], axis=-1))
    observed = "observed" if commanded else onnx_policy.INPUT
    nodes += [
        helper.make_node("Sub", [observed, "mean"], ["centred"]),
        helper.make_node("Div", ["centred", "std"], ["hidden_in_0"]),
    ]
    for index in range(count):
        kernel, bias = arrays[f"kernel_{index}"], arrays[f"bias_{index}"]
        if index == count - 1:  # (loc, scale): the action is tanh(loc)
            kernel, bias = kernel[:, :action_size], bias[:action_size]
        weights[f"kernel_{index}"], weights[f"bias_{index}"] = kernel, bias
        source, product = f"hidden_in_{index}", f"product_{index}"
        out = f"hidden_in_{index + 1}" if index < count - 1 else "loc"
        affine = f"affine_{index}" if index < count - 1 else out
        nodes.append(helper.make_node("MatMul", [source, f"kernel_{index}"], [product]))
        nodes.append(helper.make_node("Add", [product, f"bias_{index}"], [affine]))
        if index < count - 1:
            nodes.append(helper.make_node("Relu", [affine], [out]))
    nodes.append(helper.make_node("Tanh", ["loc"], [onnx_policy.OUTPUT]))
    graph = helper.make_graph(
        nodes,
        "quadcos_policy",
        [
            helper.make_tensor_value_info(name, TensorProto.FLOAT, ["batch", size])
            for name, size in inputs
        ],
        [
            helper.make_tensor_value_info(
                onnx_policy.OUTPUT, TensorProto.FLOAT, ["batch", action_size]
            )
        ],
        initializer=[
            numpy_helper.from_array(np.asarray(value, np.float32), name)
            for name, value in weights.items()
        ],
    )
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", ONNX_OPSET)],
        producer_name="quadcos",
        ir_version=ONNX_IR_VERSION,
    )
    metadata = {
        "format": onnx_policy.FORMAT,
        "env_config": str(arrays["env_config"]),
        "observation_size": str(observation_size),
        "action_size": str(action_size),
    }
    if "env_steps" in arrays:
        metadata["env_steps"] = str(int(arrays["env_steps"]))
    if commanded:
        metadata |= {key: repr(float(value)) for key, value in ranges.items()}
    helper.set_model_props(model, metadata)
    onnx.checker.check_model(model, full_check=True)
    return model


def export_policy(
    policy: PolicySpec | str | os.PathLike[str],
    out: str | os.PathLike[str],
    robot: str | None = None,
) -> pathlib.Path:
    """Writes the policy of a run or policy directory (a `PolicySpec` or its path) to `out`,
    atomically: a .npz, or an .onnx (needs the `onnx` package); `robot`, when given, must be the
    robot the policy was trained on (its env config names it).

    Raises:
      FileNotFoundError, ValueError: no loadable policy there, `out` ends in neither .npz nor
        .onnx or lies in no existing folder, or the policy drives another robot.
    """
    out = pathlib.Path(out)
    if out.suffix not in SUFFIXES:
        raise ValueError(f"--out must end in {' or '.join(SUFFIXES)}; got {out}")
    if not out.absolute().parent.is_dir():
        raise ValueError(f"--out {out}: {out.absolute().parent} is not a directory")
    spec = policy if isinstance(policy, PolicySpec) else PolicySpec.parse(policy)
    if robot is not None and robot != spec.robot:
        raise ValueError(f"the policy {spec.text} was trained on robot {spec.robot!r}, not {robot!r}")
    arrays = policy_arrays(spec)
    temporary = out.with_name(f".{out.name}.tmp-{os.getpid()}{out.suffix}")
    if out.suffix == ".onnx":
        temporary.write_bytes(onnx_model(arrays).SerializeToString())
    else:
        np.savez(temporary, **arrays)
    os.replace(temporary, out)
    return out
