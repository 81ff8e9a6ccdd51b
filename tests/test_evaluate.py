"""`quadcos.evaluate` and `quadcos.plots`: the JSON, the trace, fixed parameters, the search, bad
input, video, figures, and the two engines of `quadcos.deploy.engines.evaluate`.

Compiling a rollout costs tens of seconds on two cores, so there are two: the fixed trot on flat
(4 robots; also the search's and notebook fallbacks') and the stand-in policy on flat (4 robots;
also notebook (a)'s). Every evaluation here has those shapes, so the rest are persistent-cache hits.
"""

import dataclasses
import functools
import json
import math
import pathlib
import shutil
import types

import jax.numpy as jnp
import numpy as np
import pytest
from PIL import Image

from quadcos import evaluate
from quadcos import evaluation as evaluation_lib
from quadcos.equations import oscillator, reward
from quadcos.evaluation import rollout as rollout_lib
from quadcos.robot import constants
from quadcos.viz import plots, video

ROOT = pathlib.Path(__file__).resolve().parent.parent
# A trained flat-ground run (its config.json and metrics.jsonl; its policy is the shipped
# experiments/policies/flat, put back into a copy of the run by `stand_in_run`).
STAND_IN_RUN = ROOT / "tests" / "data" / "trained" / "flat" / "flat_s0"
FLAT_POLICY = ROOT / "experiments" / "policies" / "flat"
LEGACY_POLICY = ROOT / "tests" / "data" / "trained" / "archive" / "flat_gpu" / "paper_20hz" / "policy"
NUM_ENVS, SECONDS = 4, 2.0


def _video_supported() -> bool:
    try:
        video.check_video_support()
    except video.VideoError:
        return False
    return True


@pytest.fixture(scope="session")
def fixed_trot_files(tmp_path_factory):
    """`python -m quadcos.evaluate --policy=fixed:trot` (in-process): its JSON, trace and video."""
    out = tmp_path_factory.mktemp("evaluate")
    files = {"out": out / "trot.json", "trace": out / "trot_trace.json", "video": out / "trot.mp4"}
    args = [
        "--policy=fixed:trot",
        "--terrain=flat",
        f"--num_envs={NUM_ENVS}",
        f"--seconds={SECONDS}",
        f"--out={files['out']}",
        f"--trace={files['trace']}",
        "--video_size=96x64",
        "--no_progress",
    ]
    if _video_supported():
        args.append(f"--video={files['video']}")
    assert evaluate.main(args) == 0
    return files


@pytest.fixture(scope="session")
def fixed_trot_result(fixed_trot_files):
    return json.loads(fixed_trot_files["out"].read_text())


@pytest.fixture(scope="session")
def stand_in_run(tmp_path_factory) -> pathlib.Path:
    """A run folder: the stand-in run's files with the flat policy as its `policy`."""
    run = tmp_path_factory.mktemp("trained") / STAND_IN_RUN.name
    shutil.copytree(STAND_IN_RUN, run)
    shutil.copytree(FLAT_POLICY, run / "policy")
    return run


@pytest.fixture(scope="session")
def policy_evaluation(stand_in_run):
    """The stand-in trained run evaluated through the library on its training terrain (flat)."""
    return evaluation_lib.evaluate(
        str(stand_in_run), num_envs=NUM_ENVS, seconds=SECONDS, trace_episode=1
    )


REQUIRED_KEYS = (
    "num_episodes",
    "success_rate",
    "fall_rate",
    "mean_forward_speed",
    "mean_max_abs_roll",
    "mean_max_abs_yaw",
    "mean_max_abs_pitch_error",
    "mean_lateral_drift",
    "slope_error_rms",
)


def test_evaluation_json_has_the_aggregates_and_episodes(fixed_trot_result):
    result = fixed_trot_result
    for key in REQUIRED_KEYS:
        assert key in result, key
    assert result["num_episodes"] == NUM_ENVS == len(result["episodes"])
    assert result["setup"]["terrain"] == "flat" and result["setup"]["course_end_x"] is None
    assert result["setup"]["robot"]["name"] == "quadcos"
    assert result["setup"]["num_steps"] == 40 and result["setup"]["seconds"] == pytest.approx(2.0)
    for key in ("success_rate", "fall_rate"):
        assert 0.0 <= result[key] <= 1.0
    for key in REQUIRED_KEYS[4:]:
        assert math.isfinite(result[key]) and result[key] >= 0.0, key
    speeds = [episode["forward_speed"] for episode in result["episodes"]]
    assert result["mean_forward_speed"] == pytest.approx(np.mean(speeds))
    # slope_error_rms pools the steps of all episodes; here all episodes ran all 40 steps
    per_episode = [episode["slope_error_rms"] for episode in result["episodes"]]
    assert result["slope_error_rms"] == pytest.approx(math.sqrt(np.mean(np.square(per_episode))))


