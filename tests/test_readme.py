"""The README's code blocks run as written: the library example, and the command lines that train
on terrains of the user's own (up to the training itself, which tests/test_cli.py runs)."""

import pathlib
import re
import shlex
import sys
from unittest import mock

import pytest

from quadcos import gait_search, terrain
from quadcos import train
from quadcos import training

README = (pathlib.Path(__file__).resolve().parent.parent / "README.md").read_text()
PYTHON_BLOCKS = re.findall(r"```python\n(.*?)```", README, re.S)
BASH_BLOCKS = re.findall(r"```bash\n(.*?)```", README, re.S)
MODULE_HEADER = "# my_courses.py\n"
EVALUATION_HEADER = "# Evaluate a policy from Python.\n"


@pytest.fixture
def registry(monkeypatch):
    """The README registers terrains; keep them out of the other tests."""
    monkeypatch.setattr(terrain, "_REGISTRY", dict(terrain._REGISTRY))


@pytest.mark.slow
def test_readme_library_example_runs(registry):
    namespace: dict = {}
    exec(compile(PYTHON_BLOCKS[0], "README.md", "exec"), namespace)
    state = namespace["state"]
    assert float(state.pipeline_state.qpos[0]) > 0.3  # the fixed trot walked forward
    assert not bool(state.done)
    assert "my_course" in namespace["terrain"].names()


def test_readme_custom_terrain_commands_build_their_envs(registry, tmp_path, monkeypatch):
    """my_courses.py and course.npy as the README writes them, then each `--terrain=` command line
    of its block, with the training replaced by a check of the env it was handed."""
    module = next(block for block in PYTHON_BLOCKS if block.startswith(MODULE_HEADER))
    (tmp_path / "my_courses.py").write_text(module)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))  # as `python -m` puts the current directory
    monkeypatch.delitem(sys.modules, "my_courses", raising=False)
    for block in PYTHON_BLOCKS[1:]:
        if not block.startswith((MODULE_HEADER, EVALUATION_HEADER)):
            exec(compile(block, "README.md", "exec"), {})
    commands = [
        shlex.split(line)
        for block in BASH_BLOCKS
        if "--terrain=my_courses:" in block
        for line in block.splitlines()
    ]
    assert len(commands) == 3
    built = {}

    def fake_train(env, config, run_dir, **kwargs):
        built[env.terrain.spec] = env.terrain
        return mock.Mock(env_steps=0)

    for command in commands:
        assert command[:3] == ["python", "-m", "quadcos.train"], command
        with mock.patch.object(training, "train", side_effect=fake_train):
            assert train.main(command[3:]) == 0, command
    heightfield = "heightfield:course.npy;x_range=-2,10"
    assert set(built) == {"my_courses:hills", "my_courses:climb", heightfield}
    assert built["my_courses:hills"].name == "hills"
    assert built["my_courses:climb"].course_end_x == 4.0  # 2 m lead-in, 2 m at 4°
    assert built[heightfield].extent[:2] == (-2.0, 10.0)
    sys.modules.pop("my_courses", None)


@pytest.mark.slow
def test_readme_evaluation_example_runs(monkeypatch):
    block = next(block for block in PYTHON_BLOCKS if block.startswith(EVALUATION_HEADER))
    monkeypatch.chdir(pathlib.Path(__file__).resolve().parent.parent)
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    result = namespace["result"]
    assert result.success == 1.0 and result.falls == 0.0  # the pretrained policy, 2 s on flat
    assert 0.2 < result.speed < 1.5
    assert namespace["summary"]["num_episodes"] == 8


def test_readme_course_distribution_command_builds_its_lanes(tmp_path, monkeypatch):
    """The README's `--terrain=random:` training command line, with the training replaced by a
    check of the env and trainer config it was handed."""
    lines = [
        line
        for block in BASH_BLOCKS
        for line in block.replace("\\\n", " ").splitlines()
        if "quadcos.train" in line and "--terrain=random:" in line
    ]
    assert len(lines) == 1
    command = shlex.split(lines[0])
    command = [arg for arg in command if not arg.startswith("--output_dir")]
    monkeypatch.chdir(tmp_path)
    built = {}

    def fake_train(env, config, run_dir, **kwargs):
        built.update(terrain=env.terrain, config=config, centre=env.config.action_centre)
        return mock.Mock(env_steps=0)

    def fake_search(config):  # the from-scratch preset's gait search, on the same terrain
        built.update(search_terrain=config.env.terrain, search=config.sac.gait_search.to_dict())
        return {"action_centre": "0.3,0.15,0.5,1.8,-1.3", "setup": {"wall_time_s": 0.0}}

    with (
        mock.patch.object(training, "train", side_effect=fake_train),
        mock.patch.object(gait_search, "find_gait", side_effect=fake_search),
    ):
        assert train.main(command[3:] + [f"--output_dir={tmp_path / 'run'}"]) == 0
    assert built["terrain"].num_lanes == 64 and built["config"].curriculum.enabled
    assert built["config"].episode_length == 400
    assert built["search_terrain"] == "random:max_deg=12,sections=3-5,len=1-3,seed=0"
    assert built["search"]["num_candidates"] * built["search"]["robots_per_candidate"] == 4096
    assert built["centre"] == "0.3,0.15,0.5,1.8,-1.3"
