"""A SAC policy exported by `python -m quadcos.export --out policy.onnx`, run with ONNX Runtime.

Copy this file to a robot stack (it needs numpy and onnxruntime, no JAX, no quadcos):
`OnnxPolicy.load("policy.onnx")(obs) -> action`, deterministic (the tanh of the Gaussian mean).
The graph: input "observation" float32 (batch, observation_size), output "action" float32
(batch, action_size). Its metadata (`model.metadata_props`): `format` ("quadcos.onnx_policy"),
`env_config` (JSON of the quadcos env config the policy was trained in: observation layout,
control_dt, action map, robot, training terrain), `observation_size`, `action_size`.

A policy trained with velocity commands has a second input, "command" float32 (batch, 2): v*
(m/s), ω* (rad/s); "observation" is then (batch, observation_size − 2), and the metadata holds
the command ranges `command_speed_min`, `command_speed_max` (m/s), `command_yaw_rate_max`
(rad/s) and `command_resample_seconds` (s) (`OnnxPolicy.command_ranges`). Called with the whole
observation (the command as its last two values, as the env's), `OnnxPolicy` splits it.
"""

import json
import os

import numpy as np

FORMAT = "quadcos.onnx_policy"
INPUT, COMMAND, OUTPUT = "observation", "command", "action"
COMMAND_KEYS = (
    "command_speed_min",
    "command_speed_max",
    "command_yaw_rate_max",
    "command_resample_seconds",
)


class OnnxPolicy:
    """An ONNX Runtime session of the exported graph, with the env config from its metadata."""

    def __init__(self, session, metadata: dict[str, str], source: str = "model"):
        self.session, self.source = session, source
        try:
            if metadata["format"] != FORMAT:
                raise KeyError("format")
            self.env_config = json.loads(metadata["env_config"])
            self.observation_size = int(metadata["observation_size"])
            self.action_size = int(metadata["action_size"])
            commanded = COMMAND_KEYS[0] in metadata
            # {"speed_min": m/s, ...} of a commanded policy, else {}
            self.command_ranges = {
                key.removeprefix("command_"): float(metadata[key])
                for key in (COMMAND_KEYS if commanded else ())
            }
        except (KeyError, ValueError) as error:
            what = f"metadata {error.args[0]!r}" if isinstance(error, KeyError) else str(error)
            raise ValueError(f"{source} is not a {FORMAT} file: {what} missing or wrong") from None
        self.command_size = 2 if commanded else 0
        names = [INPUT, COMMAND] if commanded else [INPUT]
        sizes = [self.observation_size - self.command_size, self.command_size][: len(names)]
        inputs, outputs = session.get_inputs(), session.get_outputs()
        if (
            [node.name for node in inputs] != names
            or [node.name for node in outputs] != [OUTPUT]
            or [node.shape[-1] for node in inputs] != sizes
        ):
            expected = ", ".join(f"{name!r} (batch, {size})" for name, size in zip(names, sizes))
            raise ValueError(
                f"{source}: the graph does not take {expected} to {OUTPUT!r} as its metadata says"
            )

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> "OnnxPolicy":
        """Reads a policy .onnx. Raises FileNotFoundError, or ValueError for another file."""
        import onnxruntime  # the export extra: only needed for .onnx files
        from onnxruntime.capi import onnxruntime_pybind11_state as errors

        if not os.path.isfile(path):
            raise FileNotFoundError(f"no exported policy at {path}")
        options = onnxruntime.SessionOptions()
        options.log_severity_level = 3  # errors only: a robot loop's stderr stays readable
        unloadable = (
            errors.Fail,
            errors.InvalidArgument,
            errors.InvalidGraph,
            errors.InvalidProtobuf,
            errors.NotImplemented,
            errors.RuntimeException,
        )
        try:
            session = onnxruntime.InferenceSession(
                os.fspath(path), options, providers=["CPUExecutionProvider"]
            )
        except unloadable as error:
            message = str(error).strip().splitlines()[0] if str(error).strip() else "unreadable"
            raise ValueError(f"{path} is not an ONNX model: {message}") from None
        metadata = dict(session.get_modelmeta().custom_metadata_map)
        return cls(session, metadata, source=os.fspath(path))

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        """(..., action_size) actions in [−1, 1] for (..., observation_size) observations (a
        commanded policy's: the command last)."""
        observation = np.asarray(observation, np.float32)
        batch = observation.reshape(-1, self.observation_size)
        split = self.observation_size - self.command_size
        feeds = {INPUT: batch[:, :split]}
        if self.command_size:
            feeds[COMMAND] = batch[:, split:]
        (action,) = self.session.run([OUTPUT], feeds)
        return action.reshape(*observation.shape[:-1], self.action_size)
