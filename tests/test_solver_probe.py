"""The solver probe (quadcos.env.solver_probe): Go1's MJCF loaded by its path (no preset applies)
on the CPU, 4 robots for 1 s; one reference rollout (C MuJoCo) and one compiled candidate rollout
(MJX-JAX) shared by every test (the probe keeps them per robot and config in the process)."""

import dataclasses
import json
import pathlib

import pytest

from quadcos import env as env_lib
from quadcos._util.overrides import apply_overrides
from quadcos.env import solver_probe
from quadcos.robot.__main__ import main as robot_main
from quadcos.training import run_config, session
from quadcos.training.presets import PRESETS, build_config

MENAGERIE = pathlib.Path(__file__).resolve().parents[2] / "shared" / "menagerie"
GO1 = MENAGERIE / "unitree_go1" / "go1.xml"
pytestmark = pytest.mark.skipif(not GO1.is_file(), reason=f"no Menagerie Go1 at {GO1}")
ROBOTS, SECONDS = 4, 1.0
# A 25-ms step blows Go1 up; Go1's preset (5 ms, pyramidal, 4 / 8) holds it: one compiled rollout.
UNSTABLE = solver_probe.SolverOptions(0.025, 4, 8, "pyramidal")
PRESET = solver_probe.SolverOptions(0.005, 4, 8, "pyramidal")


def _go1_config():
    config = env_lib.default_config()
    config.robot = str(GO1)
    return config


@pytest.fixture
def small_probe(monkeypatch):
    """The default candidates and probe size cut to the two above and 4 robots for 1 s."""
    monkeypatch.setattr(solver_probe, "STEPS", (0.025, 0.005))
    monkeypatch.setattr(solver_probe, "ITERATIONS", ((4, 8),))
    monkeypatch.setattr(solver_probe, "CONES", ("pyramidal",))
    monkeypatch.setattr(solver_probe, "PROBE_ROBOTS", ROBOTS)
    monkeypatch.setattr(solver_probe, "PROBE_SECONDS", SECONDS)


@pytest.fixture(scope="module")
def go1_probe():
    return solver_probe.probe(_go1_config(), [UNSTABLE, PRESET], num_robots=ROBOTS, seconds=SECONDS)


def test_go1_by_path_needs_the_probe_and_a_preset_robot_does_not(monkeypatch):
    assert solver_probe.needs_probe(_go1_config())
    for key, value in (("solver_probe", False), ("physics_dt", 0.002), ("cone", "elliptic")):
        config = _go1_config()
        config[key] = value
        assert not solver_probe.needs_probe(config), key
    monkeypatch.setenv("MENAGERIE_ROOT", str(GO1.parents[1]))
    preset = env_lib.default_config()
    preset.robot = "menagerie:unitree_go1"
    assert not solver_probe.needs_probe(preset)


def test_candidates_divide_the_control_step_cheapest_first():
    reference = solver_probe.SolverOptions(0.002, 100, 50, "elliptic")
    options = solver_probe.candidates(0.05, reference)
    steps = [option.physics_dt for option in options]
    assert steps == sorted(steps, reverse=True) and set(steps) == {0.005, 0.0025}
    assert options[0] == solver_probe.SolverOptions(0.005, 4, 8, "pyramidal")
    steps = {option.physics_dt for option in solver_probe.candidates(0.015, reference)}
    assert steps == {0.005, 0.0025}
    slow = solver_probe.SolverOptions(0.0025, 100, 50, "elliptic")
    assert {option.physics_dt for option in solver_probe.candidates(0.05, slow)} == {0.005}


def test_judge_rejects_what_strays_from_the_reference():
    reference = solver_probe.Outcome(True, 0, 0.26, 0.25, 0.14, 0.4, 0.017, 1.0)
    tolerances = solver_probe.Tolerances()
    assert solver_probe.judge(reference, reference, 0.29, tolerances) == ""
    for change, reason in (
        ({"finite": False}, "not finite"),
        ({"fell": 1}, "fell"),
        ({"hold_height": 0.24}, "hold_height"),
        ({"max_tilt": 0.3}, "tilted"),
        ({"trot_forward": 0.2}, "trotted"),
        ({"max_penetration": 0.03}, "deep"),
    ):
        trial = reference._replace(**change)
        assert reason in solver_probe.judge(reference, trial, 0.29, tolerances)
    broken = reference._replace(finite=False)
    assert "reference" in solver_probe.judge(broken, reference, 0.29, tolerances)