def test_fixed_trot_walks_on_flat(fixed_trot_result):
    result = fixed_trot_result
    assert result["success_rate"] == 1.0 and result["fall_rate"] == 0.0
    assert result["setup"]["fixed_parameters"]["period"] == pytest.approx(0.6)
    assert 0.3 < result["mean_forward_speed"] < 1.0  # oscillator.FIXED_TROT: ~0.5 m/s
    assert result["mean_max_abs_roll"] < 0.3 and result["mean_max_abs_pitch_error"] < 0.3
    assert result["slope_error_rms"] < math.radians(3)  # the estimator on level ground
    for episode in result["episodes"]:
        assert episode["success"] and episode["timed_out"] and episode["fall_time_s"] is None
        assert episode["seconds"] == pytest.approx(2.0)
        assert episode["distance"] == pytest.approx(episode["final_x"], abs=1e-6)
        assert sum(episode["reward_terms"].values()) == pytest.approx(
            episode["episode_reward"], rel=1e-4
        )


def test_trace_has_every_series_at_one_length(fixed_trot_files):
    trace = json.loads(fixed_trot_files["trace"].read_text())
    series = trace["series"]
    expected = {
        *evaluation_lib.TRACE_SERIES,
        *(f"controller/{joint}" for joint in constants.JOINTS),
        *(f"joint/{joint}" for joint in constants.JOINTS),
        *(f"parameter/{name}" for name in oscillator.RhythmParameters._fields),
        *(f"action/{i}" for i in range(5)),
    }
    assert expected <= set(series)
    assert {len(values) for values in series.values()} == {40}
    np.testing.assert_allclose(series["time"], np.arange(1, 41) * 0.05, atol=1e-5)
    assert trace["success"] and not trace["fell"]
    # fixed parameters: the parameters in force are FIXED_TROT at every step
    for name, value in oscillator.FIXED_TROT._asdict().items():
        np.testing.assert_allclose(series[f"parameter/{name}"], value, atol=1e-4)
    # the controller outputs are Eq. 3 of those parameters: knees half-wave, hips within ±A_h
    knees = np.array([series[f"controller/{leg}_knee"] for leg in constants.LEGS])
    hips = np.array([series[f"controller/{leg}_hip"] for leg in constants.LEGS])
    assert knees.min() >= 0.0 and knees.max() <= 0.4 + 1e-5
    assert np.abs(hips).max() <= 0.15 + 1e-5 and np.abs(hips).max() > 0.1
    np.testing.assert_allclose(series["expected_pitch"], 0.0)
    qpos = np.array(trace["qpos"])  # from reset on: one row more than the series
    assert qpos.shape == (41, 15)
    np.testing.assert_allclose(qpos[1:, 0], series["cog_x"], atol=1e-6)
    assert trace["env"]["terrain"] == "flat" and trace["env"]["action_filter_tau"] == 0.25


@pytest.mark.slow
def test_a_second_evaluation_of_a_network_shape_reuses_the_compiled_rollout(policy_evaluation):
    # The stand-in run's policy folder: the same env, network shape and number of robots as
    # `policy_evaluation`, another source object.
    del policy_evaluation
    before = rollout_lib._compiled_chunk.cache_info()
    again = evaluation_lib.evaluate(str(FLAT_POLICY), num_envs=NUM_ENVS, seconds=SECONDS)
    after = rollout_lib._compiled_chunk.cache_info()
    assert after.misses == before.misses and after.hits == before.hits + 1
    assert again.summary["num_episodes"] == NUM_ENVS and again.summary["fall_rate"] == 0.0


