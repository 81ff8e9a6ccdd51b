"""`quadcos.bench`: the stock-Brax compatibility patch, the time-to-walk loop and the JSON schema.

Benchmarks are not tests: these check that the bench runs, measures what it says and writes what
the issue asks for, not what the numbers are.
"""

import json
import math
import os
import time

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from quadcos import bench, evaluation, training
from quadcos._util.overrides import apply_overrides
from quadcos.benchmarking import profile, settings, time_to_walk, trainers
from quadcos.benchmarking import results as results_lib
from tests.toy_env import PointEnv

_TOY_SAC = {
    "num_envs": 8,
    "batch_size": 16,
    "replay_size": 1_024,
    "min_replay_size": 64,
    "hidden_sizes.policy": (16, 16),
    "hidden_sizes.q": (16, 16),
    "steps_per_chunk": 4,
}


def _toy_config(**overrides):
    return apply_overrides(training.default_config(), {**_TOY_SAC, **overrides})


def _finite_positive(value) -> bool:
    return isinstance(value, (int, float)) and math.isfinite(value) and value > 0


def test_device_put_replicated_patch_provides_and_removes_the_function():
    assert "device_put_replicated" not in jax.__dict__  # removed in JAX 0.10
    tree = {"a": jnp.arange(3.0), "b": (jnp.ones((2, 2), jnp.int32), jnp.float32(5))}
    with trainers.device_put_replicated_patch():
        replicated = jax.device_put_replicated(tree, jax.local_devices()[:1])
    assert "device_put_replicated" not in jax.__dict__
    for original, copy in zip(jax.tree.leaves(tree), jax.tree.leaves(replicated)):
        assert copy.shape == (1, *original.shape) and copy.dtype == original.dtype
        np.testing.assert_array_equal(copy[0], original)
        assert copy.addressable_shards[0].data.shape == (1, *original.shape)


def test_device_put_replicated_patch_restores_an_existing_attribute_after_an_error(monkeypatch):
    sentinel = object()
    monkeypatch.setattr(jax, "device_put_replicated", sentinel, raising=False)
    with pytest.raises(KeyError), trainers.device_put_replicated_patch():
        assert jax.device_put_replicated is not sentinel
        raise KeyError("inside")
    assert jax.device_put_replicated is sentinel


@pytest.mark.slow
def test_stock_brax_sac_runs_under_the_patch_and_reports_its_rate():
    config = _toy_config()
    start = time.perf_counter()
    measured = trainers.measure_stock_brax(
        PointEnv(),
        config,
        train_seconds=0.0,
        epoch_steps=4,
        timeout_s=600.0,
        section_start=start,
        startup_s=1.5,
    )
    assert measured["timed_epochs"] == 2  # ended from the callback: first epoch + 2 timed
    assert _finite_positive(measured["env_steps_per_s"])
    assert 1.5 < measured["start_to_first_step_s"] < 1.5 + time.perf_counter() - start
    assert measured["timed_out"] == 0.0
    assert "device_put_replicated" not in jax.__dict__


def test_time_to_success_stops_at_the_first_successful_evaluation_after_the_warm_up():
    config = _toy_config(actor_warmup_steps=6)
    evaluated = []

    def evaluation(state):  # the untrained policy "walks"; later ones from the second on
        evaluated.append(int(state.gradient_steps))
        return {"success_rate": 1.0 if len(evaluated) in (1, 3) else 0.5}

    start = time.perf_counter()
    outcome = time_to_walk.time_to_success(
        training.SACTrainer(PointEnv(), config),
        evaluation,
        timeout_s=600.0,
        eval_interval=1,
        section_start=start,
        startup_s=0.25,
    )
    # Chunks of 4 updates: the warm-up (6) ends in the 2nd chunk; then one evaluation per chunk.
    assert evaluated == [0, 8, 12]
    assert outcome["reason"] is None and outcome["initial_success_rate"] == 1.0
    assert [row["success_rate"] for row in outcome["evaluations"]] == [1.0, 0.5, 1.0]
    assert outcome["seconds"] == outcome["evaluations"][-1]["seconds"]
    assert 0.25 < outcome["seconds"] < 0.25 + time.perf_counter() - start