def test_go1_by_path_gets_faster_physics_and_stands(go1_probe):
    reference, chosen = go1_probe.reference, go1_probe.chosen
    assert reference == solver_probe.SolverOptions(0.002, 100, 50, "elliptic")  # go1.xml's own
    assert go1_probe.passed and chosen == PRESET
    assert chosen.physics_dt >= reference.physics_dt
    assert chosen.solver_iterations <= reference.solver_iterations
    (unstable, rejected, why), (_, outcome, passed) = go1_probe.trials
    assert unstable == UNSTABLE and why and not passed
    assert outcome.finite and outcome.fell == 0
    standing = 0.288  # m: Go1's home pose
    assert 0.85 * standing < outcome.hold_height < 1.02 * standing
    assert 0.8 * standing < outcome.trot_height < 1.02 * standing
    assert outcome.trot_forward > 0.05  # the trot walks forward
    assert "5 ms" in go1_probe.message and "2 ms" in go1_probe.message
    json.dumps(go1_probe.record(), allow_nan=False)  # config.json stays strict JSON


def test_the_reference_runs_in_c_mujoco_and_knows_a_blown_up_robot(go1_probe):
    standing = 0.288
    reference = go1_probe.reference_outcome
    assert reference.finite and reference.fell == 0
    assert 0.85 * standing < reference.hold_height < 1.02 * standing
    # C MuJoCo resets a simulation that went non-finite (a warning, finite numbers again).
    config = env_lib.config.resolve(_go1_config()).to_json(sort_keys=True)
    blown = solver_probe._rollout(config, ROBOTS, SECONDS, 0).reference(UNSTABLE)  # noqa: SLF001
    assert not blown.finite and blown.fell == 3  # of the 4: every robot that holds or trots


def test_no_passing_candidate_keeps_the_mjcf_options(go1_probe):
    result = solver_probe.probe(_go1_config(), [UNSTABLE], num_robots=ROBOTS, seconds=SECONDS)
    assert not result.passed and result.chosen == result.reference == go1_probe.reference
    assert "no candidate passed" in result.message and "2 ms" in result.message
    untried = dataclasses.replace(result, trials=())  # no candidate cheaper than the MJCF's
    assert untried.message.startswith("solver probe: no cheaper candidate than")
    config = _go1_config()
    solver_probe.apply(config, result)
    assert (config.physics_dt, config.solver_iterations, config.cone) == (0.002, 100, "elliptic")
    assert not solver_probe.needs_probe(config)


def test_a_training_run_probes_once_and_its_config_json_reuses_it(go1_probe, small_probe):
    config = _go1_config()
    record = session._probe_physics(config)  # noqa: SLF001 — what `training.run` calls
    assert record["passed"] and record["chosen"]["physics_dt"] == 0.005
    assert (config.physics_dt, config.solver_iterations, config.ls_iterations, config.cone) == (
        0.005,
        4,
        8,
        "pyramidal",
    )
    saved = {"config": {}, "run_info": {"env": config.to_dict(), "solver_probe": record}}
    overrides = run_config.env_overrides(run_config.migrate(saved))
    resumed = apply_overrides(env_lib.default_config(), overrides)
    assert resumed.physics_dt == 0.005 and not solver_probe.needs_probe(resumed)
    assert session._probe_physics(resumed) is None  # noqa: SLF001


def test_describe_probe_prints_the_chosen_physics(go1_probe, small_probe, capsys):
    assert robot_main(["describe", "--probe", f"--robot={GO1}"]) == 0
    captured = capsys.readouterr()
    physics = json.loads(captured.out)["physics"]
    assert (physics["dt_s"], physics["solver_iterations"], physics["cone"]) == (
        0.005,
        4,
        "pyramidal",
    )
    assert physics["probe"]["reference"]["physics_dt"] == 0.002
    assert "solver probe: physics_dt 5 ms" in captured.err


def test_a_run_still_to_search_its_gait_probes_its_physics_on_the_default_trot():
    # A run probes its physics before its gait search: `--preset=command --robot=go1.xml`.
    config = build_config(PRESETS["command"], {"env.robot": str(GO1)}).env
    assert config.action_centre == "search" and solver_probe.needs_probe(config)
    probed = solver_probe._probed_config(config)  # noqa: SLF001 — what `probe` runs
    assert probed.action_centre == env_lib.default_config().action_centre
    assert config.action_centre == "search"  # the run's config untouched
    resolved = env_lib.config.resolve(probed).to_json(sort_keys=True)
    rollout = solver_probe._rollout(resolved, ROBOTS, SECONDS, 0)  # noqa: SLF001 — built, not run
    assert 0.25 < rollout.layout.standing_height < 0.32  # Go1's home pose
