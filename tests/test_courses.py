"""Lane terrains (courses side by side), the random course family, the held-out test set, the
course curriculum and per-course evaluation."""

import re

import flax.struct
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from brax.envs import base
from brax.envs.wrappers import training as training_wrappers

from quadcos import evaluation, terrain
from quadcos.evaluation import fixed_search
from quadcos.terrain import courses
from quadcos.training import config as training_config
from quadcos.training import curriculum
from tests.test_terrain import _compile, _ray_heights

FAMILY = "random:max_deg=12,sections=3-5,len=1-3,seed=5,lanes=6"


def _band_points(ground, lane, count, rng):
    """Random (x, y) inside `lane`'s band (0.7 m either side of its centre line)."""
    x = rng.uniform(-1.9, ground.extent[1] - 0.1, count)
    y = ground.lanes[lane].y + rng.uniform(-0.7, 0.7, count)
    return x, y


def test_testset_lanes_are_the_named_courses_exactly():
    ground = terrain.parse("testset:3")
    names = [lane.name for lane in ground.lanes]
    assert names == [f"test{i}" for i in range(64)] + ["flat", "slope5", "s4"]
    np.testing.assert_allclose(np.diff(ground.lane_y), 2.0)
    rng = np.random.default_rng(0)
    for lane, name in ((64, "flat"), (65, "slope5"), (66, "s4")):
        single = terrain.parse(name)
        x, y = _band_points(ground, lane, 500, rng)
        x = np.minimum(x, single.extent[1] - 0.05) if single.extent else x
        np.testing.assert_allclose(ground.height_at(x, y), single.height_at(x, 0 * y), atol=1e-6)
        np.testing.assert_allclose(ground.slope_at(x, y), single.slope_at(x, 0 * y), atol=1e-5)
        end = 12.0 if single.course_end_x is None else single.course_end_x  # flat: 10 m course
        assert ground.lane_end_x[lane] == end


def test_testset_courses_go_up_and_down_within_the_stated_ranges():
    ground = terrain.parse("testset:11")
    for lane in ground.lanes[:64]:
        sections = courses.course_sections(_single_lane(ground, lane))
        angles = np.array([s.angle_deg for s in sections])
        lengths = np.array([s.length_m for s in sections])
        assert 3 <= len(sections) <= 6
        assert (angles > 0).any() and (angles < 0).any()
        slopes = np.abs(angles[angles != 0])
        assert slopes.min() >= 2.0 - 1e-6 and slopes.max() <= 11.0 + 1e-6
        assert lengths.min() >= 1.0 - 1e-9 and lengths.max() <= 3.0 + 1e-9
        np.testing.assert_allclose(lengths / 0.05, np.round(lengths / 0.05), atol=1e-6)


def _single_lane(ground, lane):
    """The lane's profile as a one-course terrain (rows of its band)."""
    row = int(np.argmin(np.abs(ground.y_knots - (lane.y - 0.75))))
    return terrain.Terrain(
        name=lane.name,
        spec=lane.name,
        x_knots=ground.x_knots,
        y_knots=np.zeros(1),
        heights=ground.heights[row : row + 1],
        course_end_x=lane.course_end_x,
    )


def test_random_family_is_seeded_graded_and_apart_from_the_test_stream():
    first, again = terrain.parse(FAMILY), terrain.parse(FAMILY)
    np.testing.assert_array_equal(first.heights, again.heights)
    assert first.spec == FAMILY and terrain.parse(first.spec).spec == FAMILY
    other = terrain.parse(FAMILY.replace("seed=5", "seed=6"))
    assert not np.array_equal(first.heights, other.heights)
    for i, lane in enumerate(first.lanes):  # lane i's slopes are at most 12° (i + 1) / 6
        angles = [s.angle_deg for s in courses.course_sections(_single_lane(first, lane))]
        assert max(map(abs, angles)) <= 12.0 * (i + 1) / 6 + 1e-6
    # The same seed draws other courses for the test set (a separate random stream).
    test = [courses.course_sections(_single_lane(t, t.lanes[0])) for t in [terrain.parse("testset:5")]]
    train = courses.course_sections(_single_lane(first, first.lanes[0]))
    assert test[0] != train


def test_mujoco_heightfield_is_each_lane_exactly():
    ground = terrain.parse(FAMILY)
    model = _compile(ground)
    rng = np.random.default_rng(1)
    for lane in range(ground.num_lanes):
        x, y = _band_points(ground, lane, 40, rng)
        np.testing.assert_allclose(_ray_heights(model, x, y), ground.height_at(x, y), atol=2e-4)