@pytest.mark.slow
def test_policy_run_is_evaluated_in_its_training_env(policy_evaluation):
    evaluation = policy_evaluation
    setup = evaluation.summary["setup"]
    assert setup["policy_kind"] == "sac" and setup["terrain"] == "flat"
    assert setup["impl"] == "jax"  # "auto" on a machine without a GPU
    saved = json.loads((STAND_IN_RUN / "config.json").read_text())["run_info"]["env"]
    assert setup["env"]["action_filter_tau"] == saved["action_filter_tau"]
    assert evaluation.summary["num_episodes"] == NUM_ENVS
    # the stand-in walks (0.9 m/s in training's 20-s evaluations): a wrongly rebuilt env would not
    assert evaluation.summary["fall_rate"] == 0.0 and evaluation.summary["mean_forward_speed"] > 0.5
    trace = evaluation.trace
    assert trace["episode"] == 1
    steps = round(evaluation.episodes[1]["seconds"] / 0.05)
    assert {len(values) for values in trace["series"].values()} == {steps}
    assert len(evaluation.qpos) == len(trace["series"]["time"]) + 1  # the reset pose first
    periods = np.array(trace["series"]["parameter/period"])
    assert np.all((periods >= 0.2 - 1e-6) & (periods <= 2.0 + 1e-6))


def test_legacy_policy_gets_the_env_of_its_time():
    spec = evaluation_lib.PolicySpec.parse(str(LEGACY_POLICY))
    assert spec.kind == "directory" and spec.robot == "quadcos"
    assert spec.env_options["action_filter_tau"] == 0.0
    assert spec.env_options["action_centre"] == "midpoint"
    assert spec.env_config().action_centre == "midpoint"
    env = evaluation_lib.build_env(spec.action_source())
    assert env.observation_size == spec.observation_size == 14


def test_evaluation_starts_at_the_spawn_point_wherever_training_spawned():
    source = evaluation_lib.PolicySpec.parse(str(LEGACY_POLICY)).action_source()
    trained_spread = dataclasses.replace(
        source, env_overrides={**source.env_overrides, "spawn_x_max": 8.0}
    )
    assert evaluation_lib.build_env(trained_spread, "slope5").config.spawn_x_max == 0.0
    spec = evaluation_lib.PolicySpec.parse("fixed:trot")
    spread = dataclasses.replace(spec, env_options={"spawn_x_max": 8.0})
    assert spread.env_config().spawn_x_max == 0.0  # the C MuJoCo engine's config: the same


def test_both_engines_run_through_one_function_and_write_one_format(fixed_trot_result):
    from quadcos.deploy import engines

    mujoco = engines.evaluate(
        "fixed:trot", "flat", engine="mujoco", episodes=NUM_ENVS, seconds=SECONDS
    ).to_json()
    assert mujoco["setup"]["engine"] == "mujoco" and "engine" not in fixed_trot_result["setup"]
    assert set(fixed_trot_result) == set(mujoco)
    assert set(fixed_trot_result["episodes"][0]) <= set(mujoco["episodes"][0])
    assert mujoco["success_rate"] == fixed_trot_result["success_rate"] == 1.0
    assert mujoco["mean_forward_speed"] == pytest.approx(
        fixed_trot_result["mean_forward_speed"], abs=0.15
    )
    with pytest.raises(ValueError, match="unknown engine 'warp'; known: mjx, mujoco"):
        engines.evaluate("fixed:trot", engine="warp")
    with pytest.raises(ValueError, match="options of the mujoco engine"):
        engines.evaluate("fixed:trot", engine="mjx", obs_noise=0.1)
    with pytest.raises(ValueError, match="options of the mujoco engine"):
        engines.evaluate("fixed:trot", engine="mjx", friction=0.4)
    with pytest.raises(ValueError, match="trace_episode is an mjx option"):
        engines.evaluate("fixed:trot", engine="mujoco", trace_episode=1)


