"""The code blocks of the README and of the documentation pages (docs/*.md) run as written: the
README's library example, the evaluation example, the Python blocks of the pages, and the command
lines that train on terrains of the user's own (up to the training itself, which
tests/test_cli.py runs)."""

import pathlib
import re
import shlex
import sys
from unittest import mock

import pytest

from quadcos import terrain, train, training
from quadcos.evaluation import gait_search

ROOT = pathlib.Path(__file__).resolve().parent.parent
# The README first (its first Python block is the library example), then the pages in name order.
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def _blocks(language: str) -> list[tuple[str, str]]:
    """(file name relative to the repository, block) of every ```language block, in page order."""
    return [
        (str(page.relative_to(ROOT)), block)
        for page in PAGES
        for block in re.findall(rf"```{language}\n(.*?)```", page.read_text(), re.S)
    ]


PYTHON_BLOCKS = _blocks("python")
BASH_BLOCKS = [block for _, block in _blocks("bash")]
LIBRARY_EXAMPLE = PYTHON_BLOCKS[0]
MODULE_HEADER = "# my_courses.py\n"
EVALUATION_HEADER = "# Evaluate a policy from Python.\n"


def test_the_blocks_are_where_the_tests_look():
    assert LIBRARY_EXAMPLE[0] == "README.md" and "quadcos.make_env(course)" in LIBRARY_EXAMPLE[1]
    assert sum(block.startswith(MODULE_HEADER) for _, block in PYTHON_BLOCKS) == 1
    assert sum(block.startswith(EVALUATION_HEADER) for _, block in PYTHON_BLOCKS) == 1


@pytest.fixture
def registry(monkeypatch):
    """The README registers terrains; keep them out of the other tests."""
    monkeypatch.setattr(terrain.registry, "_REGISTRY", dict(terrain.registry._REGISTRY))


@pytest.mark.slow
def test_readme_library_example_runs(registry):
    namespace: dict = {}
    name, block = LIBRARY_EXAMPLE
    exec(compile(block, name, "exec"), namespace)
    state = namespace["state"]
    assert float(state.pipeline_state.qpos[0]) > 0.3  # the fixed trot walked forward
    assert not bool(state.done)
    assert "my_course" in namespace["terrain"].names()


def test_readme_custom_terrain_commands_build_their_envs(registry, tmp_path, monkeypatch):
    """my_courses.py and course.npy as the docs write them (and every other Python block of the
    pages but the two run by their own tests), then each `--terrain=my_courses:` command line, with
    the training replaced by a check of the env it was handed."""
    module = next(block for _, block in PYTHON_BLOCKS if block.startswith(MODULE_HEADER))
    (tmp_path / "my_courses.py").write_text(module)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))  # as `python -m` puts the current directory
    monkeypatch.delitem(sys.modules, "my_courses", raising=False)
    for name, block in PYTHON_BLOCKS[1:]:
        if not block.startswith((MODULE_HEADER, EVALUATION_HEADER)):
            exec(compile(block, name, "exec"), {})
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
        with mock.patch.object(training.loop, "train", side_effect=fake_train):
            assert train.main(command[3:]) == 0, command
    heightfield = "heightfield:course.npy;x_range=-2,10"
    assert set(built) == {"my_courses:hills", "my_courses:climb", heightfield}
    assert built["my_courses:hills"].name == "hills"
    assert built["my_courses:climb"].course_end_x == 4.0  # 2 m lead-in, 2 m at 4°
    assert built[heightfield].extent[:2] == (-2.0, 10.0)
    sys.modules.pop("my_courses", None)


@pytest.mark.slow
def test_readme_evaluation_example_runs(monkeypatch):
    name, block = next(pair for pair in PYTHON_BLOCKS if pair[1].startswith(EVALUATION_HEADER))
    monkeypatch.chdir(ROOT)
    namespace: dict = {}
    exec(compile(block, name, "exec"), namespace)
    result = namespace["result"]
    assert result.success == 1.0 and result.falls == 0.0  # the pretrained policy, 2 s on flat
    assert 0.2 < result.speed < 1.5
    assert namespace["summary"]["num_episodes"] == 4


def test_readme_course_distribution_command_builds_its_lanes(tmp_path, monkeypatch):
    """The docs' any-slope training command line (`--preset=any_slope`, the random course family),
    with the training replaced by a check of the env and trainer config it was handed."""
    lines = [
        line
        for block in BASH_BLOCKS
        for line in block.replace("\\\n", " ").splitlines()
        if "quadcos.train" in line and "--preset=any_slope" in line and "--population" not in line
    ]  # (a population of the preset: tests/test_population.py)
    assert len(lines) == 2  # docs/training.md and docs/terrains.md: the same line
    assert len({line.split("#")[0].strip() for line in lines}) == 1
    command = shlex.split(lines[0].split("#")[0])
    command = [arg for arg in command if not arg.startswith("--output_dir")]
    monkeypatch.chdir(tmp_path)
    built = {}

    def fake_train(env, config, run_dir, **kwargs):
        built.update(terrain=env.terrain, config=config, env_config=env.config)
        return mock.Mock(env_steps=0)

    def fake_search(config):  # the from-scratch preset's gait search, on the same terrain
        built.update(search_terrain=config.env.terrain, search=config.sac.gait_search.to_dict())
        return {"action_centre": "0.3,0.15,0.5,1.8,-1.3", "setup": {"wall_time_s": 0.0}}

    with (
        mock.patch.object(training.loop, "train", side_effect=fake_train),
        mock.patch.object(gait_search, "find_gait", side_effect=fake_search),
        # no trainer compiled during the (replaced) search: tests/test_ahead.py covers that
        mock.patch.object(training.ahead, "applies", return_value=False),
    ):
        assert train.main(command[3:] + [f"--output_dir={tmp_path / 'run'}"]) == 0
    assert built["terrain"].num_lanes == 64 and built["config"].curriculum.enabled
    assert built["config"].curriculum.promote_lanes == 2 and built["config"].max_seconds == 300
    assert built["config"].episode_length == 400
    assert built["search_terrain"] == "random:max_deg=12,sections=3-5,len=1-3,seed=0"
    assert built["search"]["num_candidates"] * built["search"]["robots_per_candidate"] == 4096
    assert built["env_config"].action_centre == "0.3,0.15,0.5,1.8,-1.3"
    assert built["env_config"].start_ramp_s == 0.25