@pytest.mark.parametrize(
    "spec, message",
    [
        ("random:max_deg=0", r"max_deg must be in \(0, 45\]"),
        ("random:sections=5-3", "sections must be MIN-MAX"),
        ("random:len=abc", "expected random:max_deg=DEG"),
        ("random:lanes=0", r"lanes must be in 1..256"),
        ("random:seed=1,seed=2", "bad option 'seed=2'"),
        ("random:colour=red", "bad option 'colour=red'"),
        ("testset:-1", "expected testset:SEED"),
        ("testset:x", "expected testset:SEED"),
    ],
)
def test_bad_course_specs_name_the_problem(spec, message):
    with pytest.raises(ValueError, match=message):
        terrain.parse(spec)


def test_lanes_refuse_a_width_that_is_not_whole_cells():
    with pytest.raises(ValueError, match="whole number"):
        courses.lanes([("a", [])], lane_width=1.1)
    with pytest.raises(ValueError, match="courses is empty"):
        courses.lanes([])


def test_next_level_moves_up_on_success_and_down_on_failure():
    level = jnp.array([0, 2, 2, 2, 2, 3, 3], jnp.int32)
    fell = jnp.array([True, True, False, False, False, False, False])
    crossed = jnp.array([False, True, True, False, False, False, True])
    walked = jnp.array([9.0, 9.0, 0.5, 4.0, 3.0, 1.0, 1.0])
    new = curriculum.next_level(level, fell, crossed, walked, jax.random.PRNGKey(0), 4, 4.0)
    # fell at 0 stays 0; fell -> down; crossed -> up; walked 4 m -> up; 3 m -> same; 1 m -> down;
    # past the top lane -> a lane drawn uniformly
    np.testing.assert_array_equal(new[:6], [0, 1, 3, 3, 2, 2])
    assert 0 <= int(new[6]) < 4
    tops = curriculum.next_level(
        jnp.full(4000, 3, jnp.int32), jnp.zeros(4000, bool), jnp.ones(4000, bool),
        jnp.zeros(4000), jax.random.PRNGKey(1), 4, 4.0,
    )
    assert set(np.unique(tops)) == {0, 1, 2, 3}
    upper = curriculum.next_level(
        jnp.full(4000, 3, jnp.int32), jnp.zeros(4000, bool), jnp.ones(4000, bool),
        jnp.zeros(4000), jax.random.PRNGKey(1), 4, 4.0, restart_from=2,
    )
    assert set(np.unique(upper)) == {2, 3}  # restart_from: only the upper lanes
    # promote_lanes: a success climbs that many lanes, a failure still goes down one
    faster = curriculum.next_level(level, fell, crossed, walked, jax.random.PRNGKey(0), 8, 4.0, 3)
    np.testing.assert_array_equal(faster, [0, 1, 5, 5, 2, 2, 6])


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("promote_lanes", 0, "promote_lanes must be a whole number >= 1, got 0"),
        ("start_fraction", 0.0, "start_fraction must be in (0, 1]"),
        ("promote_m", -1.0, "promote_m finite and > 0"),
        ("restart_fraction", 0.0, "restart_fraction must be in (0, 1], got 0.0"),
    ],
)
def test_a_bad_curriculum_value_is_named(key, value, message):
    from quadcos.training import checks

    config = training_config.default_config()
    config.curriculum[key] = value
    with pytest.raises(checks.ConfigError, match=re.escape(message)):
        checks.check_config(config)


@flax.struct.dataclass
class _Body:
    qpos: jax.Array  # (x, y)


class _LaneWalker(base.Env):
    """A point walking along x at 1 m per step on the lanes of `ground` (a test double of
    QuadrupedEnv's lane interface); done (a fall) when it steps on a lane ≥ `fall_lane`."""

    def __init__(self, ground, fall_lane):
        self.terrain, self.fall_lane = ground, fall_lane

    def reset(self, rng):
        return self.reset_on_lane(rng, jnp.zeros((), jnp.int32))

    def reset_on_lane(self, rng, lane):
        qpos = jnp.stack([jnp.zeros(()), jnp.asarray(self.terrain.lane_y, jnp.float32)[lane]])
        zero = jnp.zeros(())
        return base.State(_Body(qpos), qpos, zero, zero, {}, {})

    def step(self, state, action):
        qpos = state.pipeline_state.qpos.at[0].add(1.0)
        lane = jnp.argmin(jnp.abs(jnp.asarray(self.terrain.lane_y) - qpos[1]))
        done = (lane >= self.fall_lane).astype(jnp.float32)
        return state.replace(pipeline_state=_Body(qpos), obs=qpos, done=done)

    observation_size, action_size, backend = 2, 1, "none"