def test_time_to_success_gives_up_at_the_timeout_with_a_reason():
    outcome = time_to_walk.time_to_success(
        training.SACTrainer(PointEnv(), _toy_config()),
        lambda state: {"success_rate": 0.25},
        timeout_s=0.0,
        eval_interval=1,
        section_start=time.perf_counter(),
    )
    assert outcome["seconds"] is None
    # The prefill (64 env steps) and one chunk (4 steps of 8 envs), then the time is up.
    assert outcome["reason"] == (
        "not reached in 0 s (96 env steps); best success rate after the actor's warm-up: 0.25"
    )


def test_a_profiled_row_traces_two_more_chunks_without_the_python_tracer(
    tmp_path, monkeypatch, capsys
):
    # The toy trainer stands in for the robots (the CPU's trace of a robot chunk holds every XLA
    # op of every physics step): what is profiled, not what is simulated, is under test.
    monkeypatch.setenv("XLA_FLAGS", os.environ.get("XLA_FLAGS", ""))
    monkeypatch.setattr(trainers, "make_bench_env", lambda *args, **kwargs: PointEnv())
    monkeypatch.setattr(trainers, "trainer_config", lambda *args, **kwargs: _toy_config())
    out, traces = tmp_path / "bench.json", tmp_path / "profile"
    argv = ["--preset=cpu", f"--out={out}", "--only=train", "--train_rows=8x16x1",
            "--train_seconds=0", f"--profile_dir={traces}"]
    assert bench.main(argv) == 0
    (row,) = json.loads(out.read_text())["train"]
    assert _finite_positive(row["quadcos_env_steps_per_s"])
    events = profile.read_events(profile.trace_file(traces / "8x16x1"))  # a folder per row
    assert any("train_chunk" in str(event.get("name", "")) for event in events)
    # Without the Python tracer (--profile_python): its events' names start with "$".
    assert not any(str(event.get("name", "")).startswith("$") for event in events)
    assert "train 8x16x1: " in capsys.readouterr().out


def _stats(**values):
    zeros = np.zeros(4)
    fields = {
        "running": zeros.astype(bool),
        "lane": np.zeros(4, np.int32),
        "fell": zeros.astype(bool),
        "finished": zeros.astype(bool),
        "steps": np.full(4, 400),
        **{
            name: zeros
            for name in (
                "start_x",
                "start_y",
                "x",
                "y",
                "max_lateral_deviation",
                "max_abs_roll",
                "max_abs_yaw",
                "max_abs_pitch_error",
                "slope_sq_error",
                "episode_reward",
            )
        },
        "reward_terms": {},
    }
    return evaluation.EpisodeStats(**{**fields, **{k: np.asarray(v) for k, v in values.items()}})


def test_episode_success_walking_and_crossing():
    walk = time_to_walk.Goal(num_steps=400, duration_s=20.0)
    stats = _stats(
        fell=[False, False, True, False],
        steps=[400, 400, 120, 399],
        start_x=[0.0, 0.0, 0.0, 1.0],
        x=[6.0, 5.9, 9.0, 8.0],
    )
    np.testing.assert_array_equal(
        time_to_walk.episode_success(stats, walk), [True, False, False, False]
    )
    cross = time_to_walk.Goal(num_steps=734, duration_s=36.7, finish_x=11.0)
    stats = _stats(finished=[True, False, False, True], fell=[False, True, False, False])
    np.testing.assert_array_equal(
        time_to_walk.episode_success(stats, cross), [True, False, False, True]
    )


def test_goals_of_the_paper_terrains():
    flat = time_to_walk.terrain_goal(settings.make_bench_env("flat", "gpu"))
    assert flat == time_to_walk.Goal(400, 20.0)
    slope5 = time_to_walk.terrain_goal(settings.make_bench_env("slope5", "gpu"))
    assert slope5 == time_to_walk.Goal(
        734, pytest.approx(36.7), finish_x=11.0
    )  # 2 m lead-in + 3 x 3 m


