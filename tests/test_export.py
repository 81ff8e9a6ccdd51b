"""`quadcos.export` / `quadcos.numpy_policy` / `quadcos.deploy.onnx_policy`: the exported .npz and
.onnx give the JAX policy's actions."""

import json
import pathlib
import subprocess
import sys

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper

from quadcos import export, sim2sim
from quadcos.deploy import engines, host_robot
from quadcos.deploy import export as export_lib
from quadcos.deploy import onnx_policy
from quadcos.deploy.numpy_policy import NumpyPolicy
from quadcos.deploy.onnx_policy import OnnxPolicy
from quadcos.training import load_policy

ROOT = pathlib.Path(__file__).resolve().parent.parent
POLICIES = ROOT / "experiments" / "policies"


def _recorded_observations(name: str) -> np.ndarray:
    """Observations of 2 s of walking under policy `name` on its training terrain in C MuJoCo,
    then normaliser-scaled noise (3 std around the mean)."""
    pilot = host_robot.Pilot.load(str(POLICIES / name))
    host = host_robot.HostRobot(pilot.spec.training_terrain, pilot.config)
    act = pilot.actor()
    observations = [host.reset(0)]
    for _ in range(40):
        observations.append(host.step(act(observations[-1])).obs)
    policy = pilot.policy
    noise = np.random.default_rng(0).normal(size=(64, policy.observation_size))
    return np.concatenate([np.stack(observations), policy.mean + 3.0 * policy.std * noise])


@pytest.mark.parametrize("name", ["flat", "slope5"])
def test_exported_actions_equal_the_jax_policy(tmp_path, name):
    out = export_lib.export_policy(POLICIES / name, tmp_path / f"{name}.npz")
    exported = NumpyPolicy.load(out)
    observations = _recorded_observations(name)
    jax_actions = np.asarray(load_policy(POLICIES / name).act(observations.astype(np.float32)))
    assert np.abs(exported(observations) - jax_actions).max() <= 1e-5
    assert np.abs(exported(observations[0]) - jax_actions[0]).max() <= 1e-5  # unbatched
    saved = json.loads((POLICIES / name / "policy.json").read_text())["config"]["run_info"]["env"]
    for key in ("observe_slope", "observe_phase", "action_filter_tau", "control_dt", "terrain"):
        assert exported.env_config[key] == saved[key]


