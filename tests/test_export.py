"""`quadcos.export` / `quadcos.numpy_policy`: the exported .npz gives the JAX policy's actions."""

import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from quadcos import export, sim2sim
from quadcos.deploy.numpy_policy import NumpyPolicy
from quadcos.training import load_policy

ROOT = pathlib.Path(__file__).resolve().parent.parent
POLICIES = ROOT / "experiments" / "policies"


def _recorded_observations(name: str) -> np.ndarray:
    """Observations of 2 s of walking under policy `name` on its training terrain in C MuJoCo,
    then normaliser-scaled noise (3 std around the mean)."""
    pilot = sim2sim.load_pilot(str(POLICIES / name))
    host = sim2sim.HostRobot(pilot.training_terrain, pilot.config)
    act = pilot.actor()
    observations = [host.reset(0)]
    for _ in range(40):
        observations.append(host.step(act(observations[-1])).obs)
    policy = pilot.policy
    noise = np.random.default_rng(0).normal(size=(64, policy.observation_size))
    return np.concatenate([np.stack(observations), policy.mean + 3.0 * policy.std * noise])


@pytest.mark.parametrize("name", ["flat", "slope5"])
def test_exported_actions_equal_the_jax_policy(tmp_path, name):
    out = export.export_policy(POLICIES / name, tmp_path / f"{name}.npz")
    exported = NumpyPolicy.load(out)
    observations = _recorded_observations(name)
    jax_actions = np.asarray(load_policy(POLICIES / name).act(observations.astype(np.float32)))
    assert np.abs(exported(observations) - jax_actions).max() <= 1e-5
    assert np.abs(exported(observations[0]) - jax_actions[0]).max() <= 1e-5  # unbatched
    saved = json.loads((POLICIES / name / "policy.json").read_text())["config"]["run_info"]["env"]
    for key in ("observe_slope", "observe_phase", "action_filter_tau", "control_dt", "terrain"):
        assert exported.env_config[key] == saved[key]


def test_numpy_policy_imports_numpy_only(tmp_path):
    export.export_policy(POLICIES / "flat", tmp_path / "flat.npz")
    script = (
        "import sys, importlib.util\n"
        "for name in ('jax', 'flax', 'brax', 'quadcos', 'mujoco'): sys.modules[name] = None\n"
        f"path = {str(ROOT / 'quadcos' / 'deploy' / 'numpy_policy.py')!r}\n"
        "spec = importlib.util.spec_from_file_location('np_policy', path)\n"
        "module = importlib.util.module_from_spec(spec); spec.loader.exec_module(module)\n"
        f"policy = module.NumpyPolicy.load({str(tmp_path / 'flat.npz')!r})\n"
        "print(policy([0.0] * policy.observation_size).shape)\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "(5,)"


def test_bad_files_are_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="missing.npz"):
        NumpyPolicy.load(tmp_path / "missing.npz")
    np.savez(tmp_path / "other.npz", weights=np.zeros(3))
    with pytest.raises(ValueError, match="other.npz"):
        NumpyPolicy.load(tmp_path / "other.npz")
    (tmp_path / "text.npz").write_text("not a zip")
    with pytest.raises(ValueError, match="text.npz"):
        NumpyPolicy.load(tmp_path / "text.npz")


def test_cli_exports_and_refuses_bad_input(tmp_path, capsys):
    out = tmp_path / "flat.npz"
    assert export.main(["--policy", str(POLICIES / "flat"), "--out", str(out)]) == 0
    assert NumpyPolicy.load(out).action_size == 5
    capsys.readouterr()
    assert export.main(["--policy", str(tmp_path / "nowhere"), "--out", str(out)]) == 2
    assert export.main(["--policy", str(POLICIES / "flat"), "--out", str(tmp_path / "a.onnx")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 2 and "nowhere" in lines[0] and ".npz" in lines[1]
