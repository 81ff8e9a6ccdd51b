"""A SAC policy exported by `python -m quadcos.export`, run with NumPy alone (no JAX, no quadcos).

Copy this file to a robot stack: `NumpyPolicy.load("policy.npz")(obs) -> action`, deterministic
(the tanh of the Gaussian mean, as Brax's `NormalTanhDistribution.mode`). `env_config` holds the
quadcos env config the policy was trained in (observation layout, control_dt, action map).
"""

import json

import numpy as np

FORMAT = "quadcos.numpy_policy"
ACTIVATIONS = {"relu": lambda x: np.maximum(x, 0.0), "tanh": np.tanh}


class NumpyPolicy:
    """Normalise, Dense layers with the activation between them, tanh of the output's first half."""

    def __init__(self, mean, std, kernels, biases, activation, action_size, env_config):
        if activation not in ACTIVATIONS:
            raise ValueError(f"unknown activation {activation!r}; known: {', '.join(ACTIVATIONS)}")
        self.mean, self.std = np.asarray(mean, np.float64), np.asarray(std, np.float64)
        self.layers = [
            (np.asarray(kernel, np.float64), np.asarray(bias, np.float64))
            for kernel, bias in zip(kernels, biases)
        ]
        self.activation, self.action_size = activation, int(action_size)
        self.env_config = dict(env_config)
        self.observation_size = self.mean.shape[0]

    @classmethod
    def load(cls, path) -> "NumpyPolicy":
        """Reads a policy .npz. Raises FileNotFoundError, or ValueError for another file."""
        try:
            arrays = dict(np.load(path, allow_pickle=False))
        except FileNotFoundError:
            raise FileNotFoundError(f"no exported policy at {path}") from None
        except (OSError, ValueError) as error:
            raise ValueError(f"{path} is not an exported policy (.npz): {error}") from None
        return cls.from_arrays(arrays, source=path)

    @classmethod
    def from_arrays(cls, arrays: dict, source="arrays") -> "NumpyPolicy":
        """From the .npz's arrays by name; ValueError naming `source` when one is missing."""
        try:
            if str(arrays["format"]) != FORMAT:
                raise KeyError("format")
            count = int(arrays["num_layers"])
            return cls(
                arrays["normalizer_mean"],
                arrays["normalizer_std"],
                [arrays[f"kernel_{i}"] for i in range(count)],
                [arrays[f"bias_{i}"] for i in range(count)],
                str(arrays["activation"]),
                int(arrays["action_size"]),
                json.loads(str(arrays["env_config"])),
            )
        except KeyError as error:
            raise ValueError(f"{source} is not a {FORMAT} file: {error} missing or wrong") from None

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        """(..., action_size) actions in [−1, 1] for (..., observation_size) observations."""
        hidden = (np.asarray(observation, np.float64) - self.mean) / self.std
        for index, (kernel, bias) in enumerate(self.layers):
            hidden = hidden @ kernel + bias
            if index < len(self.layers) - 1:
                hidden = ACTIVATIONS[self.activation](hidden)
        return np.tanh(hidden[..., : self.action_size])