@pytest.mark.slow
def test_rollout_evaluator_the_untrained_policy_trots_on_flat():
    # With the gpu/cpu presets a fresh policy acts at the action centre: the fixed trot, which
    # walks on flat (about 0.6-0.8 m/s).
    env = settings.make_bench_env("flat", "cpu")
    config = settings.trainer_config("cpu", settings.TrainRow(2, 8, 1))
    trainer = training.SACTrainer(env, config)
    evaluation = time_to_walk.rollout_evaluator(
        trainer, time_to_walk.terrain_goal(env), num_episodes=2
    )
    result = evaluation(trainer.init())
    assert result == {
        "success_rate": 1.0,
        "fall_rate": 0.0,
        "mean_speed": pytest.approx(0.7, abs=0.3),
    }


@pytest.mark.slow
def test_cpu_preset_at_the_smallest_sizes_writes_the_issues_schema(
    tmp_path, capsys, monkeypatch, smoke_run
):
    # XLA_FLAGS as conftest set it (main() keeps a set value, as `quadcos.train` does, and is
    # restored after the test), so that the smoke-sized trainer's init and prefill are the ones
    # the CLI tests' smoke run put in the cache (`smoke_run`: waits for that run, so that this
    # test loads those programs rather than compiling them beside it).
    del smoke_run
    monkeypatch.setenv("XLA_FLAGS", os.environ.get("XLA_FLAGS", ""))
    # JAX names a program's inner functions after what this process traced before: the rollouts
    # of earlier tests (test_courses') make the trainer's programs text-wise other than the CLI's,
    # and the persistent cache misses them (~30 s of compiling). Traced afresh, they are the CLI's.
    jax.clear_caches()
    # The cache's state is the one the CLI found when it switched the caches on (said "cold"
    # here), not what its own compiling left there later.
    enable = bench.caches.enable
    monkeypatch.setattr(bench.caches, "enable", lambda: {**enable(), "state": "cold"})
    out = tmp_path / "cpu.json"
    argv = [
        "--preset=cpu",
        f"--out={out}",
        "--env_counts=4",
        "--train_rows=4x32x1",
        "--training_preset=smoke",
        "--steps=2",
        "--train_seconds=0",
        "--skip=stock,walk,slope5",
    ]
    assert bench.main(argv) == 0
    results = json.loads(out.read_text())

    for key in (
        "device",
        "substeps_per_env_step",
        "physics_steps_per_s",
        "env_steps_per_s",
        "train",
        "compile_s",
        "time_to_walk_flat_s",
        "time_to_cross_slope5_s",
    ):
        assert key in results, key
    assert results["device"] == jax.devices()[0].device_kind
    assert results["substeps_per_env_step"] == 10  # 20 Hz control, 200 Hz physics
    tables = ("physics_steps_per_s", "gait_physics_steps_per_s", "env_steps_per_s")
    assert all(set(results[table]) == {"4"} for table in tables)
    assert _finite_positive(results["physics_steps_per_s"]["4"])
    assert _finite_positive(results["gait_physics_steps_per_s"]["4"])
    assert _finite_positive(results["env_steps_per_s"]["4"])
    (row,) = results["train"]
    assert (row["num_envs"], row["batch_size"], row["updates_per_step"]) == (4, 32, 1)
    assert _finite_positive(row["quadcos_env_steps_per_s"])
    assert row["physics_env_steps_per_s"] == results["physics_steps_per_s"]["4"] / 10
    assert row["gait_physics_env_steps_per_s"] == results["gait_physics_steps_per_s"]["4"] / 10
    assert row["stock_brax_env_steps_per_s"] is None  # skipped
    assert results["cache"] == row["cache"] == "cold"
    assert _finite_positive(results["compile_s"]["quadcos"])
    assert results["compile_s"]["stock_brax"] is None
    assert results["time_to_walk_flat_s"] is None and results["time_to_cross_slope5_s"] is None
    assert set(results["versions"]) >= {"jax", "jaxlib", "mujoco", "mujoco-mjx", "brax"}

    table = results_lib.markdown_table(results)
    assert "| 4 |" in table and "| 4 | 32 | 1 |" in table
    printed = capsys.readouterr().out
    assert "physics 4 envs: " in printed and "train 4x32x1: " in printed
    assert "gait 4 envs: " in printed
    assert "FAILED" not in printed and "errors" not in results["details"]