def test_episode_statistics_stop_at_a_fall_and_at_the_course_end():
    def state(x, done):
        n = len(x)
        qpos = np.zeros((n, 15), np.float32)
        qpos[:, 0], qpos[:, 3] = x, 1.0
        metrics = {f"reward/{term}": jnp.ones(n) for term in reward.TERM_NAMES}
        metrics |= {"slope_estimate": jnp.full(n, 0.1), "slope_truth": jnp.zeros(n)}
        metrics |= {"abs_roll": jnp.zeros(n), "abs_pitch_error": jnp.zeros(n)}  # the env's
        return types.SimpleNamespace(
            pipeline_state=types.SimpleNamespace(qpos=jnp.asarray(qpos)),
            metrics=metrics,
            done=jnp.asarray(done, jnp.float32),
            reward=jnp.full(n, 5.0),
        )

    start = state([0.0, 0.0, 0.0], [0, 0, 0])
    stats = rollout_lib._initial_stats(start, jnp.zeros(3, jnp.int32))
    # robot 0 walks on, robot 1 falls, robot 2 crosses the course end at x = 1
    update = rollout_lib._update_stats
    stats = update(stats, state([0.5, 0.5, 1.2], [0, 1, 0]), stats.running, jnp.ones(1))
    stats = update(stats, state([0.9, 0.7, 1.5], [0, 1, 0]), stats.running, jnp.ones(1))
    np.testing.assert_array_equal(stats.running, [True, False, False])
    np.testing.assert_array_equal(stats.fell, [False, True, False])
    np.testing.assert_array_equal(stats.finished, [False, False, True])
    np.testing.assert_array_equal(stats.steps, [2, 1, 1])
    np.testing.assert_allclose(stats.x, [0.9, 0.5, 1.2])
    np.testing.assert_allclose(stats.episode_reward, [10.0, 5.0, 5.0])
    np.testing.assert_allclose(stats.slope_sq_error, [0.02, 0.01, 0.01], rtol=1e-5)


