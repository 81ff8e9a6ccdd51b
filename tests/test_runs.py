"""`quadcos.runs`: every committed run config migrates, and `--resume` and `quadcos.evaluate`
rebuild the same env from it (the env the run was trained in)."""

import importlib.util
import json
import pathlib

import pytest

from quadcos import env as env_lib
from quadcos import train
from quadcos._util.overrides import apply_overrides
from quadcos.evaluation import sources
from quadcos.training import run_config as runs

ROOT = pathlib.Path(__file__).resolve().parent.parent
ANY_SLOPE = ROOT / "experiments" / "any_slope"
CONFIGS = sorted(ROOT.glob("tests/data/trained/**/config.json"))
POLICIES = sorted(ROOT.glob("tests/data/trained/**/policy.json")) + sorted(
    ROOT.glob("experiments/policies/*/policy.json")
)


def test_the_committed_configs_are_found():
    assert len(CONFIGS) >= 38 and len(POLICIES) >= 7


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


@pytest.mark.parametrize(
    ("name", "runs", "seeds"),
    [
        ("seeds", r"any_slope_top50_s\d+", [0, 1, 2, 3]),
        ("seeds_jax", r"any_slope_jax_s\d+", [0, 1, 2]),
        ("seeds_restart_all", r"any_slope_ramp_s\d+", [0, 1, 2]),
        ("seeds_no_ramp", r"any_slope_promote2_s\d+", [0, 1, 2, 3]),
        ("seeds_promote1", None, [0, 1, 2]),
        ("levers", ".*", [0, 0, 0, 0, 0]),
    ],
)
def test_the_committed_any_slope_tables_are_what_their_runs_and_evaluations_say(
    name, runs, seeds, tmp_path
):
    out = tmp_path / f"{name}.json"
    pattern = ["--runs", runs] if runs else []
    assert _script("seeds").main([str(ANY_SLOPE / name), "--out", str(out), *pattern]) == 0
    committed = json.loads((ROOT / "experiments" / "any_slope" / f"{name}.json").read_text())
    assert json.loads(out.read_text()) == committed
    assert [row["seed"] for row in committed] == seeds
    for row in committed:  # each kept policy is the one of a run's own evaluation
        assert row["env_steps"] <= row["last_env_steps"] and row["train_seconds"] > 0
        assert row["command"].startswith("python -m quadcos.train --preset=any_slope --seed=")


def _script(name: str):
    """experiments/any_slope/NAME.py as a module: its main() runs in this process (a Python
    of its own would spend seconds importing quadcos for it)."""
    spec = importlib.util.spec_from_file_location(name, ANY_SLOPE / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_committed_falls_table_is_what_the_kept_episodes_say(capsys):
    folder = ANY_SLOPE / "seeds"
    _script("falls").main([str(path) for path in sorted(folder.glob("*.episodes.json.gz"))])
    table = capsys.readouterr().out
    assert table == (folder / "falls.md").read_text()
    for line in table.splitlines()[2:]:  # each row's falls are those of its evaluation's summary
        name, falls = line.split(" | ")[0].strip("| "), int(line.split(" | ")[1])
        summary = json.loads((folder / f"{name}.json").read_text())
        assert falls == round(summary["fall_rate"] * summary["num_episodes"]) > 0


def test_the_committed_success_by_slope_is_what_the_evaluations_say(capsys):
    folder = ANY_SLOPE
    table = (folder / "by_slope.md").read_text()
    names = [line.split(" | ")[0].strip("| ") for line in table.splitlines()[2:]]
    found = {path.stem: path for path in folder.rglob("eval_*.json")}
    _script("by_slope").main([str(found[name]) for name in names])
    assert capsys.readouterr().out == table
    # on the steepest courses every 300-s run that climbed two lanes a success (the preset, with
    # and without the start ramp) beats every one that climbed one or three, and only the 870-s
    # policy of one lane a success comes close
    steepest = dict(
        zip(names, (float(line.split(" | ")[-1].split()[0]) for line in table.splitlines()[2:]))
    )
    two_lanes = {
        name: value
        for name, value in steepest.items()
        if "promote2" in name or name.startswith(("eval_any_slope_ramp_s", "eval_any_slope_top50"))
    }
    three_lanes = {name: value for name, value in steepest.items() if "promote3" in name}
    one_lane = {
        name: value
        for name, value in steepest.items()
        if name not in two_lanes | three_lanes and "posture" not in name
    }
    assert len(two_lanes) == 11 and len(three_lanes) == 1 and len(one_lane) == 6
    assert min(two_lanes.values()) > max(*one_lane.values(), *three_lanes.values())
    assert steepest["eval_posture_cap_s0_testset"] > max(one_lane.values())