def test_numpy_policy_imports_numpy_only(tmp_path):
    export_lib.export_policy(POLICIES / "flat", tmp_path / "flat.npz")
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
    assert export.main(["--policy", str(POLICIES / "flat"), "--out", str(tmp_path / "a.pt")]) == 2
    no_folder = tmp_path / "no" / "a.onnx"
    assert export.main(["--policy", str(POLICIES / "flat"), "--out", str(no_folder)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 3 and "nowhere" in lines[0] and ".npz or .onnx" in lines[1]
    assert lines[2].endswith(f"{no_folder.parent} is not a directory"), lines[2]
    assert export.main(["--policy", str(POLICIES / "flat"), "--out", str(tmp_path / "a.onnx")]) == 0
    assert OnnxPolicy.load(tmp_path / "a.onnx").action_size == 5
    assert sorted(path.name for path in tmp_path.iterdir()) == ["a.onnx", "flat.npz"]  # no temp


# --- ONNX ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("name, action_size", [("flat", 5), ("any_slope", 7)])
def test_onnx_runtime_gives_the_jax_policys_actions(tmp_path, name, action_size):
    out = export_lib.export_policy(POLICIES / name, tmp_path / f"{name}.onnx")
    exported = OnnxPolicy.load(out)
    jax_policy = load_policy(POLICIES / name)
    noise = np.random.default_rng(1).normal(size=(1000, exported.observation_size))
    mean = np.asarray(jax_policy.params["normalizer"]["mean"])
    std = np.asarray(jax_policy.params["normalizer"]["std"])
    observations = (mean + 3.0 * std * noise).astype(np.float32)
    jax_actions = np.asarray(jax_policy.act(observations))
    actions = exported(observations)
    assert actions.shape == (1000, action_size) and actions.dtype == np.float32
    assert np.abs(actions - jax_actions).max() <= 1e-5
    assert np.abs(exported(observations[7]) - jax_actions[7]).max() <= 1e-5  # a batch of one

    model = onnx.load(out)
    metadata = {prop.key: prop.value for prop in model.metadata_props}
    arrays = export_lib.policy_arrays(POLICIES / name)
    assert metadata["format"] == onnx_policy.FORMAT
    assert json.loads(metadata["env_config"]) == json.loads(str(arrays["env_config"]))
    assert exported.env_config == NumpyPolicy.from_arrays(arrays).env_config
    assert int(metadata["observation_size"]) == exported.observation_size == mean.size
    assert int(metadata["action_size"]) == action_size
    saved = json.loads((POLICIES / name / "policy.json").read_text())["config"]["run_info"]["env"]
    for key in ("observe_slope", "observe_phase", "action_filter_tau", "control_dt", "terrain"):
        assert exported.env_config[key] == saved[key]
    assert [value.name for value in model.graph.input] == ["observation"]
    assert model.graph.input[0].type.tensor_type.shape.dim[0].dim_param == "batch"
    assert {node.op_type for node in model.graph.node} == {
        "Sub",
        "Div",
        "MatMul",
        "Add",
        "Relu",
        "Tanh",
    }


def _tiny_onnx(path: pathlib.Path) -> pathlib.Path:
    """A valid ONNX model (observation -> action, Identity) without quadcos's metadata."""
    shape = ["batch", 19]
    graph = helper.make_graph(
        [helper.make_node("Identity", ["observation"], ["action"])],
        "tiny",
        [helper.make_tensor_value_info("observation", TensorProto.FLOAT, shape)],
        [helper.make_tensor_value_info("action", TensorProto.FLOAT, shape)],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=8)
    onnx.save(model, path)
    return path


def test_onnx_that_is_not_a_quadcos_policy_is_named(tmp_path, capsys):
    tiny = _tiny_onnx(tmp_path / "tiny.onnx")
    plain = "tiny.onnx is not a quadcos.onnx_policy file: metadata 'format' missing"
    with pytest.raises(ValueError, match=plain):
        OnnxPolicy.load(tiny)
    (tmp_path / "text.onnx").write_text("not a protobuf")
    with pytest.raises(ValueError, match="text.onnx is not an ONNX model"):
        OnnxPolicy.load(tmp_path / "text.onnx")
    with pytest.raises(FileNotFoundError, match="missing.onnx"):
        OnnxPolicy.load(tmp_path / "missing.onnx")
    for policy in (tiny, tmp_path / "text.onnx"):
        out = tmp_path / "x.json"
        assert sim2sim.main([f"--policy={policy}", f"--out={out}", "--no_progress"]) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and policy.name in lines[0] and not out.exists()


def test_onnx_for_another_observation_size_is_refused(tmp_path, capsys):
    out = export_lib.export_policy(POLICIES / "flat", tmp_path / "flat.onnx")
    model = onnx.load(out)
    for prop in model.metadata_props:
        if prop.key == "env_config":  # the env then adds the slope estimate: 20 values, not 19
            prop.value = json.dumps(json.loads(prop.value) | {"observe_slope": True})
    onnx.save(model, tmp_path / "other.onnx")
    with pytest.raises(ValueError, match="other.onnx expects observations of size 19"):
        engines.evaluate(
            str(tmp_path / "other.onnx"), "flat", engine="mujoco", episodes=1, seconds=0.1
        )
    argv = [f"--policy={tmp_path / 'other.onnx'}", f"--out={tmp_path / 'x.json'}", "--no_progress"]
    assert sim2sim.main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "other.onnx" in lines[0] and "20" in lines[0]


# --- one way to name a policy -------------------------------------------------------------------


def test_a_policy_spec_parses_each_kind_and_knows_its_env(tmp_path):
    from quadcos.evaluation import PolicySpec

    directory = PolicySpec.parse(str(POLICIES / "flat"))
    npz = PolicySpec.parse(str(export_lib.export_policy(directory, tmp_path / "flat.npz")))
    onnx_spec = PolicySpec.parse(str(export_lib.export_policy(directory, tmp_path / "flat.onnx")))
    fixed = PolicySpec.parse("fixed:0.4,0.15,0.6,pi/2,-pi/2")
    assert [spec.kind for spec in (directory, npz, onnx_spec, fixed)] == [
        "directory",
        "npz",
        "onnx",
        "fixed",
    ]
    for spec in (npz, onnx_spec):
        assert spec.env_config().to_dict() == directory.env_config().to_dict()
        assert (spec.training_terrain, spec.robot) == ("flat", "quadcos")
        assert (spec.observation_size, spec.action_size) == (19, 5)
        with pytest.raises(ValueError, match="exported .* run it with the mujoco engine"):
            spec.action_source()
        with pytest.raises(ValueError, match="is not a run or policy directory"):
            export_lib.policy_arrays(spec)
    assert fixed.fixed_parameters == pytest.approx((0.4, 0.15, 0.6, np.pi / 2, -np.pi / 2))
    assert (fixed.path, fixed.training_terrain, fixed.env_options) == (None, "flat", {})
    assert fixed.env_config({"robot": "quad12"}).robot == "quad12"  # fixed parameters: any robot
    with pytest.raises(ValueError, match="trained on robot 'quadcos', not 'quad12'"):
        directory.env_config({"robot": "quad12"})


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "bad policy ''"),
        ("fixed:0.4,0.15", "bad fixed parameters '0.4,0.15'"),
        ("fixed:walk", "bad fixed parameters 'walk'"),
        ("README.md", "bad policy 'README.md': a file that is not a run or policy directory"),
        ("other.npz", "other.npz is not an exported quadcos policy"),
        ("other.onnx", "other.onnx is not an exported quadcos policy"),
    ],
)
def test_a_bad_policy_spec_is_a_value_error_naming_it(tmp_path, monkeypatch, text, message):
    from quadcos.evaluation import PolicySpec

    monkeypatch.chdir(tmp_path)
    (tmp_path / "README.md").write_text("not a policy")
    np.savez(tmp_path / "other.npz", weights=np.zeros(3))
    _tiny_onnx(tmp_path / "other.onnx")
    with pytest.raises(ValueError, match=message):
        PolicySpec.parse(text)
    with pytest.raises(FileNotFoundError, match="no policy at nowhere.npz"):
        PolicySpec.parse("nowhere.npz")
