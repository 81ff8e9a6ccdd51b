"""Tests of the SAC trainer on a toy env: learning, resume, NaN guard, files; and a run in two
phases (`sac.at_actor_start`) on the smoke preset."""

import json
import logging
import os
import shutil
import signal
import time
import types
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest
from brax import envs
from brax.training.acme import running_statistics, specs

from quadcos import training
from quadcos._util import caches
from quadcos._util.cli import UsageError
from quadcos.training import best_policy, checkpoint, host, loop, phases, sac, updates
from quadcos.training import policy as policy_lib
from quadcos.training import state as state_lib
from quadcos.training.checks import ConfigError
from quadcos.training.presets import PRESETS, build_config
from tests.toy_env import CHUNK, PointEnv, toy_config

pytestmark = pytest.mark.slow

# Sum of rewards of a deterministic policy that has learned to go to the
# target; the optimum is about -0.4, uniform random actions get about -9.
LEARNED_RETURN = -2.5
# Keys whose values depend on timing, not on the computation.
TIMING_KEYS = ("wall_time_s", "env_steps_per_s")


def without_timing(rows):
    return [{name: value for name, value in row.items() if name not in TIMING_KEYS} for row in rows]


def random_policy_return(env: PointEnv, episodes: int = 256) -> float:
    """Mean return of uniform random actions over eval-length episodes."""
    key_reset, key_actions = jax.random.split(jax.random.PRNGKey(1))
    state = jax.vmap(env.reset)(jax.random.split(key_reset, episodes))
    actions = jax.random.uniform(key_actions, (20, episodes, 1), minval=-1.0, maxval=1.0)

    def step(state, action):
        state = jax.vmap(env.step)(state, action)
        return state, state.reward

    _, rewards = jax.lax.scan(step, state, actions)
    return float(jnp.mean(jnp.sum(rewards, axis=0)))


# --- Learning ---------------------------------------------------------------