def test_merged_results_keep_the_earlier_numbers():
    row = {"num_envs": 4, "batch_size": 8, "updates_per_step": 1}
    earlier = {
        "device": "cpu",
        "physics_steps_per_s": {"4": 2.0},
        "train": [{**row, "quadcos_env_steps_per_s": 3.0, "stock_brax_env_steps_per_s": None}],
        "compile_s": {"quadcos": 5.0, "stock_brax": None},
        "time_to_walk_flat_s": 7.0,
        "command": "first",
    }
    later = {
        "device": "cpu",
        "physics_steps_per_s": {"8": 1.0},
        "train": [
            {**row, "quadcos_env_steps_per_s": None, "stock_brax_env_steps_per_s": 4.0},
            {
                **row,
                "num_envs": 8,
                "quadcos_env_steps_per_s": 6.0,
                "stock_brax_env_steps_per_s": None,
            },
        ],
        "compile_s": {"quadcos": None, "stock_brax": 9.0},
        "time_to_walk_flat_s": None,
        "command": "second",
    }
    merged = results_lib.merge_results(earlier, later)
    assert merged["physics_steps_per_s"] == {"4": 2.0, "8": 1.0}
    assert merged["train"] == [
        {**row, "quadcos_env_steps_per_s": 3.0, "stock_brax_env_steps_per_s": 4.0},
        later["train"][1],
    ]
    assert merged["compile_s"] == {"quadcos": 5.0, "stock_brax": 9.0}
    assert merged["time_to_walk_flat_s"] == 7.0
    assert merged["command"] == ["first", "second"]
    with pytest.raises(ValueError, match="cannot merge"):
        results_lib.merge_results(earlier, {**later, "device": "NVIDIA H100 80GB HBM3"})


def test_randomised_rows_are_rows_of_their_own():
    args = bench._parser().parse_args(["--preset=cpu", "--randomize"])
    assert settings.settings_from_args(args).randomize
    assert settings.make_bench_env("flat", "smoke", "jax", randomize=True).randomized
    assert not settings.make_bench_env("flat", "smoke", "jax").randomized
    row = {
        "num_envs": 4,
        "batch_size": 8,
        "updates_per_step": 1,
        "stock_brax_env_steps_per_s": None,
    }
    nominal = {"device": "cpu", "train": [{**row, "quadcos_env_steps_per_s": 3.0}]}
    randomised = {
        "device": "cpu",
        "randomized": True,
        "train": [{**row, "randomized": True, "quadcos_env_steps_per_s": 2.5}],
    }
    merged = results_lib.merge_results(nominal, randomised)
    assert [r["quadcos_env_steps_per_s"] for r in merged["train"]] == [3.0, 2.5]
    table = results_lib.markdown_table(
        {
            **merged,
            "platform": "cpu",
            "substeps_per_env_step": 10,
            "physics_steps_per_s": {},
            "env_steps_per_s": {},
            "compile_s": {},
            "time_to_walk_flat_s": None,
            "time_to_cross_slope5_s": None,
            "details": {},
        }
    )
    assert "| quadcos | flat | jax, randomised | 4 | 8 | 1 |" in table


