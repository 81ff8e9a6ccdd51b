"""`quadcos.runs`: every committed run config migrates, and `--resume` and `quadcos.evaluate`
rebuild the same env from it (the env the run was trained in)."""

import json
import pathlib

import pytest

from quadcos import env as env_lib
from quadcos import train
from quadcos._util.overrides import apply_overrides
from quadcos.evaluation import sources
from quadcos.training import run_config as runs

ROOT = pathlib.Path(__file__).resolve().parent.parent
CONFIGS = sorted(ROOT.glob("tests/data/trained/**/config.json"))
POLICIES = sorted(ROOT.glob("tests/data/trained/**/policy.json")) + sorted(
    ROOT.glob("experiments/policies/*/policy.json")
)


def test_the_committed_configs_are_found():
    assert len(CONFIGS) >= 30 and len(POLICIES) >= 7


@pytest.mark.parametrize("path", CONFIGS, ids=lambda path: str(path.parent.relative_to(ROOT)))
def test_resume_and_evaluate_rebuild_the_same_env(path):
    resumed = train.build_config(train._saved_config(path.parent), {}).env.to_dict()
    overrides, terrain = sources.trained_env(json.loads(path.read_text()))
    evaluated = apply_overrides(env_lib.default_config(), overrides).to_dict() | {
        "terrain": terrain
    }
    assert evaluated == resumed
    saved = json.loads(path.read_text())["run_info"]["env"]
    if "action_filter_tau" not in saved:  # made before the command filter: trained without one
        assert resumed["action_filter_tau"] == 0.0
    if "action_centre" not in saved:
        assert resumed["action_centre"] == "midpoint"


@pytest.mark.parametrize("path", POLICIES, ids=lambda path: str(path.parent.relative_to(ROOT)))
def test_every_committed_policy_gets_the_env_of_its_run(path):
    source = sources.policy_source(path.parent)
    run_config = path.parent.parent / "config.json"
    if run_config.is_file():
        expected = runs.env_overrides(runs.load_run_config(run_config.parent))
        assert source.env_overrides | {"terrain": source.training_terrain} == expected


def test_a_config_from_a_newer_quadcos_is_refused():
    saved = {"config": {}, "run_info": {"env": {"teleport": True}}}
    with pytest.raises(ValueError, match="does not know: env.teleport"):
        runs.migrate(saved)
    with pytest.raises(ValueError, match="not a quadcos run config"):
        runs.migrate({"config": {}})