@pytest.fixture(scope="module")
def learned(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("learned")
    config = toy_config(
        num_timesteps=CHUNK + 10 * CHUNK, eval_interval=2 * CHUNK, keep_best_policy=True
    )
    return training.train(PointEnv(), config, run_dir, progress=False)


def test_learns_toy_task(learned):
    random_return = random_policy_return(PointEnv())
    final_return = learned.metrics["eval/episode_reward"]
    assert random_return < -6.0
    assert final_return > LEARNED_RETURN
    assert final_return > random_return + 5.0
    assert learned.metrics["eval/fall_rate"] == 0.0
    # reward/ metrics are per-episode sums, others per-step means.
    assert learned.metrics["eval/reward/distance"] == pytest.approx(final_return)
    assert 0.0 < learned.metrics["eval/distance"] < 0.2


def test_updates_beside_the_env_step_learn_store_every_transition_and_copy_no_buffer():
    """overlap_updates: each step's updates draw before its transitions are stored; a chunk still
    stores them all, the toy task is learned, and the buffer is never copied (in place)."""
    config = toy_config(
        num_timesteps=CHUNK + 10 * CHUNK, eval_interval=10 * CHUNK, overlap_updates=True
    )
    result = training.train(PointEnv(), config, None, progress=False)
    assert result.metrics["eval/episode_reward"] > LEARNED_RETURN
    assert int(result.state.replay.size) == result.env_steps == 11 * CHUNK
    chunk = jax.jit(result.trainer._train_chunk, donate_argnums=0)
    program = chunk.lower(result.state).compile().as_text()
    buffer = "f32[%d,%d]" % result.state.replay.data.shape
    assert buffer in program
    assert not [line for line in program.splitlines() if f"= {buffer}" in line and " copy(" in line]


def test_chunk_traced_once(learned):
    assert learned.env_steps >= CHUNK + 3 * CHUNK
    assert learned.chunk_traces == 1


def test_run_files(learned):
    run_dir = learned.run_dir
    rows = [json.loads(line) for line in (run_dir / "metrics.jsonl").open()]
    assert rows == learned.history
    steps = [row["step"] for row in rows]
    assert steps == [0, 2 * CHUNK, 4 * CHUNK, 6 * CHUNK, 8 * CHUNK, 10 * CHUNK, 11 * CHUNK]
    for name in (
        "train/critic_loss",
        "train/actor_loss",
        "train/alpha_loss",
        "train/alpha",
        "train/nan_resets",
        "env_steps_per_s",
    ):
        assert name in rows[-1]
    csv_lines = (run_dir / "metrics.csv").read_text().splitlines()
    assert len(csv_lines) == len(rows) + 1
    assert csv_lines[0].startswith("step,wall_time_s,env_steps_per_s")
    info = json.loads((run_dir / "config.json").read_text())
    assert info["config"]["num_envs"] == 16
    assert "jax" in info["versions"] and "brax" in info["versions"]
    assert list((run_dir / "tensorboard").iterdir())
    with checkpoint.CheckpointStore(run_dir / "checkpoints", 3) as store:
        assert store.steps() == [8 * CHUNK, 10 * CHUNK, 11 * CHUNK]


def test_policy_round_trip(learned):
    policy = training.load_policy(learned.run_dir)
    observations = jnp.array([[0.0, 0.5], [0.5, 0.0], [0.9, -0.4]])
    actions = policy.act(observations)
    assert actions.shape == (3, 1)
    np.testing.assert_array_equal(actions, learned.policy.act(observations))
    # Loose: GPUs may use TF32 matmuls, whose rounding depends on the batch.
    np.testing.assert_allclose(jax.jit(policy.act)(observations[0]), actions[0], atol=1e-2)
    # Left of the target it moves right, right of it it moves left.
    assert actions[0, 0] > 0.0 > actions[2, 0], actions
    assert policy.config["config"]["hidden_sizes"]["policy"] == [32, 32]
    again = training.load_policy(learned.run_dir / "policy")
    np.testing.assert_array_equal(again.act(observations), actions)


def test_best_policy_is_that_of_the_best_evaluation(learned):
    rows = learned.history
    best_row = max(rows, key=lambda row: row["eval/episode_reward"])
    assert best_row["eval/episode_reward"] > rows[0]["eval/episode_reward"]  # it learned
    best = training.load_policy(learned.run_dir / "policy_best")
    best_of_run = dict(best.config["best_of_run"])
    # written after its evaluation, which starts at the row's wall time
    assert best_of_run.pop("written_at_s") >= best_row["wall_time_s"]
    assert best_of_run == {
        "step": best_row["step"],
        "eval/episode_reward": pytest.approx(best_row["eval/episode_reward"]),
        "eval/fall_rate": pytest.approx(best_row.get("eval/fall_rate", 0.0)),
    }
    observations = jnp.array([[0.0, 0.5], [0.9, -0.4]])
    same = np.array_equal(best.act(observations), learned.policy.act(observations))
    assert same == (best_row["step"] == rows[-1]["step"])


_SPEC = policy_lib.PolicySpec(
    observation_size=2, action_size=1, hidden_sizes=(4,), normalize_observations=True
)
_STATE = types.SimpleNamespace(
    normalizer_params=types.SimpleNamespace(mean=np.zeros(2), std=np.ones(2)),
    policy_params={"w": np.ones(3)},
)


def test_best_policy_beats_earlier_rows_only(tmp_path):
    """Resumed: the rows before the resume count; a worse or equal evaluation saves nothing."""
    spec, state = _SPEC, _STATE
    best = best_policy.BestPolicy(
        tmp_path / "policy_best", spec, {"run_info": {}}, [{"step": 0, "eval/episode_reward": 5.0}]
    )
    assert not best.offer(state, {"step": 10, "eval/episode_reward": 5.0})
    assert not best.offer(state, {"step": 10})  # a row without an evaluation
    assert not (tmp_path / "policy_best").exists()
    assert best.offer(state, {"step": 20, "eval/episode_reward": 7.5})
    assert best.describe() == "episode reward 8"  # the progress line's words
    saved = json.loads((tmp_path / "policy_best" / "policy.json").read_text())
    assert saved["config"]["best_of_run"] == {
        "step": 20,
        "eval/episode_reward": 7.5,
        "eval/fall_rate": 0.0,
    }
    assert not best.offer(state, {"step": 30, "eval/episode_reward": 6.0})
    assert not best.offer(state, {"step": 40, "eval/episode_reward": float("nan")})
    assert json.loads((tmp_path / "policy_best" / "policy.json").read_text()) == saved


def test_best_policy_prefers_an_evaluation_that_does_not_fall(tmp_path):
    """With a fall-rate bound, a slower evaluation without falls beats a richer one that falls;
    the reward ranks evaluations on the same side of the bound, resumed rows included."""
    path = tmp_path / "policy_best" / "policy.json"
    history = [{"step": 0, "eval/episode_reward": 9.0, "eval/fall_rate": 0.5}]
    best = best_policy.BestPolicy(path.parent, _SPEC, {}, history, max_fall_rate=0.01)
    assert not best.offer(_STATE, {"step": 10, "eval/episode_reward": 8.0, "eval/fall_rate": 0.3})
    assert best.offer(_STATE, {"step": 20, "eval/episode_reward": 3.0, "eval/fall_rate": 0.01})
    assert not best.offer(_STATE, {"step": 30, "eval/episode_reward": 9.5, "eval/fall_rate": 0.02})
    assert best.offer(_STATE, {"step": 40, "eval/episode_reward": 4.0, "eval/fall_rate": 0.0})
    assert json.loads(path.read_text())["config"]["best_of_run"]["step"] == 40
    # Without the bound (the default), the reward alone ranks them.
    plain = best_policy.BestPolicy(tmp_path / "plain", _SPEC, {}, history)
    assert plain.offer(_STATE, {"step": 30, "eval/episode_reward": 9.5, "eval/fall_rate": 0.02})
    assert not plain.offer(_STATE, {"step": 40, "eval/episode_reward": 4.0, "eval/fall_rate": 0.0})


def test_best_policy_by_tracking_keeps_the_evaluation_nearest_its_targets(tmp_path):
    """`best_policy_by` "tracking": the worse of speed / 0.10 m/s and yaw rate / 0.15 rad/s
    ranks evaluations that fall alike; rows without tracking (step 0 of another run) never win."""
    path = tmp_path / "policy_best" / "policy.json"
    speed, yaw_rate = best_policy.TRACKING
    history = [{"step": 0, "eval/episode_reward": 9.0}]  # no tracking measured
    best = best_policy.BestPolicy(path.parent, _SPEC, {}, history, 0.01, "tracking", (0.1, 0.15))
    assert best.rank is None
    assert best.offer(_STATE, {"step": 10, "eval/episode_reward": 1.0, speed: 0.12, yaw_rate: 0.12})
    # speed 0.9 of its target, the yaw rate 1.07: its worse ratio beats the first row's 1.2
    assert best.offer(_STATE, {"step": 20, "eval/episode_reward": 0.5, speed: 0.09, yaw_rate: 0.16})
    assert not best.offer(
        _STATE, {"step": 30, "eval/episode_reward": 9.0, speed: 0.11, yaw_rate: 0.1}
    )
    assert not best.offer(
        _STATE, {"step": 40, speed: 0.05, yaw_rate: 0.05, "eval/fall_rate": 0.02}
    )  # falls more than the bound
    saved = json.loads(path.read_text())["config"]["best_of_run"]
    assert saved == {
        "step": 20,
        "eval/episode_reward": 0.5,
        speed: 0.09,
        yaw_rate: 0.16,
        "eval/fall_rate": 0.0,
    }
    assert best.score == pytest.approx(-0.16 / 0.15)
    assert best.describe() == "tracking 1.067 of the targets in the worse of speed and yaw rate"


def test_best_policy_by_gait_keeps_the_evaluation_that_improves_most_on_step_0(tmp_path):
    """`best_policy_by` "gait": the tracking rank against the step-0 evaluation's own RMS (the
    gait the run started from), so that a policy better in speed alone does not win."""
    speed, yaw_rate = best_policy.TRACKING
    gait = {"step": 0, speed: 0.10, yaw_rate: 0.08}
    best = best_policy.BestPolicy(tmp_path / "policy_best", _SPEC, {}, [], 0.01, "gait")
    assert best.describe() == "none yet"
    assert best.offer(_STATE, gait) and best.score == pytest.approx(-1.0)
    assert not best.offer(_STATE, {"step": 10, speed: 0.09, yaw_rate: 0.085})  # yaw rate worse
    assert best.offer(_STATE, {"step": 20, speed: 0.095, yaw_rate: 0.078})  # both better
    # Far better in speed, hardly in the yaw rate: the tracking rank's pick, not this one's.
    faster = {"step": 30, speed: 0.05, yaw_rate: 0.079}
    assert not best.offer(_STATE, faster)
    assert best_policy.rank(faster, 0.01, "tracking") > best_policy.rank(
        {"step": 20, speed: 0.095, yaw_rate: 0.078}, 0.01, "tracking"
    )
    saved = json.loads((tmp_path / "policy_best" / "policy.json").read_text())
    assert saved["config"]["best_of_run"]["step"] == 20
    words = "tracking 0.975 of its step-0 gait's in the worse of speed and yaw rate"
    assert best.describe() == words
    # A resumed run ranks its history against its own step 0.
    resumed = best_policy.BestPolicy(tmp_path / "again", _SPEC, {}, [gait, faster], 0.01, "gait")
    assert resumed.score == pytest.approx(-0.079 / 0.08)


def test_best_policy_by_gait_with_conditions_must_beat_the_gait_in_each(tmp_path):
    """With `randomization.eval_conditions` the rows carry each condition's tracking and falls:
    the gait rank takes the worst ratio over every cell, and a row that falls more often than
    step 0 under a condition never beats it."""
    speed, yaw_rate = best_policy.TRACKING
    gait = {"step": 0, speed: 0.10, yaw_rate: 0.08, "eval/fall_rate": 0.0}
    gait |= {"eval/latency_40_ms/speed_tracking_rms": 0.12, "eval/latency_40_ms/fall_rate": 0.0}
    gait |= {"eval/latency_40_ms/yaw_rate_tracking_rms": 0.09}
    best = best_policy.BestPolicy(tmp_path / "b", _SPEC, {}, [gait], 0.01, "gait")
    worse_late = gait | {"step": 10, speed: 0.08, yaw_rate: 0.06}
    worse_late |= {"eval/latency_40_ms/yaw_rate_tracking_rms": 0.091}
    assert not best.offer(_STATE, worse_late)  # better pooled, worse at 40 ms
    falls = worse_late | {"step": 20, "eval/latency_40_ms/yaw_rate_tracking_rms": 0.08}
    falls |= {"eval/latency_40_ms/speed_tracking_rms": 0.11}
    assert not best.offer(_STATE, falls | {"eval/latency_40_ms/fall_rate": 0.004})
    assert best.offer(_STATE, falls)
    assert best.score == pytest.approx(-0.11 / 0.12)  # the worst of the four ratios
    assert best_policy.cells(falls) == {
        key: falls[key]
        for key in (speed, yaw_rate)
        + tuple(
            f"eval/latency_40_ms/{name}" for name in ("speed_tracking_rms", "yaw_rate_tracking_rms")
        )
    }


def test_an_attitude_bound_ranks_a_level_evaluation_above_a_rolling_one(tmp_path):
    """`best_policy_max_attitude`: an evaluation that rolls or pitches beyond the bound (mean of
    the episodes' peaks) ranks below every one within it, however well it tracks; rows that
    measured no attitude (runs before it) count as within; 0 turns it off."""
    speed, yaw_rate = best_policy.TRACKING
    roll, pitch = best_policy.ATTITUDE
    gait = {"step": 0, speed: 0.10, yaw_rate: 0.08, roll: 0.09, pitch: 0.06}
    best = best_policy.BestPolicy(tmp_path / "b", _SPEC, {}, [gait], 0.01, "gait", max_attitude=0.1)
    assert not best.offer(_STATE, {"step": 10, speed: 0.05, yaw_rate: 0.05, roll: 0.11, pitch: 0.0})
    assert not best.offer(_STATE, {"step": 20, speed: 0.05, yaw_rate: 0.05, roll: 0, pitch: 0.12})
    assert best.offer(_STATE, {"step": 30, speed: 0.095, yaw_rate: 0.079, roll: 0.1, pitch: 0.1})
    saved = json.loads((tmp_path / "b" / "policy.json").read_text())["config"]["best_of_run"]
    assert saved[roll] == 0.1 and saved[pitch] == 0.1
    assert best_policy.rank({speed: 0.05, yaw_rate: 0.1}, 0.01, "tracking", max_attitude=0.1)[0]
    rolling = {speed: 0.05, yaw_rate: 0.05, roll: 0.5}
    assert best_policy.rank(rolling, 0.01, "tracking") == (True, pytest.approx(-0.5))
    assert not best_policy.rank(rolling, 0.01, "tracking", max_attitude=0.1)[0]
    from quadcos import train  # the command line's config builder

    with pytest.raises(ValueError, match="best_policy_max_attitude must be a finite angle >= 0"):
        train.build_config(train.PRESETS["smoke"], {"sac.best_policy_max_attitude": -0.1})


def test_a_tracking_rank_needs_robots_that_follow_commands():
    from quadcos import train  # the command line's config builder

    with pytest.raises(ValueError, match="best_policy_by 'tracking' .* needs config.env.commands"):
        tracked = {"sac.keep_best_policy": True, "sac.best_policy_by": "tracking"}
        train.build_config(train.PRESETS["smoke"], tracked)
    with pytest.raises(ValueError, match="best_policy_by 'gait' .* needs config.env.commands"):
        tracked = {"sac.keep_best_policy": True, "sac.best_policy_by": "gait"}
        train.build_config(train.PRESETS["smoke"], tracked)
    with pytest.raises(ValueError, match="best_policy_by must be one of reward, tracking, gait"):
        train.build_config(train.PRESETS["smoke"], {"sac.best_policy_by": "speed"})
    with pytest.raises(ValueError, match="best_policy_tracking_targets must be two"):
        train.build_config(train.PRESETS["smoke"], {"sac.best_policy_tracking_targets": (0.1, 0)})
    config = toy_config(keep_best_policy=True, best_policy_by="tracking")
    with pytest.raises(training.ConfigError, match="must follow velocity commands"):
        training.train(PointEnv(), config, progress=False)


# --- Resume -----------------------------------------------------------------


@pytest.fixture(scope="module")
def resumed_runs(tmp_path_factory):
    """The same 4 chunks run straight through and as 2 + 2 with a resume."""
    straight = tmp_path_factory.mktemp("straight")
    split = tmp_path_factory.mktemp("split")
    config = toy_config(save_replay=True)
    training.train(PointEnv(), config, straight, progress=False)
    first = training.train(
        PointEnv(),
        toy_config(save_replay=True, num_timesteps=3 * CHUNK),
        split,
        progress=False,
    )
    second = training.train(PointEnv(), config, split, resume=True, progress=False)
    return straight, split, first, second


def test_resume_is_exact(resumed_runs):
    straight, split, first, second = resumed_runs
    assert first.env_steps == 3 * CHUNK
    assert second.env_steps == 5 * CHUNK
    assert second.chunk_traces == 1
    straight_rows = metrics_rows(straight)
    assert [row["step"] for row in straight_rows] == [0] + [k * CHUNK for k in range(2, 6)]
    assert without_timing(metrics_rows(split)) == without_timing(straight_rows)


def test_extend_finished_run(resumed_runs, tmp_path):
    straight = copy_run(resumed_runs[0], tmp_path)
    extended = training.train(
        PointEnv(),
        toy_config(num_timesteps=7 * CHUNK),
        straight,
        resume=True,
        progress=False,
    )
    steps = [row["step"] for row in metrics_rows(straight)]
    assert steps == [0] + [k * CHUNK for k in range(2, 8)]
    assert extended.env_steps == 7 * CHUNK
    info = json.loads((straight / "config.json").read_text())
    assert info["config"]["num_timesteps"] == 7 * CHUNK


# Orbax leaves a callback behind after the failed read of the corrupt
# checkpoint; it fires on a closed event loop when garbage collected.
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_corrupt_checkpoint_falls_back(resumed_runs, tmp_path, caplog):
    straight = copy_run(resumed_runs[0], tmp_path)
    latest = straight / "checkpoints" / str(5 * CHUNK)
    for path in (latest / "state").rglob("*"):
        if path.is_file() and path.parent.name == "d":
            path.write_bytes(b"garbage")
    original_rows = metrics_rows(straight)

    with caplog.at_level(logging.WARNING):
        result = training.train(
            PointEnv(),
            toy_config(save_replay=True),
            straight,
            resume=True,
            progress=False,
        )
    assert str(latest) in caplog.text
    assert result.env_steps == 5 * CHUNK
    # Resumed from 4 chunks and redid the last one identically.
    assert without_timing(metrics_rows(straight)) == without_timing(original_rows)
    assert list((straight / "checkpoints_corrupt").iterdir())


def test_resume_without_replay_refills(tmp_path):
    config = toy_config(num_timesteps=3 * CHUNK)
    training.train(PointEnv(), config, tmp_path, progress=False)
    result = training.train(PointEnv(), toy_config(), tmp_path, resume=True, progress=False)
    # Resumed at 3 chunks, refilled (one chunk's worth), then trained one chunk.
    assert result.env_steps == 5 * CHUNK
    assert int(result.state.replay.size) == 2 * CHUNK
    steps = [row["step"] for row in metrics_rows(tmp_path)]
    assert steps == sorted(set(steps))


def test_signal_stops_after_chunk_with_checkpoint(tmp_path, monkeypatch):
    add = host.Window.add
    chunks = []

    def add_then_signal(self, *args):
        add(self, *args)
        chunks.append(None)
        if len(chunks) == 2:
            os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(host.Window, "add", add_then_signal)
    result = training.train(
        PointEnv(),
        toy_config(checkpoint_interval=100 * CHUNK),
        tmp_path,
        progress=False,
    )
    assert result.stopped_by_signal == "SIGTERM"
    assert result.env_steps == 3 * CHUNK
    with checkpoint.CheckpointStore(tmp_path / "checkpoints", 3) as store:
        assert store.steps() == [3 * CHUNK]
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_a_spent_time_budget_ends_the_run_as_its_last_step_would(tmp_path):
    """max_seconds counts from `started_at` (the process's start for quadcos.train): a budget
    already spent ends the run after its first chunk, evaluated, checkpointed, its policy saved."""
    result = training.train(
        PointEnv(),
        toy_config(max_seconds=1.0, checkpoint_interval=100 * CHUNK),
        tmp_path,
        progress=False,
        started_at=time.monotonic() - 10.0,
    )
    assert result.stopped_by_signal is None
    assert result.env_steps < toy_config().num_timesteps
    assert metrics_rows(tmp_path)[-1]["step"] == result.env_steps
    with checkpoint.CheckpointStore(tmp_path / "checkpoints", 3) as store:
        assert store.steps() == [result.env_steps]
    assert (tmp_path / "policy" / "policy.json").is_file()


@pytest.mark.parametrize("warmup, warned", [(10**8, True), (0, False)])
def test_a_warm_up_that_outlasts_the_time_budget_is_warned_as_the_run_goes_on(
    warmup, warned, caplog
):
    """10⁸ critic-only updates cannot end within a minute at the toy's pace: said once, after the
    second chunk, while the run trains on to its end; an actor learning says nothing."""
    with caplog.at_level(logging.WARNING, logger="quadcos"):
        result = training.train(
            PointEnv(),
            toy_config(actor_warmup_steps=warmup, max_seconds=60.0, num_timesteps=4 * CHUNK),
            progress=False,
        )
    late = [r.getMessage() for r in caplog.records if "past the time budget" in r.getMessage()]
    assert len(late) == int(warned), late
    assert result.env_steps >= 4 * CHUNK
    if warned:
        assert "(sac.max_seconds 60) that ends in" in late[0]
        assert "give it more time or fewer warm-up updates (sac.actor_warmup_steps)" in late[0]


def test_a_time_budget_keeps_room_for_what_is_due_another_chunk_and_the_final_evaluation():
    # a budget ending at 100 s; a chunk takes 1 s, an evaluation 2 s, a checkpoint 0.5 s
    def spent(now, evaluating_now=False, saving_now=False, deadline=100.0):
        return host.budget_spent(
            deadline,
            now,
            chunk_s=1.0,
            evaluation_s=2.0,
            save_s=0.5,
            evaluating_now=evaluating_now,
            saving_now=saving_now,
        )

    assert not spent(96.4)  # another chunk, then the final evaluation and checkpoint fit
    assert spent(96.5)  # they would end at 100 s: evaluate now
    # this chunk's own evaluation and checkpoint come first
    assert not spent(93.9, evaluating_now=True, saving_now=True)
    assert spent(94.0, evaluating_now=True, saving_now=True)
    assert not spent(94.4, evaluating_now=True)
    assert spent(94.5, evaluating_now=True)
    assert not spent(1e9, deadline=None)  # no budget


def test_run_hands_a_later_run_of_the_same_programs_the_envs_and_trainer_it_kept(monkeypatch):
    """`training.run` with a `Trainers`: another seed reuses the first run's envs and trainer
    (reseeded), another batch size builds its own."""
    from quadcos.training import presets, sac, session

    built, trained = [], []

    def fake_envs(env_config):
        env = types.SimpleNamespace(impl="jax", robot=types.SimpleNamespace(provenance=dict))
        built.append(env)
        return env, env

    def fake_train(env, config, run_dir, *, trainer, **kwargs):
        if trainer is None:
            trainer = object.__new__(sac.SACTrainer)
            trainer.config = config.copy_and_resolve_references()
        trained.append((env, trainer))
        return types.SimpleNamespace(trainer=trainer)

    monkeypatch.setattr(session, "_envs", fake_envs)
    monkeypatch.setattr(loop, "train", fake_train)
    trainers = training.Trainers()
    for overrides in ({}, {"sac.seed": 4}, {"sac.batch_size": 64}):
        training.run(presets.build_config(presets.PRESETS["smoke"], overrides), trainers=trainers)
    (first_env, first), (second_env, second), (third_env, third) = trained
    assert len(built) == 2 and second_env is first_env and third_env is not first_env
    assert second is not first and second.config.seed == 4 and first.config.seed == 0
    assert second._key_init.tolist() == jax.random.split(jax.random.PRNGKey(4))[0].tolist()
    assert third.config.batch_size == 64


# --- Two phases (sac.at_actor_start) ----------------------------------------

SWITCH = "env.reward.forward=2.0, sac.max_grad_norm=1.0 sac.learning_rate.critic=1e-4"


def test_the_switch_reads_words_apart_by_spaces_or_commas_and_refuses_what_changes_shapes():
    assert phases.parse(SWITCH) == {
        "env.reward.forward": 2.0,
        "sac.max_grad_norm": 1.0,
        "sac.learning_rate.critic": 1e-4,
    }
    assert phases.parse("  ") == {}
    for text, message in [
        ("sac.num_envs=8", "'sac.num_envs' cannot change"),
        ("sac.hidden_sizes.q=(8,8)", "'sac.hidden_sizes.q' cannot change"),
        ("env.reward.forward", "is not KEY=VALUE"),
    ]:
        with pytest.raises(ValueError, match=message):
            phases.parse(text)


def test_the_second_phase_config_applies_the_switch_once_and_the_first_settings_are_kept():
    config = build_config(
        PRESETS["smoke"], {"sac.actor_warmup_steps": 128, "sac.at_actor_start": SWITCH}
    )
    second = phases.second(config)
    assert second.env.reward.forward == 2.0 and second.sac.max_grad_norm == 1.0
    assert second.sac.learning_rate.critic == 1e-4 and second.sac.at_actor_start == ""
    assert config.env.reward.forward != 2.0  # the first phase's config is left as it was
    assert phases.first_settings(config) == {
        "env.reward.forward": config.env.reward.forward,
        "sac.max_grad_norm": None,
        "sac.learning_rate.critic": config.sac.learning_rate.critic,
    }
    # smoke: 4 envs, a prefill of 256 env steps; 128 critic updates, one per step of the 4 envs
    assert phases.switch_step(config.sac) == 256 + 128 * 4
    with pytest.raises(UsageError, match="env.reward.forward"):
        build_config(
            PRESETS["smoke"],
            {"sac.actor_warmup_steps": 128, "sac.at_actor_start": "env.reward.forward=fast"},
        )


def test_a_state_is_carried_into_an_optimiser_that_clips_and_refused_where_shapes_differ():
    params = {"w": jnp.ones((3, 2)), "b": jnp.zeros(2)}
    adam, clipped = optax.adam(1e-3), optax.chain(optax.clip_by_global_norm(1.0), optax.adam(1e-3))
    state = {"params": params, "opt": adam.init(params), "steps": jnp.int32(7)}
    template = jax.eval_shape(lambda: {**state, "opt": clipped.init(params)})
    carried = phases.carried(state, template)
    assert jax.tree.structure(carried) == jax.tree.structure(template)
    assert int(carried["steps"]) == 7 and jnp.array_equal(carried["params"]["w"], params["w"])
    _, updated = clipped.update(params, carried["opt"], params)  # the clipping optimiser takes it
    assert int(updated[1][0].count) == 1
    wider = jax.eval_shape(lambda: {**state, "params": {"w": jnp.ones((3, 3)), "b": jnp.zeros(2)}})
    with pytest.raises(ConfigError, match="changes the training state's arrays"):
        phases.carried(state, wider)


def test_a_two_phase_run_goes_on_from_its_first_phase_under_the_second_settings(tmp_path, caplog):
    config = build_config(
        PRESETS["smoke"],
        {"sac.actor_warmup_steps": 128, "sac.at_actor_start": SWITCH, "sac.seed": 3},
    )
    with caplog.at_level(logging.WARNING, logger="quadcos.training.loop"):
        result = training.run(config, tmp_path / "run", progress=False)
    # the first phase ends where its actor would learn: no warning, the second one follows
    assert "never learned" not in caplog.text
    # smoke's chunks of 128 env steps: the first phase ends at the switch, 768 (a boundary)
    assert [row["step"] for row in result.history] == [0, 512, 768, 1024]
    # one run's updates: (1024 - 256) / 4 steps of the envs, one update each, none taken twice
    assert int(result.state.gradient_steps) == 192 and result.env_steps == 1024
    assert result.trainer.config.max_grad_norm == 1.0 and result.trainer.config.at_actor_start == ""
    saved = json.loads((tmp_path / "run" / "config.json").read_text())
    assert saved["config"]["learning_rate"]["critic"] == 1e-4
    assert saved["config"]["num_timesteps"] == 1024
    assert saved["run_info"]["env"]["reward"]["forward"] == 2.0
    assert saved["run_info"]["first_phase"] == {
        "until_step": 768,
        "env.reward.forward": 150.0,
        "sac.max_grad_norm": None,
        "sac.learning_rate.critic": 3e-4,
    }
    rows = [json.loads(line) for line in (tmp_path / "run" / "metrics.jsonl").open()]
    assert [row["step"] for row in rows] == [0, 512, 768, 1024]
    # the replay holds the first phase's transitions and the second's: every one of the run's
    assert result.trainer.replay_size(result.state) == 1024


def test_a_two_phase_run_ended_before_its_switch_resumes_into_both_phases(tmp_path, caplog):
    overrides = {"sac.actor_warmup_steps": 128, "sac.at_actor_start": SWITCH, "sac.seed": 3}
    early = build_config(PRESETS["smoke"], {**overrides, "sac.num_timesteps": 512})
    with caplog.at_level(logging.WARNING, logger="quadcos.training.loop"):
        first = training.run(early, tmp_path / "run", progress=False)  # before the switch (768)
    assert "the actor never learned" in caplog.text  # no second phase follows: said
    assert first.env_steps == 512 and first.trainer.config.max_grad_norm is None
    saved = json.loads((tmp_path / "run" / "config.json").read_text())
    assert saved["config"]["at_actor_start"] == SWITCH and "first_phase" not in saved["run_info"]
    config = build_config(PRESETS["smoke"], overrides)  # the run's, to 1024 env steps
    result = training.run(config, tmp_path / "run", resume=True, progress=False)
    assert result.env_steps >= 1024 and result.trainer.config.max_grad_norm == 1.0
    saved = json.loads((tmp_path / "run" / "config.json").read_text())
    assert saved["config"]["at_actor_start"] == "" and saved["config"]["max_grad_norm"] == 1.0
    switched = saved["run_info"]["first_phase"]["until_step"]
    assert 768 <= switched < result.env_steps
    # (its replay, not in the checkpoint, refilled past the switch: no chunk before it)
    steps = [row["step"] for row in result.history]
    assert steps[:2] == [0, 512] and steps == sorted(set(steps)) and steps[-1] == result.env_steps


# --- Failures ---------------------------------------------------------------


def test_nan_guard(tmp_path):
    config = toy_config(num_timesteps=3 * CHUNK)
    result = training.train(
        PointEnv(nan_at_step=3),
        config,
        tmp_path,
        eval_env=PointEnv(),
        progress=False,
    )
    state = result.state
    assert result.env_steps >= config.num_timesteps  # training went on to the end
    nan_resets = int(state.nan_resets)
    assert nan_resets > 0
    assert result.metrics["train/nan_resets"] == nan_resets
    # Every transition but the poisoned ones was stored.
    assert int(state.replay.size) == result.env_steps - nan_resets
    assert int(state.normalizer_params.count) == int(state.replay.size)
    # A reset env starts over, so poisoning cannot hit every step after it.
    assert nan_resets < result.env_steps / 4
    for tree in (
        state.replay.data,
        state.policy_params,
        state.q_params,
        state.normalizer_params.mean,
        state.normalizer_params.std,
        state.env_state,
    ):
        leaves = jax.tree.leaves(tree)
        assert all(
            bool(jnp.all(jnp.isfinite(leaf)))
            for leaf in leaves
            if jnp.issubdtype(leaf.dtype, jnp.floating)
        )


def test_a_masked_env_restarts_from_its_first_state_and_the_others_carry_on():
    from brax.envs.base import State

    nan, first_q = jnp.nan, jnp.array([[0.0, 1.0], [2.0, 3.0], [4.0, 5.0]])
    env_state = State(
        pipeline_state={
            "q": jnp.array([[9.0, 9.0], [nan, nan], [7.0, 7.0]]),
            "shared": jnp.ones(5),  # no env axis (MJX-Warp has such leaves)
        },
        obs=jnp.array([[1.0], [nan], [2.0]]),
        reward=jnp.array([0.5, nan, 0.25]),
        done=jnp.zeros(3),
        metrics={"speed": jnp.array([1.0, nan, 2.0])},
        info={
            "first_pipeline_state": {"q": first_q, "shared": jnp.ones(5)},
            "first_obs": jnp.array([[10.0], [11.0], [12.0]]),
            "episode_metrics": {"sum_reward": jnp.array([1.0, nan, nan])},
            "steps": jnp.array([3, 4, 5], jnp.int32),
        },
    )
    assert state_lib.keeps_first_state(env_state)
    restarted = state_lib.restart_where(jnp.array([False, True, False]), env_state)
    np.testing.assert_array_equal(restarted.pipeline_state["q"], [[9, 9], [2, 3], [7, 7]])
    np.testing.assert_array_equal(restarted.obs, [[1.0], [11.0], [2.0]])
    np.testing.assert_array_equal(restarted.reward, [0.5, 0.0, 0.25])
    np.testing.assert_array_equal(restarted.done, [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(restarted.metrics["speed"], [1.0, 0.0, 2.0])
    # Only the restarted env's non-finite values are cleared; another env's NaN is its own.
    sums = restarted.info["episode_metrics"]["sum_reward"]
    assert sums[0] == 1.0 and sums[1] == 0.0 and jnp.isnan(sums[2])
    np.testing.assert_array_equal(restarted.info["steps"], [3, 4, 5])
    assert restarted.pipeline_state["shared"].shape == (5,)  # no env axis: kept


def test_non_finite_loss_raises_and_keeps_checkpoint(tmp_path):
    training.train(PointEnv(), toy_config(num_timesteps=3 * CHUNK), tmp_path, progress=False)
    with checkpoint.CheckpointStore(tmp_path / "checkpoints", 3) as store:
        steps_before = store.steps()
    assert steps_before[-1] == 3 * CHUNK

    # Rewards of 1e30 square to infinity in the critic loss.
    with pytest.raises(training.NonFiniteLossError, match=str(3 * CHUNK)):
        training.train(
            PointEnv(),
            toy_config(reward_scaling=1e30),
            tmp_path,
            resume=True,
            progress=False,
        )
    template = training.SACTrainer(PointEnv(), toy_config()).init()
    with checkpoint.CheckpointStore(tmp_path / "checkpoints", 3) as store:
        assert store.steps() == steps_before
        restored = store.restore_latest(template)
    assert restored.step == 3 * CHUNK
    assert all(
        bool(jnp.all(jnp.isfinite(leaf))) for leaf in jax.tree.leaves(restored.state.q_params)
    )


# --- Helpers ----------------------------------------------------------------


def metrics_rows(run_dir: Path) -> list[dict]:
    return [json.loads(line) for line in (run_dir / "metrics.jsonl").open()]


def copy_run(run_dir: Path, tmp_path: Path) -> Path:
    target = tmp_path / "run"
    shutil.copytree(run_dir, target)
    return target


# --- Starting from the action centre -------------------------------------------


def _trees_equal(a, b) -> bool:
    return all(jax.tree.leaves(jax.tree.map(lambda x, y: bool(jnp.array_equal(x, y)), a, b)))


def test_fresh_policy_explores_around_the_centre_with_init_std():
    """policy_output_scale + init_std: mean ≈ 0 (the env's action centre), std = init_std; the
    "policy" prefill stores that policy's actions, not uniform ones."""
    config = toy_config(policy_output_scale=0.01, init_std=0.05, prefill_actions="policy")
    trainer = training.SACTrainer(PointEnv(), config)
    state = trainer.init()
    params = trainer.networks.policy_network.apply(
        state.normalizer_params, state.policy_params, state.env_state.obs
    )
    dist = trainer.networks.parametric_action_distribution.create_dist(params)
    np.testing.assert_allclose(dist.scale, 0.05, rtol=5e-3)
    assert np.abs(np.asarray(dist.loc)).max() < 0.01

    state = trainer.prefill(state)
    actions = trainer.replay.sample(state.replay, jax.random.PRNGKey(0), 2048).action
    # Uniform actions on [-1, 1] have std 0.58; these are tanh(N(≈0, 0.05)).
    assert 0.03 < float(jnp.std(actions)) < 0.07


@pytest.mark.parametrize("warmup, actor_moves", [(10**6, False), (0, True)])
def test_actor_waits_for_the_critic_warmup(warmup, actor_moves):
    config = toy_config(actor_warmup_steps=warmup)
    trainer = training.SACTrainer(PointEnv(), config)
    start = trainer.prefill(trainer.init())
    policy, log_alpha, q = start.policy_params, start.log_alpha, start.q_params
    policy, q = jax.tree.map(jnp.copy, (policy, q))  # train_chunk donates `start`
    log_alpha = jnp.copy(log_alpha)
    state, _ = trainer.train_chunk(start)
    assert not _trees_equal(q, state.q_params)
    assert _trees_equal(policy, state.policy_params) is not actor_moves
    assert bool(jnp.array_equal(log_alpha, state.log_alpha)) is not actor_moves


def test_the_untrained_policy_is_evaluated_after_the_first_chunk_from_a_copy():
    """`run_chunks` trains first and then finishes `on_start`'s work, whose copy of the untrained
    policy outlives the state the prefill and the chunk were donated; the compiled evaluation
    (`compile_ahead`) gives what the jitted one gives."""
    trainer = training.SACTrainer(PointEnv(), toy_config(actor_warmup_steps=0))
    state = trainer.init()
    initial = jax.device_get(state.policy_params)
    expected = jax.device_get(trainer.evaluate(state.normalizer_params, state.policy_params))
    events = []

    def on_start(state):
        policy = policy_lib.PolicyPart.copy_of(state)

        def finish():
            events.append("finish")
            metrics = trainer.evaluate(policy.normalizer_params, policy.policy_params)
            events.append((jax.device_get(policy.policy_params), jax.device_get(metrics)))

        return finish

    def on_chunk(state, chunk):
        events.append(("chunk", chunk.step))
        return True

    final = loop.run_chunks(
        trainer, state, on_start=on_start, on_chunk=on_chunk, num_timesteps=None
    )
    assert events[0] == "finish" and events[2][0] == "chunk" and len(events) == 3
    params, metrics = events[1]
    assert _trees_equal(params, initial) and not _trees_equal(params, final.policy_params)
    assert metrics.keys() == expected.keys()
    for name, value in expected.items():
        np.testing.assert_allclose(metrics[name], value, rtol=1e-5, atol=1e-6, err_msg=name)
    # The same trainer goes on from there (its programs compiled once, no step-0 evaluation).
    final_steps = int(final.env_steps)  # read now: the next chunk is donated `final`
    later = loop.run_chunks(
        trainer, final, on_start=on_start, on_chunk=on_chunk, num_timesteps=None
    )
    assert events[-1] == ("chunk", int(later.env_steps)) and int(later.env_steps) > final_steps
    assert trainer.chunk_traces == 1


def test_a_delayed_actor_learns_every_second_update_beside_layer_norm_critics():
    config = toy_config(actor_warmup_steps=0, policy_delay=2, critic_layer_norm=True)
    trainer = training.SACTrainer(PointEnv(), config)
    state = trainer.prefill(trainer.init())
    assert all("LayerNorm_0" in critic for critic in state.q_params["params"].values())
    batch = trainer.replay.sample(state.replay, jax.random.PRNGKey(0), config.batch_size)
    moved, update = [], jax.jit(trainer._sgd_step)  # one compiled update, not op by op
    for step in range(3):
        before = jax.tree.map(jnp.copy, (state.policy_params, state.q_params))
        state, _ = update(state, (batch, jax.random.PRNGKey(step)))
        assert not _trees_equal(before[1], state.q_params)  # the critics learn every update
        moved.append(not _trees_equal(before[0], state.policy_params))
    assert moved == [True, False, True]


def test_a_privileged_critic_observes_more_than_the_policy_which_acts_on_its_own_part():
    """With `critic_observation_size` the critics read the whole stored observation and the
    policy its first entries, normalised by their statistics: the policy kept from such a state
    acts on the env's observation as the trainer's did on the stored one."""
    nets = sac.make_networks(3, 2, (8,), (8,), True, critic_observation_size=5)
    key_policy, key_q, key_obs = jax.random.split(jax.random.PRNGKey(0), 3)
    policy_params, q_params = nets.policy_network.init(key_policy), nets.q_network.init(key_q)
    obs = 2.0 + 3.0 * jax.random.normal(key_obs, (6, 5))
    stats = running_statistics.init_state(specs.Array((5,), jnp.dtype("float32")))
    stats = running_statistics.update(stats, obs)
    other_extra = obs.at[:, 3:].add(1.0)
    logits = nets.policy_network.apply(stats, policy_params, obs)
    np.testing.assert_array_equal(
        logits, nets.policy_network.apply(stats, policy_params, other_extra)
    )
    action = jnp.zeros((6, 2))
    q = nets.q_network.apply(stats, q_params, obs, action)
    assert not np.allclose(q, nets.q_network.apply(stats, q_params, other_extra, action))
    spec = policy_lib.PolicySpec(3, 2, (8,), True)
    kept = policy_lib.Policy.from_training_state(policy_lib.PolicyPart(stats, policy_params), spec)
    assert kept.params["normalizer"]["mean"].shape == (3,)
    expected = nets.parametric_action_distribution.mode(logits)
    np.testing.assert_allclose(kept.act(obs[:, :3]), expected, atol=1e-6)
    with pytest.raises(ValueError, match="privileged_critic needs a quadcos env; PointEnv"):
        training.SACTrainer(PointEnv(), toy_config(privileged_critic=True))


def test_the_smoothness_loss_charges_the_policys_change_and_its_update_shrinks_it():
    """CAPS: temporal · mean ‖μ(s) − μ(s')‖² + spatial · the same to noisy s; off (0, 0) the
    actor's loss is Brax's own function; on, a few updates bring μ(s) and μ(s') closer than
    Brax's loss alone does from the same state and batches."""
    from quadcos import train

    with pytest.raises(ValueError, match="smoothness.temporal must be finite and >= 0, got -1"):
        train.build_config(train.PRESETS["smoke"], {"sac.smoothness.temporal": -1.0})
    plain = training.SACTrainer(PointEnv(), toy_config(actor_warmup_steps=0))
    smooth_config = toy_config(actor_warmup_steps=0)
    smooth_config.smoothness.temporal = 30.0
    smooth = training.SACTrainer(PointEnv(), smooth_config)
    assert plain._sgd_step.smoothness is None  # off: Brax's actor loss alone
    state = plain.prefill(plain.init())
    batch = plain.replay.sample(state.replay, jax.random.PRNGKey(0), 128)
    networks, key = plain.networks, jax.random.PRNGKey(1)

    def step_change(policy_params) -> jax.Array:  # mean ‖μ(s) − μ(s')‖² over the batch
        def mean_action(observation):
            normalizer = state.normalizer_params
            logits = networks.policy_network.apply(normalizer, policy_params, observation)
            return networks.parametric_action_distribution.mode(logits)

        change = mean_action(batch.observation) - mean_action(batch.next_observation)
        return jnp.mean(jnp.sum(change**2, axis=-1))

    def loss(**weights) -> float:
        return float(
            updates.smoothness_loss(
                networks, state.policy_params, state.normalizer_params, batch, key, **weights
            )
        )

    start = float(step_change(state.policy_params))
    assert start > 0
    np.testing.assert_allclose(loss(temporal=2.0, spatial=0.0, sigma=0.1), 2 * start, rtol=1e-5)
    assert loss(temporal=0.0, spatial=1.0, sigma=0.0) == 0.0
    assert loss(temporal=0.0, spatial=1.0, sigma=0.5) > 0.0
    after = []
    for trainer in (plain, smooth):
        learned, update = state, jax.jit(trainer._sgd_step)
        for step in range(5):
            learned, metrics = update(learned, (batch, jax.random.PRNGKey(step)))
        after.append(float(step_change(learned.policy_params)))
    assert after[1] < min(after[0], start), (start, after)
    assert float(metrics["smoothness"]) > 0  # the term, beside Brax's actor loss


def test_the_anchor_charges_the_policys_distance_from_the_centre_and_its_update_shrinks_it():
    """anchor · mean ‖μ(s)‖²: 0 is the env's action centre; a few updates with it bring μ nearer
    the centre than Brax's loss alone does from the same state and batches."""
    plain = training.SACTrainer(PointEnv(), toy_config(actor_warmup_steps=0))
    anchored_config = toy_config(actor_warmup_steps=0)
    anchored_config.smoothness.anchor = 30.0
    anchored = training.SACTrainer(PointEnv(), anchored_config)
    state = plain.prefill(plain.init())
    batch = plain.replay.sample(state.replay, jax.random.PRNGKey(0), 128)
    networks = plain.networks

    def distance(policy_params) -> float:  # mean ‖μ(s)‖² over the batch
        logits = networks.policy_network.apply(
            state.normalizer_params, policy_params, batch.observation
        )
        mean = networks.parametric_action_distribution.mode(logits)
        return float(jnp.mean(jnp.sum(mean**2, axis=-1)))

    start = distance(state.policy_params)
    loss = updates.smoothness_loss(
        networks,
        state.policy_params,
        state.normalizer_params,
        batch,
        jax.random.PRNGKey(1),
        temporal=0.0,
        spatial=0.0,
        sigma=0.0,
        anchor=2.0,
    )
    np.testing.assert_allclose(float(loss), 2 * start, rtol=1e-5)
    after = []
    for trainer in (plain, anchored):
        learned, update = state, jax.jit(trainer._sgd_step)
        for step in range(5):
            learned, metrics = update(learned, (batch, jax.random.PRNGKey(step)))
        after.append(distance(learned.policy_params))
    assert after[1] < after[0], (start, after)
    assert float(metrics["smoothness"]) > 0


# --- traced programs kept on disk ----------------------------------------------------------------


def _affine(params: dict, x: jax.Array) -> dict:
    return {"y": params["w"] * x + params["b"], "n": jnp.sum(x)}


def test_a_traced_program_is_loaded_from_disk_by_the_next_trainer(tmp_path, monkeypatch):
    monkeypatch.setattr(caches, "traced_directory", lambda: tmp_path / caches.TRACED)
    args = ({"w": jnp.float32(2.0), "b": jnp.float32(1.0)}, jnp.arange(3.0))
    first = caches.Program(_affine, "affine", "fingerprint")(*args)
    assert [path.name[:7] for path in (tmp_path / caches.TRACED).iterdir()] == ["affine-"]

    def no_trace(*_):
        raise AssertionError("traced again")

    monkeypatch.setattr(caches.Program, "_trace", no_trace)
    again = caches.Program(_affine, "affine", "fingerprint")
    np.testing.assert_array_equal(again(*args)["y"], first["y"])
    assert float(again(*args)["n"]) == 3.0
    with pytest.raises(AssertionError, match="traced again"):  # another fingerprint or shape
        caches.Program(_affine, "affine", "other")(*args)
    with pytest.raises(AssertionError, match="traced again"):
        caches.Program(_affine, "affine", "fingerprint")(args[0], jnp.arange(4.0))
    # Inside another trace (the memory check's jax.eval_shape of init) the kept trace stands in
    # for the function, which is not traced again; a program not kept is staged there.
    shapes = jax.eval_shape(caches.Program(no_trace, "affine", "fingerprint"), *args)
    assert shapes["y"].shape == (3,) and shapes["n"].shape == ()
    with pytest.raises(AssertionError, match="traced again"):
        jax.eval_shape(caches.Program(no_trace, "affine", "other"), *args)


def test_a_damaged_traced_program_is_traced_again_and_rewritten(tmp_path, monkeypatch):
    monkeypatch.setattr(caches, "traced_directory", lambda: tmp_path / caches.TRACED)
    args = ({"w": jnp.float32(3.0), "b": jnp.float32(0.0)}, jnp.ones(2))
    caches.Program(_affine, "affine", "fingerprint")(*args)
    (saved,) = (tmp_path / caches.TRACED).iterdir()
    saved.write_bytes(saved.read_bytes()[:100])
    result = caches.Program(_affine, "affine", "fingerprint")(*args)
    np.testing.assert_array_equal(result["y"], [3.0, 3.0])
    assert saved.stat().st_size > 100


def test_a_program_export_refuses_runs_traced_as_usual(tmp_path, monkeypatch):
    monkeypatch.setattr(caches, "traced_directory", lambda: tmp_path / caches.TRACED)

    def with_host_callback(x: jax.Array) -> jax.Array:
        return jax.pure_callback(np.negative, jax.ShapeDtypeStruct(x.shape, x.dtype), x) + 1

    result = caches.Program(with_host_callback, "callback", "fingerprint")(jnp.arange(3.0))
    np.testing.assert_array_equal(result, [1.0, 0.0, -1.0])
    assert not (tmp_path / caches.TRACED).exists() or not any((tmp_path / caches.TRACED).iterdir())


def test_only_quadcos_envs_on_one_device_with_mjx_jax_keep_their_programs(tmp_path, monkeypatch):
    monkeypatch.setattr(caches, "traced_directory", lambda: tmp_path / caches.TRACED)
    trainer = training.SACTrainer(PointEnv(), toy_config())  # the toy env: traced as usual
    assert not isinstance(trainer.train_chunk, caches.Program)
    assert caches.trainer_fingerprint(PointEnv(), None, {}, one_device=True) is None
    monkeypatch.setattr(caches, "traced_directory", lambda: None)  # the compilation cache off
    assert caches.trainer_fingerprint(PointEnv(), None, {}, one_device=True) is None


def test_an_env_that_counts_its_observation_is_not_traced_for_it(monkeypatch):
    import quadcos  # noqa: PLC0415 (the rest of this module needs no MJX)
    from quadcos.training import batched_envs  # noqa: PLC0415

    traced = []
    monkeypatch.setattr(jax, "eval_shape", lambda *args: traced.append(args))
    env = quadcos.make_env("flat", observe_slope=True)
    assert batched_envs.observation_size(env, None, 4) == env.observation_size == 20
    assert batched_envs.observation_size(PointEnv(), None, 4) == PointEnv().observation_size
    assert traced == []

    class Uncounted(PointEnv):  # Brax's `observation_size`, a reset run: read off its trace
        observation_size = envs.PipelineEnv.observation_size

    with pytest.raises(AttributeError):  # the stand-in eval_shape returned None
        batched_envs.observation_size(Uncounted(), "reset", 4)
    assert traced and traced[0][0] == "reset"