def test_a_failed_measurement_is_recorded_and_the_others_still_run(tmp_path, monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", os.environ.get("XLA_FLAGS", ""))

    def out_of_memory(row, *args):
        if row.num_envs == 4:
            raise MemoryError("RESOURCE_EXHAUSTED: 4 envs")
        return {"env_steps_per_s": 10.0, "first_chunk_s": 1.0, "start_to_first_step_s": 2.0}

    monkeypatch.setattr(trainers, "measure_trainer", out_of_memory)
    out = tmp_path / "bench.json"
    argv = [f"--out={out}", "--only=train", "--train_rows=4x8x1,8x8x1"]
    assert bench.main(argv) == 1
    results = json.loads(out.read_text())
    assert results["details"]["errors"] == {
        "train 4x8x1": "MemoryError: RESOURCE_EXHAUSTED: 4 envs"
    }
    assert [row["quadcos_env_steps_per_s"] for row in results["train"]] == [10.0]
    assert results["compile_s"]["quadcos"] == 2.0


def test_slope5_section_trains_with_spawns_along_the_course_and_evaluates_from_the_start():
    course = settings.SECTION_COURSES["slope5"]
    centre = "0.3,0.15,0.5,1.8,-1.3"
    train_env = settings.make_bench_env(
        course.terrain, "scratch", action_centre=centre, **course.env
    )
    eval_env = settings.make_bench_env(course.terrain, "scratch", action_centre=centre)
    assert train_env.config.spawn_x_max == 10.0 and eval_env.config.spawn_x_max == 0.0
    assert train_env.config.action_centre == centre
    goal = time_to_walk.terrain_goal(eval_env)
    assert goal.finish_x == pytest.approx(11.0)  # slope5's end: 2 m lead-in + 3 x 3 m
    assert goal.duration_s == pytest.approx(11.0 / time_to_walk.WALK_MIN_SPEED, abs=0.05)
    assert settings.trainer_config("scratch", **course.sac).episode_length == 400
    assert settings.SECTION_COURSES["walk"] == settings.Course("time_to_walk_flat_s", "flat")
    assert course.result_key == "time_to_cross_slope5_s"


def test_env_overrides_reach_the_env_and_keep_their_rows_apart():
    args = bench._parser().parse_args(
        ["--preset=cpu", "--env", "substep_unroll=2", "--env", "warp.graph_mode=none"]
    )
    chosen = settings.settings_from_args(args).env
    assert chosen == (("substep_unroll", 2), ("warp.graph_mode", "none"))
    env = settings.make_bench_env("flat", "smoke", "jax", **dict(chosen))
    assert (env.config.substep_unroll, env.config.warp.graph_mode) == (2, "none")
    for bad, message in (("substep_unroll", "KEY=VALUE"), ("substep_unrol=2", "substep_unrol")):
        with pytest.raises(ValueError, match=message):
            settings.settings_from_args(bench._parser().parse_args(["--env", bad]))
    row = {"num_envs": 4, "batch_size": 8, "updates_per_step": 1}
    plain = {"device": "cpu", "train": [{**row, "quadcos_env_steps_per_s": 3.0}]}
    text = results_lib.env_text(chosen)
    unrolled = {"device": "cpu", "env": text, "train": [{**row, "env": text}]}
    with pytest.raises(ValueError, match="cannot merge results measured with --env"):
        results_lib.merge_results(plain, unrolled)
    assert results_lib._row_key(plain["train"][0]) != results_lib._row_key(unrolled["train"][0])
    assert text == "substep_unroll=2,warp.graph_mode=none"


def test_trainer_overrides_reach_the_rows_config_and_keep_their_rows_apart():
    args = bench._parser().parse_args(["--preset=cpu", "--sac=steps_per_chunk=8"])
    chosen = settings.settings_from_args(args).sac
    assert chosen == (("steps_per_chunk", 8),)
    row = settings.TrainRow.parse("32x256x4")
    assert settings.trainer_config("cpu", row, **dict(chosen)).steps_per_chunk == 8
    with pytest.raises(ValueError, match="steps_per_chunks"):
        settings.settings_from_args(bench._parser().parse_args(["--sac", "steps_per_chunks=8"]))
    plain = {"device": "cpu", "train": [{"num_envs": 32, "batch_size": 256, "updates_per_step": 4}]}
    short = {"device": "cpu", "train": [{**plain["train"][0], "sac": "steps_per_chunk=8"}]}
    assert len(results_lib.merge_results(plain, short)["train"]) == 2


def test_import_table_splits_the_import_by_what_quadcos_imports_first():
    import importlib.util
    import pathlib

    path = pathlib.Path(__file__).parents[1] / "benchmarks" / "import_table.py"
    spec = importlib.util.spec_from_file_location("import_table", path)
    import_table = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(import_table)
    text = """import time: self [us] | cumulative | imported package
import time:       100 |        100 |       numpy
import time:       200 |        300 |     jax
import time:       400 |        400 |       trimesh
import time:       500 |        900 |     mujoco.mjx
import time:        50 |       1250 |   quadcos.env
import time:        30 |       1280 | quadcos.train
"""
    totals = import_table.by_first_import(import_table.parse(text))
    assert totals == pytest.approx({"jax": 3e-4, "mujoco.mjx": 9e-4, "quadcos": 8e-5})
    assert sum(totals.values()) == pytest.approx(1280e-6)
    assert "| **all** | **0.00** |" in import_table.table(totals, top=1)