def test_curriculum_climbs_lanes_until_robots_fall():
    ground = courses.lanes([(f"c{i}", [terrain.Section(0.0, 1.0)]) for i in range(4)])
    config = training_config.default_config().curriculum
    env = curriculum.wrap(_LaneWalker(ground, fall_lane=3), episode_length=5, config=config)
    assert isinstance(env, curriculum.CourseCurriculum)
    state = env.reset(jax.random.split(jax.random.PRNGKey(0), 8))
    np.testing.assert_array_equal(state.info["course_level"], 0)  # the lowest quarter: lane 0
    levels = []
    step = jax.jit(env.step)
    for _ in range(40):
        state = step(state, jnp.zeros((8, 1)))
        levels.append(np.asarray(state.info["course_level"]))
        on_lane = np.asarray(ground.lane_y)[levels[-1]]
        done = np.asarray(state.done) > 0
        np.testing.assert_allclose(np.asarray(state.pipeline_state.qpos[:, 1])[done], on_lane[done])
    # 5 m walked in every episode: up a lane each time, down again from lane 3 (a fall there)
    assert [int(levels[i][0]) for i in (4, 9, 14, 15, 19, 20)] == [1, 2, 3, 2, 2, 3]
    # an env not done keeps walking from its spawn
    assert np.asarray(state.info["course_start_x"]).max() == 0.0


def test_search_candidates_share_lanes_from_the_gentlest_to_the_steepest():
    assert fixed_search.candidate_lanes(64, 4).tolist() == [0, 21, 42, 63]
    assert fixed_search.candidate_lanes(64, 2).tolist() == [0, 63]
    assert fixed_search.candidate_lanes(1, 3).tolist() == [0, 0, 0]  # no lanes: lane 0


def test_one_lane_keeps_brax_auto_reset():
    config = training_config.default_config().curriculum
    env = curriculum.wrap(_LaneWalker(terrain.parse("slope5"), 9), 5, config)
    assert isinstance(env, training_wrappers.AutoResetWrapper)


@pytest.mark.slow
def test_evaluation_runs_each_lane_and_reports_per_course():
    ground = courses.lanes(
        [("up", [terrain.Section(2.0, 1.0)]), ("level", []), ("short", [terrain.Section(0.0, 0.1)])],
        lead_in=0.2,
        run_out=2.0,
    )
    result = evaluation.evaluate("fixed:trot", ground, num_envs=6, seconds=1.5)
    assert [e["lane"] for e in result.episodes] == [0, 1, 2, 0, 1, 2]
    for episode in result.episodes:  # started on their lane's centre line; fallen ones slide
        assert abs(episode["final_y"] - 2.0 * (episode["lane"] - 1)) < (1.5 if episode["fell"] else 0.3)
    short = [e for e in result.episodes if e["lane"] == 2]
    level = [e for e in result.episodes if e["lane"] == 1]
    assert all(e["finished_course"] and e["success"] for e in short)  # crossed x = 0.3 m
    assert all(not e["finished_course"] and e["success"] for e in level)  # no end: survived
    summary = result.summary
    assert list(summary["courses"]) == ["up", "level", "short"]
    assert summary["courses"]["short"]["success_rate"] == 1.0
    rates = [course["success_rate"] for course in summary["courses"].values()]
    assert summary["mean_course_success_rate"] == pytest.approx(np.mean(rates))
    assert summary["worst_course_success_rate"] == min(rates)
    table = evaluation.course_table(summary)
    assert table.splitlines()[2].startswith("| up | 2 |") and "worst" in table.splitlines()[-1]


def test_the_course_table_says_when_episodes_missed_lanes():
    course = {key: 0.5 for key in ("success_rate", "fall_rate", "mean_forward_speed",
                                   "mean_max_abs_pitch_error", "mean_max_abs_yaw",
                                   "mean_max_abs_roll", "slope_error_rms")}
    summary = {"courses": {"a": {**course, "num_episodes": 1}, "b": {**course, "num_episodes": 1}},
               "mean_course_success_rate": 0.5, "worst_course": "a",
               "worst_course_success_rate": 0.5}
    assert evaluation.course_table({**summary, "lanes": 2}).splitlines()[-1].startswith(
        "courses: 2, mean success 0.500")
    partial = evaluation.course_table({**summary, "lanes": 67}).splitlines()[-1]
    assert partial.startswith("courses: 2 of 67 (--num_envs=67 or more walks each)")