def test_search_ranks_fixed_parameters_by_reward_without_falls(tmp_path):
    out = tmp_path / "search.json"
    args = ["--search_fixed", "--terrain=flat", "--num_candidates=2", "--robots_per_candidate=2"]
    args += ["--rounds=2", "--seconds=1", "--seed=1", f"--out={out}", "--no_progress"]
    assert evaluate.main(args) == 0
    result = json.loads(out.read_text())
    ranking = result["ranking"]
    assert result["num_evaluated"] == 4 and len(ranking) == 4
    scores = [entry["score"] for entry in ranking]
    finite = [score for score in scores if score is not None]
    assert finite == sorted(finite, reverse=True) and scores[: len(finite)] == finite
    for entry in ranking:
        assert (entry["score"] is None) == (entry["fall_rate"] > 0)
    trot = next(
        e for e in ranking if e["round"] == 1 and e["policy"].startswith("fixed:0.4,0.15,0.6")
    )
    assert trot["fall_rate"] == 0.0 and ranking[0]["score"] >= trot["score"]
    best = evaluation_lib.parse_fixed(ranking[0]["policy"].removeprefix("fixed:"))
    assert best == pytest.approx(tuple(ranking[0]["parameters"].values()), abs=1e-5)
    # Every candidate can be an action centre: strictly inside §3.3's box, never on an end.
    for entry in ranking:
        oscillator.action_centre(oscillator.centre_spec(entry["parameters"].values()), oscillator.PERIOD_MIN)
    # `score_gaits` scores gaits as the search's first round scored its candidates.
    from quadcos.evaluation.fixed_search import score_gaits

    first = sorted((e for e in ranking if e["round"] == 1), key=lambda e: e is not trot)
    rescored = score_gaits(
        "flat", [list(e["parameters"].values()) for e in first], robots=2, seconds=1, seed=1
    )
    assert [e["mean_episode_reward"] for e in rescored] == pytest.approx(
        [e["mean_episode_reward"] for e in first], rel=1e-5
    )
    # A speed floor ranks only the gaits that reach it: at 2 m/s none of these.
    floored = tmp_path / "floored.json"
    args[-2] = f"--out={floored}"
    assert evaluate.main([*args, "--min_speed=2"]) == 0
    floored_result = json.loads(floored.read_text())
    assert floored_result["setup"]["min_speed"] == 2.0
    assert [e["score"] for e in floored_result["ranking"]] == [None] * 4
    assert all(e["mean_forward_speed"] < 2 for e in floored_result["ranking"])
    # A confirmation reruns the rounds' best on more robots (here the whole batch: 4) and ranks
    # by that run alone: the same rounds (same seed) give the same finalist, scored anew.
    confirmed = tmp_path / "confirmed.json"
    args[-2] = f"--out={confirmed}"
    assert evaluate.main([*args, "--confirm_robots=4"]) == 0
    confirmed_result = json.loads(confirmed.read_text())
    assert confirmed_result["confirmation"]["robots"] == 4
    assert confirmed_result["confirmation"]["candidates"] == 1
    best_scores = [[r["best_score"] for r in out["rounds"]] for out in (result, confirmed_result)]
    assert best_scores[0] == best_scores[1] and confirmed_result["num_evaluated"] == 4
    (finalist,) = confirmed_result["ranking"]
    assert finalist["policy"] == ranking[0]["policy"] and finalist["round"] == 3
    assert (finalist["fall_rate"] * 4).is_integer()
    assert result["confirmation"] is None and confirmed_result["setup"]["confirm_robots"] == 4
    with pytest.raises(ValueError, match="confirm_robots must be 0 or divide .* = 4; got 3"):
        evaluation_lib.search_fixed(num_candidates=2, robots_per_candidate=2, confirm_robots=3)
    # An `on_round` that says stop ends the rounds after that one.
    seen = []
    stopped = evaluation_lib.search_fixed(
        num_candidates=2, robots_per_candidate=2, rounds=2, seconds=1, seed=1,
        on_round=lambda entry: seen.append(entry["round"]) or True,
    )
    assert seen == [1] and len(stopped["rounds"]) == 1 and stopped["num_evaluated"] == 2
    assert stopped["rounds"][0]["best_score"] == result["rounds"][0]["best_score"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--policy=/no/such/run"], "no policy at /no/such/run"),
        (["--policy=fixed:trot", "--terrain=s5"], "unknown terrain 's5'"),
        (["--policy=fixed:trot", "--terrain=sections:5@x"], "bad section"),
        (["--policy=fixed:0.4,0.15,0.6"], "five numbers"),
        (["--policy=fixed:0.4,0.15,5,0,0"], "period=5 is outside"),
        (["--policy=fixed:0.4,0.15,0.6,pi/2,exit()"], "'exit()' is not a number"),
        ([f"--policy={FLAT_POLICY}", "--env.observe_slope=True"], "observations of size 19"),
        (["--policy=fixed:trot", "--env.no_such_option=1"], "unknown config key"),
        (["--policy=fixed:trot", "--env.observe_slope"], "unrecognised argument"),
        (["--policy=fixed:trot", "--env.terrain=s4"], "the terrain is not an env option"),
        (["--policy=README.md"], "bad policy 'README.md'"),
        (["--policy=fixed:trot", "--num_envs=0"], "--num_envs must be >= 1"),
        (
            ["--policy=fixed:trot", "--num_envs=4", "--trace_episode=4"],
            "--trace_episode must be in 0..3",
        ),
        (["--policy=fixed:trot", "--video=v.avi"], "--video must end in .mp4"),
        (
            ["--search_fixed", "--policy=fixed:trot"],
            "exactly one of --policy, --search_fixed and --render",
        ),
        (["--policy=fixed:trot", "--rounds=2"], "--rounds: search flags, for --search_fixed only"),
        (["--policy=fixed:trot", "--terrain=math:pi"], "math.pi is float, not a Terrain"),
    ],
)
def test_bad_input_is_one_line_and_status_2(args, message, tmp_path, capsys):
    out = tmp_path / "result.json"
    status = evaluate.main([*args, f"--out={out}", "--no_progress"])
    error = capsys.readouterr().err.strip()
    assert status == 2
    assert error.startswith("quadcos.evaluate: error:") and "\n" not in error
    assert message in error
    assert list(tmp_path.iterdir()) == []


def test_nothing_is_said_to_compile_before_the_inputs_are_checked(tmp_path, capsys):
    assert evaluate.main([f"--policy={tmp_path / 'missing'}"]) == 2  # progress on
    error = capsys.readouterr().err.strip()
    assert error.startswith("quadcos.evaluate: error: no policy at") and "\n" not in error


def test_out_in_a_missing_directory_is_refused(tmp_path, capsys):
    status = evaluate.main(["--policy=fixed:trot", f"--out={tmp_path / 'no' / 'r.json'}"])
    assert status == 2 and "is not a writable directory" in capsys.readouterr().err


