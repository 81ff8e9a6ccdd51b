"""A from-scratch run's gait search (`env.action_centre="search"`) and numeric action centres."""

import json
import math

import numpy as np
import pytest

import quadcos
from quadcos import train, training
from quadcos.benchmarking.settings import BENCH_PRESETS, searches_gait
from quadcos.equations import oscillator
from tests.cli_runs import ROOT, run_in_process
from tests.test_robot import MENAGERIE, needs_menagerie


def test_a_numeric_action_centre_is_the_gait_its_zero_action_commands():
    spec = "0.38877,0.195895,0.50539,1.8099,-1.33169"
    centre = oscillator.action_centre(spec, oscillator.PERIOD_MIN)
    np.testing.assert_allclose(centre, [0.38877, 0.195895, 0.50539, 1.8099, -1.33169])
    assert oscillator.centre_spec(centre) == spec
    params = oscillator.action_to_parameters(np.zeros(5), oscillator.PERIOD_MIN, centre)
    np.testing.assert_allclose(params, centre, rtol=1e-6)


@pytest.mark.parametrize(
    "spec, message",
    [
        ("search", "resolved by quadcos.train"),
        ("0.4,0.15,0.6", "unknown action_centre '0.4,0.15,0.6'"),
        ("0.4,0.15,0.6,1.5,x", "unknown action_centre"),
        ("0.4,0.15,0.1,1.5,-1.5", "period = 0.1 is not strictly inside (0.2, 2)"),
        ("0.5,0.15,0.6,1.5,-1.5", "amplitude_knee = 0.5 is not strictly inside"),
    ],
)
def test_a_bad_action_centre_is_named(spec, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        oscillator.action_centre(spec, oscillator.PERIOD_MIN)


def test_only_the_scratch_preset_searches_and_the_gpu_bench_walks_with_it():
    assert searches_gait("scratch")
    assert not any(searches_gait(preset) for preset in ("smoke", "cpu", "gpu"))
    # Throughput rows keep the gpu preset (an env needs a concrete centre); time to walk is
    # measured from scratch.
    assert BENCH_PRESETS["gpu"]["training_preset"] == "gpu"
    assert BENCH_PRESETS["gpu"]["walk_training_preset"] == "scratch"


def test_the_scratch_preset_trains_20m_steps_and_keeps_its_best_policy():
    # experiments/from_scratch, "20 M env steps": speed and pitch error still improve after 10 M,
    # and a run can lose its gait in its last evaluations.
    scratch, gpu = (train.build_config(train.PRESETS[name], {}) for name in ("scratch", "gpu"))
    assert scratch.sac.num_timesteps == 20_000_000 and gpu.sac.num_timesteps == 10_000_000
    assert scratch.sac.keep_best_policy and not gpu.sac.keep_best_policy


def test_the_any_slope_preset_is_the_generalists_recipe_with_a_time_budget():
    config = train.build_config(train.PRESETS["any_slope"], {})
    assert config.env.terrain.startswith("random:max_deg=12")
    assert config.env.observe_slope and config.env.observe_phase
    assert config.env.posture_bound == 0.6 and config.env.forward_speed_cap == 0.8
    assert config.env.action_centre == "search" and config.sac.keep_best_policy
    assert config.sac.max_seconds == 300.0 and config.sac.curriculum.promote_lanes == 2
    assert config.env.start_ramp_s == 0.25 and config.sac.curriculum.restart_fraction == 0.5
    flagged = train.build_config(train.PRESETS["any_slope"], {"sac.max_seconds": 870.0})
    assert flagged.sac.max_seconds == 870.0


def test_the_robust_preset_is_the_config_of_the_measured_robust_runs():
    # experiments/robustness: the run behind policies/flat_robust was made with flags; the
    # preset must be the config its policy recorded, but for the action centre its search resolved.
    policy = ROOT / "experiments/policies/flat_robust/policy.json"
    recorded = json.loads(policy.read_text())["config"]
    config = json.loads(json.dumps(train.build_config(train.PRESETS["robust"], {}).to_dict()))
    # Trainer options added since, at the defaults that train as the runs did.
    assert config["sac"].pop("overlap_updates") is False
    assert config["sac"].pop("at_actor_start") == ""  # settings switched at the actor's start: none
    # ... and the delayed actor and LayerNorm critics, off: Brax's SAC.
    assert (config["sac"].pop("policy_delay"), config["sac"].pop("critic_layer_norm")) == (1, False)
    # ... and the trainer compiled during the search: a start-up option, not the runs' learning.
    assert config["sac"]["gait_search"].pop("compile_trainer") is True
    # ... and the search's share of the time budget, which came later.
    assert config["sac"]["gait_search"].pop("max_fraction") == 0.5
    assert config["sac"]["gait_search"].pop("max_attitude") == 0.0  # the search's bound: off
    assert config["sac"]["gait_search"].pop("track_gaits") == 0  # the best gait only, as run
    assert config["sac"]["gait_search"].pop("track_attitude") == 0.0  # (scores finalists: none)
    # ... and the kept policy ranked by tracking, an option: by reward, as the runs ranked it.
    assert config["sac"].pop("best_policy_by") == "reward"
    assert config["sac"].pop("best_policy_tracking_targets") == [0.1, 0.15]
    assert config["sac"].pop("best_policy_max_attitude") == 0.0  # the attitude bound: off
    assert config["sac"].pop("n_step") == 1  # n-step returns: off, Brax's transitions
    assert config["sac"].pop("critic_atoms") == 0  # distributional critics: off, Brax's Q
    assert config["sac"].pop("critic_value_range") == [-250.0, 250.0]
    assert config["sac"].pop("privileged_critic") is False  # the critics see what the policy sees
    # ... and CAPS's smoothness terms and the anchor, off: Brax's actor loss.
    off = {"temporal": 0.0, "spatial": 0.0, "sigma": 0.05, "anchor": 0.0}
    assert config["sac"].pop("smoothness") == off
    assert config["sac"] == recorded["config"]
    env = config["env"]
    assert env.pop("action_centre") == "search"
    recorded["run_info"]["env"].pop("action_centre")
    # Launch options added since, at the defaults that behave as the runs' physics did.
    assert (env["warp"].pop("arena"), env["warp"].pop("graph_conditional")) == (False, True)
    # Velocity commands and turning, added since: off by default.
    assert (env.pop("commands")["spec"], env.pop("turn_mode")) == ("", "none")
    env.pop("turn_bound")
    # The friction cone and the solver probe, added since: the robot preset's cone, and a probe
    # that runs only for a robot without a preset (the paper's robot has one).
    assert (env.pop("cone"), env.pop("solver_probe")) == ("", True)
    assert (env.pop("servo_kp"), env.pop("servo_kd")) == (0.0, 0.0)
    # ... and the frame of r_s's "moving", added since: x, as the runs measured it.
    assert env.pop("survival_speed_frame") == "x"
    assert env.pop("observe_angular_velocity") is False  # the gyro, added since: not observed
    assert env["reward"].pop("action_rate") == 0.0  # the action-rate term, added since: off
    assert env["randomization"].pop("range_ends") == 0.0  # draws at the ranges' ends: off
    assert env["randomization"].pop("delay_drive") is False  # the drive late too, added since
    # robots in the robustness conditions, added since: none, in training or its evaluations
    conditions = env["randomization"].pop("conditions"), env["randomization"].pop("eval_conditions")
    assert conditions == ("", "")
    assert env.pop("held_rhythm") == ""  # every rhythm parameter the policy's, as run
    assert env == recorded["run_info"]["env"]
    assert env["period_min"] == 0.15 and env["randomization"]["push_interval_s"] == 2.0


@needs_menagerie
def test_the_command_preset_is_the_config_of_the_shipped_go1_command_policy(monkeypatch):
    # experiments/commands, "A privileged critic": the shipped policy's run named the preset, Go1
    # and its seed (and the privileged critic, the preset's value for Go1); what may differ is the
    # seed and what the gait search and the feed-forward's calibration resolved.
    monkeypatch.setenv("MENAGERIE_ROOT", str(MENAGERIE))  # the config resolves Go1's ranges
    policy = ROOT / "experiments/policies/unitree_go1_command/policy.json"
    recorded = json.loads(policy.read_text())["config"]
    go1 = {"env.robot": "menagerie:unitree_go1"}
    config = json.loads(json.dumps(train.build_config(train.PRESETS["command"], go1).to_dict()))
    assert config["sac"]["privileged_critic"] is True  # Go1's own settings, applied
    assert config["sac"]["gait_search"]["track_gaits"] == 16
    assert (config["sac"].pop("seed"), recorded["config"].pop("seed")) == (0, 1)
    assert config["sac"].pop("at_actor_start") == ""  # added since: one phase, as the run trained
    assert config["sac"] == recorded["config"]
    env, trained = config["env"], recorded["run_info"]["env"]
    assert env["randomization"]["eval_conditions"] == "robustness"
    assert env["randomization"].pop("delay_drive") is False  # the drive late too: added since
    assert env.pop("action_centre") == "search" and trained.pop("action_centre") != "search"
    for resolved in ("reference_speed", "half_track", "speed_map"):  # the calibration's
        assert not env["commands"].pop(resolved) and trained["commands"].pop(resolved)
    assert env == trained
    assert env["commands"]["yaw_rate_tau"] == 0.25 and env["reward"]["yaw"] == 120.0


def test_bad_search_settings_are_refused_before_anything_runs(tmp_path, capsys):
    argv = ["--preset=smoke", "--config.sac.gait_search.rounds=0"]
    assert train.main([*argv, f"--output_dir={tmp_path / 'run'}"]) == 2
    assert "config.sac.gait_search.rounds must be a whole number >= 1" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_a_speed_floor_held_to_another_statistic_is_named():
    from quadcos.training import checks
    from quadcos.training import config as training_config

    config = training_config.default_config()
    assert config.gait_search.min_speed_of == "mean"
    config.gait_search.min_speed_of = "median"
    with pytest.raises(checks.ConfigError, match="min_speed_of must be 'mean' or 'slowest'"):
        checks.check_config(config)


@pytest.mark.parametrize("bound", [-0.1, float("nan"), float("inf")])
def test_an_attitude_bound_that_is_no_angle_is_named(bound):
    from quadcos.training import checks
    from quadcos.training import config as training_config

    for name in ("max_attitude", "track_attitude"):
        config = training_config.default_config()
        assert config.gait_search[name] == 0.0  # off
        config.gait_search[name] = bound
        with pytest.raises(checks.ConfigError, match=f"{name} must be a finite angle .*{bound}"):
            checks.check_config(config)


def test_a_confirmation_that_does_not_fill_the_search_batch_is_named():
    from quadcos.training import checks
    from quadcos.training import config as training_config

    config = training_config.default_config()
    assert config.gait_search.confirm_robots == 0
    config.gait_search.confirm_robots = 64  # divides 2048 x 2
    checks.check_config(config)
    config.gait_search.confirm_robots = 3
    with pytest.raises(checks.ConfigError, match="confirm_robots must be 0 or .* = 4096, got 3"):
        checks.check_config(config)


class _Searched(Exception):
    """Stands in for the gait search's result: the run stops there."""


def test_a_library_run_sizes_warp_for_the_search_and_hands_it_the_run_config(tmp_path):
    smaller = {"env.warp.max_envs": 1, "sac.num_envs": 256, "sac.num_eval_envs": 128}
    config = train.build_config(train.PRESETS["scratch"], smaller)
    seen = {}

    def find_gait(searched):
        seen.update(max_envs=searched.env.warp.max_envs, terrain=searched.env.terrain)
        raise _Searched

    with pytest.raises(_Searched):
        training.run(config, tmp_path / "run", find_gait=find_gait)
    search = config.sac.gait_search
    assert seen == {
        "max_envs": search.num_candidates * search.robots_per_candidate,
        "terrain": config.env.terrain,
    }
    assert seen["max_envs"] > 256  # the largest batch of the run: the search's


def test_a_library_run_with_a_search_centre_needs_the_search(tmp_path):
    config = train.build_config(train.PRESETS["scratch"], {})
    with pytest.raises(training.ConfigError, match="find_gait=quadcos.evaluation.gait_search"):
        training.run(config, tmp_path / "run")
    assert not (tmp_path / "run").exists()


@pytest.mark.slow
def test_a_from_scratch_run_searches_then_trains_from_the_gait_it_found(tmp_path):
    # On the test robot quad12 (12 joints): one end-to-end run for both paths, the
    # search and a robot other than the paper's (each alone compiles a trainer of its own). In
    # this process: a subprocess would import and trace everything again. No prefill (the smoke
    # run's covers it): the trainer's first chunk fills the buffer, a program fewer to compile.
    run_dir = tmp_path / "scratch"
    result = run_in_process(
        "--preset=smoke",
        "--robot=quad12",
        "--config.sac.min_replay_size=0",
        "--config.sac.num_timesteps=128",  # one chunk (4 envs x 32 steps): the run's programs
        "--config.env.action_centre=search",
        "--config.env.impl=jax",
        "--config.env.survival_min_speed=0.1",
        "--config.env.action_scale=0.5",
        "--config.sac.gait_search.num_candidates=6",
        "--config.sac.gait_search.robots_per_candidate=1",
        "--config.sac.gait_search.rounds=2",
        "--config.sac.gait_search.elite=2",
        "--config.sac.gait_search.seconds=0.5",
        "--config.sac.gait_search.max_attitude=1.5",  # rad: any gait that stands is within
        f"--output_dir={run_dir}",
        "--no_progress",
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert "gait search round 2/2" in result.stderr
    # On a CPU its trainer is built after the search (quadcos.training.ahead: not during it).
    startup = json.loads((run_dir / "startup.json").read_text())
    assert "trainer_traced" not in startup["seconds"]

    search = json.loads((run_dir / "gait_search.json").read_text())
    assert not search["setup"]["include_trot"] and search["setup"]["symmetric"]
    # Candidates act from the first step, as the centre will (the run's own filter is on).
    assert search["setup"]["env"]["action_filter_tau"] == 0.0
    # ... over all of §3.3's ranges, whatever share of them SAC will reach.
    assert search["setup"]["env"]["action_scale"] == 1.0
    assert [entry["round"] for entry in search["rounds"]] == [1, 2]
    # The attitude bound reached the search (its ranking: test_evaluate.py), and the log names
    # the kept gait's attitude.
    assert search["setup"]["max_attitude"] == 1.5
    best = search["ranking"][0]
    assert f"roll {best['mean_max_abs_roll']:.3f} rad" in result.stderr
    assert search["num_evaluated"] == 12
    for candidate in search["ranking"]:
        p = candidate["parameters"]
        # Mirror-symmetric: φ3 = φ1 − π up to whole cycles, inside [−2π, 2π].
        assert math.cos(p["phi3"] - p["phi1"] + math.pi) == pytest.approx(1.0, abs=1e-5)
        assert abs(p["phi3"]) <= 2 * math.pi
        assert tuple(p.values()) != tuple(oscillator.FIXED_TROT)

    config = json.loads((run_dir / "config.json").read_text())
    centre = config["run_info"]["env"]["action_centre"]
    assert config["run_info"]["env"]["action_filter_tau"] > 0
    assert config["run_info"]["env"]["action_scale"] == 0.5
    assert (
        centre == search["action_centre"] == search["ranking"][0]["policy"].removeprefix("fixed:")
    )
    oscillator.action_centre(
        centre, oscillator.PERIOD_MIN
    )  # a valid centre: evaluate/resume use it
    rows = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    # The run's clock counts from process start: the search's seconds come before step 0.
    assert rows[0]["wall_time_s"] >= config["run_info"]["gait_search_s"] > 0
    # The robot is the run's, recorded, and its policy acts on that robot's observation.
    assert config["run_info"]["env"]["robot"] == "quad12"
    assert config["run_info"]["robot"]["name"] == "quad12"
    policy = quadcos.load_policy(run_dir / "policy")
    assert policy.act(np.zeros(3 + 3 + 12 + 5)).shape == (5,)


@pytest.mark.parametrize(
    "ends, after_rounds, out",
    [
        ([10.0], 0, False),  # round 2 would end at 20 s, within 25
        ([10.0], 1, True),  # ... but its confirmation at 30 s
        ([10.0, 14.0], 1, False),  # timed by the last round (4 s): 18 and 22 s
        ([10.0, 20.0], 0, True),
    ],
)
def test_the_search_runs_no_round_that_would_end_past_its_budget(ends, after_rounds, out):
    from quadcos.evaluation import gait_search

    assert gait_search.out_of_time(ends, 25.0, after_rounds) is out


def test_a_search_with_no_gait_within_its_attitude_bound_keeps_the_most_level_that_stood(
    monkeypatch, caplog
):
    from quadcos.evaluation import fixed_search, gait_search

    def candidate(params, fall_rate, roll):
        return {"parameters": dict(zip("abcde", params)), "mean_forward_speed": 0.5,
                "slowest_forward_speed": 0.4, "fall_rate": fall_rate, "score": None,
                "mean_max_abs_roll": roll, "mean_max_abs_pitch_error": 0.05}

    level = candidate(oscillator.FIXED_TROT, 0.0, 0.12)  # stood, rolls past the bound
    fell = candidate((0.3, 0.1, 0.5, 1.0, -2.0), 0.25, 0.4)
    ranking = [level, fell]

    def search_fixed(terrain, rounds, on_round, **kwargs):
        log = [{"round": 1, "wall_time_s": 1.0, "best_score": None, "num_without_falls": 0,
                "best_forward_speed": 0.5}]
        on_round(log[0])
        return {"ranking": ranking, "num_without_falls": 0, "confirmation": None, "rounds": log,
                "setup": {"wall_time_s": 1.0}}

    monkeypatch.setattr(fixed_search, "search_fixed", search_fixed)
    config = train.build_config(train.PRESETS["scratch"], {"sac.gait_search.max_attitude": 0.1})
    with caplog.at_level("WARNING", logger=gait_search.logger.name):
        found = gait_search.find_gait(config)
    assert found["action_centre"] == oscillator.centre_spec(oscillator.FIXED_TROT)
    assert "no gait within 0.1 rad of roll and pitch error; kept the most level one" in caplog.text
    assert "roll 0.120 rad" in caplog.text
    # Falls are not a preference: without the bound, or where every candidate fell, none is kept.
    for bound, candidates in ((0.0, [level, fell]), (0.1, [fell])):
        ranking[:] = candidates
        bounded = {"sac.gait_search.max_attitude": bound}
        config = train.build_config(train.PRESETS["scratch"], bounded)
        with pytest.raises(gait_search.NoGaitFound, match="no candidate without falls in"):
            gait_search.find_gait(config)
    # ... nor is the speed floor: a gait that stood too slowly is not kept either.
    ranking[:] = [level]
    floored = {"sac.gait_search.max_attitude": 0.1, "sac.gait_search.min_speed": 0.8}
    with pytest.raises(gait_search.NoGaitFound, match="without falls at >= 0.8 m/s in"):
        gait_search.find_gait(train.build_config(train.PRESETS["scratch"], floored))


def test_a_search_in_a_timed_run_gets_its_share_of_the_budget_and_says_where_it_stopped(
    monkeypatch, caplog
):
    from quadcos.evaluation import fixed_search, gait_search

    def search_fixed(terrain, rounds, on_round, **kwargs):  # rounds of 40 s each
        log = []
        for index in range(rounds):
            log.append({"round": index + 1, "wall_time_s": 40.0 * (index + 1), "best_score": 1.0,
                        "num_without_falls": 1, "best_forward_speed": 0.5})
            if on_round(log[-1]):
                break
        best = {"parameters": dict(zip("abcde", oscillator.FIXED_TROT)), "mean_forward_speed": 0.5,
                "fall_rate": 0.0, "mean_max_abs_roll": 0.05, "mean_max_abs_pitch_error": 0.04}
        return {"ranking": [best], "num_without_falls": 1, "confirmation": None, "rounds": log,
                "setup": {"wall_time_s": log[-1]["wall_time_s"]}}

    monkeypatch.setattr(fixed_search, "search_fixed", search_fixed)
    # 300 s: the search gets 150; round 3 would end at 120 s, round 4 at 160
    config = train.build_config(train.PRESETS["scratch"], {"sac.max_seconds": 300.0})
    with caplog.at_level("WARNING", logger=gait_search.logger.name):
        assert len(gait_search.find_gait(config)["rounds"]) == 3
    assert "stopped after round 3 of 6: another would end past 150 s" in caplog.text
    # with the confirmation to fit too (two more 40-s runs), round 2 is the last
    confirmed = train.build_config(
        train.PRESETS["scratch"], {"sac.max_seconds": 300.0, "sac.gait_search.confirm_robots": 2}
    )
    assert len(gait_search.find_gait(confirmed)["rounds"]) == 2
    for untimed in ({"sac.max_seconds": 0.0}, {"sac.gait_search.max_fraction": 0.0}):
        config = train.build_config(train.PRESETS["scratch"], untimed)
        assert len(gait_search.find_gait(config)["rounds"]) == 6