def test_video_without_headless_opengl_names_the_missing_library(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.setattr(video.ctypes.util, "find_library", lambda name: None)
    args = ["--policy=fixed:trot", f"--out={tmp_path / 'r.json'}", f"--video={tmp_path / 'v.mp4'}"]
    assert evaluate.main(args) == 2
    error = capsys.readouterr().err.strip()
    assert "libOSMesa" in error and "\n" not in error
    assert list(tmp_path.iterdir()) == []


def _frames(path: pathlib.Path) -> np.ndarray:
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    assert meta["fps"] == pytest.approx(20.0)
    width, height = meta["size"]
    return np.stack([np.frombuffer(frame, np.uint8).reshape(height, width, 3) for frame in reader])


@pytest.mark.filterwarnings("ignore:os.fork")
def test_video_shows_the_rollout_and_a_saved_trace_renders_the_same(fixed_trot_files, tmp_path):
    if not _video_supported():
        pytest.skip("no headless OpenGL here (libEGL / libOSMesa)")
    frames = _frames(fixed_trot_files["video"])
    assert frames.shape == (41, 64, 96, 3)  # the reset pose and 40 control steps
    assert np.ptp(frames[0]) > 50  # not a blank frame: the robot stands out from the floor
    assert np.abs(frames[-1].astype(int) - frames[0]).mean() > 1  # the legs moved
    rendered = tmp_path / "from_trace.mp4"
    args = [f"--render={fixed_trot_files['trace']}", f"--video={rendered}", "--video_size=96x64"]
    assert evaluate.main(args) == 0
    assert np.abs(_frames(rendered).astype(int) - frames).mean() < 1.0


@pytest.mark.slow
def test_plots_write_pngs(fixed_trot_files, policy_evaluation, tmp_path):
    trace = fixed_trot_files["trace"]
    figures = {
        "cog": plots.plot_cog(trace, path=tmp_path / "cog.png"),
        "attitude": plots.plot_attitude(
            {"trot": trace, "policy": policy_evaluation.trace}, path=tmp_path / "attitude.png"
        ),
        "controller": plots.plot_controller(
            trace, window=(0.5, 1.5), path=tmp_path / "controller.png"
        ),
        "parameters": plots.plot_parameters(policy_evaluation, path=tmp_path / "parameters.png"),
        "course": plots.plot_course(policy_evaluation.env.terrain, path=tmp_path / "course.png"),
        "learning": plots.plot_learning_curves(
            sorted(STAND_IN_RUN.parent.glob("flat_s*")), path=tmp_path / "learning.png"
        ),
    }
    for name, figure in figures.items():
        png = tmp_path / f"{name}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
        assert Image.open(png).mode == "P", name  # a palette, as the docs' figures
        assert figure.axes, name
    assert len(figures["cog"].axes) == 3 and len(figures["controller"].axes) == 4


def test_learning_curve_band_is_the_t_interval_across_seeds():
    runs = [
        [{"step": 0, "m": 0.0}, {"step": 10, "m": 10.0}],
        [{"step": 0, "m": 2.0}, {"step": 10, "m": 14.0}],
        [{"step": 0, "m": 4.0}, {"step": 10, "m": 18.0}],
    ]
    curve = plots.learning_curve(runs, "m", points=3)
    np.testing.assert_allclose(curve["step"], [0, 5, 10])
    np.testing.assert_allclose(curve["mean"], [2.0, 8.0, 14.0])
    half_width = 4.302652729911275 * 2.0 / math.sqrt(3)  # t_{0.975, 2} · sd / √n, sd = 2 at step 0
    np.testing.assert_allclose(curve["high"][0] - curve["mean"][0], half_width, rtol=1e-6)
    with pytest.raises(ValueError, match="has no 'other'"):
        plots.learning_curve(runs, "other")


def test_a_step_that_blew_up_leaves_its_episode_diverged():
    # The env marks a blown-up step with a NaN reward (env.layout.MAX_SPEED), its position
    # still finite: the episode's position turns NaN, so that it counts in `diverged_rate`.
    from quadcos.evaluation import metrics, rollout

    stats = rollout._initial_stats(
        types.SimpleNamespace(pipeline_state=types.SimpleNamespace(qpos=jnp.zeros((2, 19)))),
        jnp.zeros(2, jnp.int32),
    )
    qpos = jnp.zeros((2, 19)).at[:, 0].set(jnp.array([0.5, 5e4])).at[:, 3].set(1.0)
    state = types.SimpleNamespace(
        pipeline_state=types.SimpleNamespace(qpos=qpos),
        reward=jnp.array([1.0, jnp.nan]),
        done=jnp.array([0.0, 1.0]),
        metrics={"slope_estimate": jnp.zeros(2), "slope_truth": jnp.zeros(2)}
        | {"abs_roll": jnp.zeros(2), "abs_pitch_error": jnp.zeros(2)}
        | {f"reward/{term}": jnp.zeros(2) for term in stats.reward_terms},
    )
    stats = rollout._update_stats(stats, state, jnp.ones(2, bool), jnp.full(1, jnp.inf))
    episodes = metrics.episode_values(stats, dt=1.0, num_steps=1)
    assert [e["fell"] for e in episodes] == [False, True]
    assert episodes[0]["distance"] == pytest.approx(0.5) and math.isnan(episodes[1]["distance"])


def test_a_diverged_episode_is_counted_and_left_out_of_the_means():
    from quadcos.evaluation import metrics
    from quadcos.evaluation.rollout import EpisodeStats

    def column(*values):
        return np.asarray(values, dtype=float)

    nan = float("nan")
    stats = EpisodeStats(
        lane=np.zeros(3, np.int32),
        fell=np.array([False, False, True]),
        finished=np.zeros(3, bool),
        running=np.zeros(3, bool),
        steps=np.array([10, 10, 4], np.int32),
        start_x=column(0, 0, 0),
        start_y=column(0, 0, 0),
        x=column(5, 3, nan),
        y=column(0.1, 0.3, nan),
        max_lateral_deviation=column(0.1, 0.3, nan),
        max_abs_roll=column(0.1, 0.2, nan),
        max_abs_yaw=column(0.1, 0.2, 0.3),
        max_abs_pitch_error=column(0.1, 0.2, nan),
        slope_sq_error=column(0.1, 0.3, nan),
        episode_reward=column(100, 50, nan),
        reward_terms={name: column(1, 2, nan) for name in metrics.reward.TERM_NAMES},
    )
    episodes = metrics.episode_values(stats, dt=1.0, num_steps=10)
    for episode in episodes:
        episode["success"] = not episode["fell"]
    summary = metrics.aggregate(episodes, stats)
    assert summary["diverged_rate"] == pytest.approx(1 / 3)
    assert summary["fall_rate"] == pytest.approx(1 / 3)
    assert summary["success_rate"] == pytest.approx(2 / 3)
    assert summary["mean_forward_speed"] == pytest.approx(0.4)  # (0.5 + 0.3) / 2
    assert summary["mean_max_abs_yaw"] == pytest.approx(0.2)  # finite everywhere: all three
    assert summary["slope_error_rms"] == pytest.approx(math.sqrt(0.4 / 20))
    assert summary["mean_reward_terms"]["survival"] == pytest.approx(1.5)


def test_a_speed_floor_orders_the_gaits_it_rules_out_towards_it():
    from quadcos.evaluation.fixed_search import ranking_key

    inf = float("inf")
    candidates = {
        "eligible, low reward": {"score": 10.0, "fall_rate": 0.0, "mean_forward_speed": 0.9},
        "eligible, high reward": {"score": 50.0, "fall_rate": 0.0, "mean_forward_speed": 0.85},
        "no falls, too slow": {"score": -inf, "fall_rate": 0.0, "mean_forward_speed": 0.6},
        "no falls, slower": {"score": -inf, "fall_rate": 0.0, "mean_forward_speed": 0.3},
        "falls, fast": {"score": -inf, "fall_rate": 0.5, "mean_forward_speed": 1.5},
    }
    ordered = sorted(candidates, key=lambda n: ranking_key(candidates[n], 0.8), reverse=True)
    assert ordered == [
        "eligible, high reward",
        "eligible, low reward",
        "no falls, too slow",
        "no falls, slower",
        "falls, fast",
    ]
    # Without a floor only the score counts (ties keep their order, as before the floor).
    assert ranking_key(candidates["falls, fast"]) == ranking_key(candidates["no falls, slower"])
    # Held to the slowest robot, a floor ranks the gaits it rules out by that robot's speed.
    uneven = {"score": -inf, "fall_rate": 0.0, "mean_forward_speed": 0.6, "slowest_forward_speed": 0.2}
    even = {"score": -inf, "fall_rate": 0.0, "mean_forward_speed": 0.3, "slowest_forward_speed": 0.25}
    assert ranking_key(uneven, 0.8) > ranking_key(even, 0.8)
    assert ranking_key(even, 0.8, "slowest") > ranking_key(uneven, 0.8, "slowest")
    with pytest.raises(ValueError, match="min_speed_of must be one of .*'median'"):
        evaluation_lib.search_fixed(min_speed=0.8, min_speed_of="median")


def test_an_attitude_bound_ranks_only_level_gaits_and_breeds_towards_them():
    from quadcos.evaluation import fixed_search

    def episode(roll, pitch_error, fell=False):
        return {"forward_speed": 0.6, "episode_reward": 100.0, "fell": fell, "max_abs_yaw": 0.1,
                "max_abs_roll": roll, "max_abs_pitch_error": pitch_error, "lateral_drift": 0.0}

    eligible = functools.partial(fixed_search.eligible, min_speed=0.0, min_speed_of="mean",
                                 max_attitude=0.1)
    params = np.zeros(5)
    level = fixed_search._candidate_entry(params, [episode(0.05, 0.09)] * 2, 1, eligible)
    assert level["score"] == 100.0
    assert level["mean_max_abs_pitch_error"] == pytest.approx(0.09)
    # The mean of the robots' peaks is held to the bound, roll and pitch error alike.
    rolled = fixed_search._candidate_entry(params, [episode(0.05, 0.05), episode(0.17, 0.05)], 1,
                                           eligible)
    pitched = fixed_search._candidate_entry(params, [episode(0.05, 0.14)] * 2, 1, eligible)
    assert rolled["score"] == pitched["score"] == -math.inf
    fell = fixed_search._candidate_entry(params, [episode(0.05, 0.05, fell=True)] * 2, 1, eligible)
    ordered = sorted([fell, pitched, rolled, level],
                     key=lambda c: fixed_search.ranking_key(c, max_attitude=0.1), reverse=True)
    # Level first; then the clean ones by how little they exceed it (rolled by 0.01, pitched by
    # 0.04); the one that fell last.
    assert ordered == [level, rolled, pitched, fell]
    confirmed = sorted([fell, pitched, rolled, level],
                       key=lambda c: fixed_search.confirmation_key(c, max_attitude=0.1),
                       reverse=True)
    assert confirmed == [level, rolled, pitched, fell]
    # Without the bound they all rank by score alone, the rolled and pitched among the clean.
    assert all(fixed_search.eligible(c, 0.0, "mean") for c in (rolled, pitched))
    with pytest.raises(ValueError, match="max_attitude must be finite and >= 0 rad .*-0.1"):
        evaluation_lib.search_fixed(max_attitude=-0.1)


def test_a_confirmation_ranks_clean_gaits_first_then_the_one_that_fell_least():
    from quadcos.evaluation.fixed_search import confirmation_key

    inf = float("inf")
    candidates = {
        "clean": {"score": 10.0, "fall_rate": 0.0, "mean_forward_speed": 0.81},
        "fell once, fast": {"score": -inf, "fall_rate": 1 / 64, "mean_forward_speed": 1.2},
        "fell twice, faster": {"score": -inf, "fall_rate": 2 / 64, "mean_forward_speed": 1.5},
        "clean, too slow": {"score": -inf, "fall_rate": 0.0, "mean_forward_speed": 0.5},
    }
    ordered = sorted(candidates, key=lambda n: confirmation_key(candidates[n], 0.8), reverse=True)
    assert ordered == ["clean", "clean, too slow", "fell once, fast", "fell twice, faster"]
    # Without a floor the gaits that fell equally often go by speed.
    fast, slow = dict(candidates["fell once, fast"]), dict(candidates["fell once, fast"])
    slow["mean_forward_speed"] = 0.3
    assert confirmation_key(fast) > confirmation_key(slow)


def test_the_cli_switches_the_caches_on_before_it_compiles(tmp_path, monkeypatch, capsys):
    calls = []
    monkeypatch.setattr(evaluate.caches, "enable", lambda: calls.append("caches") or {})

    def stop(*_, **__):
        calls.append("evaluate")
        raise ValueError("stopped here")

    monkeypatch.setattr(evaluate.engines, "evaluate", stop)
    argv = ["--policy=fixed:trot", "--num_envs=2", "--no_progress", f"--out={tmp_path / 'e.json'}"]
    assert evaluate.main(argv) == 2
    assert calls == ["caches", "evaluate"] and "stopped here" in capsys.readouterr().err
