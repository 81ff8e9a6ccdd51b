"""Terrain: exact heights/slopes of the paper's courses, spec parsing, registry, and the MuJoCo
(and MJX) ground agreeing with `height_at`."""

import dataclasses
import functools
import math

import hypothesis
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from hypothesis import strategies as st

from quadcos import terrain
from quadcos.terrain import Section

TAN5 = math.tan(math.radians(5.0))
TAN9 = math.tan(math.radians(9.0))
DEG5 = math.radians(5.0)
DEG9 = math.radians(9.0)
ATOL_HEIGHT = 1e-6  # m, float32 evaluation
ATOL_ANGLE = 1e-6  # rad


def _bumps(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A smooth 2-D test terrain, m, asymmetric in y so a row/column mix-up shows."""
    return 0.15 * np.sin(1.3 * x) * np.cos(0.7 * y) + 0.03 * x + 0.02 * y


def _bilinear(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear in x and y, so bilinear interpolation reproduces it exactly."""
    return 0.1 + 0.05 * x - 0.02 * y + 0.01 * x * y


# --- the paper's courses -------------------------------------------------------------------------

# (x, expected height, expected slope) at points inside each section; y is irrelevant.
SLOPE5_POINTS = [
    (-1.5, 0.0, 0.0),  # behind the spawn point
    (1.0, 0.0, 0.0),  # lead-in
    (3.5, 1.5 * TAN5, DEG5),  # 5° up, x in [2, 5)
    (6.5, 3 * TAN5, 0.0),  # top plateau, [5, 8)
    (9.5, 1.5 * TAN5, -DEG5),  # 5° down, [8, 11)
    (12.0, 0.0, 0.0),  # run-out
    (30.0, 0.0, 0.0),  # beyond the heightfield: held level
]
S4_POINTS = [
    (-1.0, 0.0, 0.0),
    (1.0, 0.0, 0.0),
    (2.7, 0.7 * TAN5, DEG5),  # 5°, [2, 3.4)
    (4.1, 1.4 * TAN5, 0.0),  # 0°, [3.4, 4.8)
    (5.4, 1.4 * TAN5 + 0.6 * TAN9, DEG9),  # 9°, [4.8, 6.0)
    (6.7, 1.4 * TAN5 + 1.2 * TAN9, 0.0),  # 0°, [6.0, 7.4)
    (9.0, 1.4 * TAN5 + 1.2 * TAN9, 0.0),  # run-out
]


@pytest.mark.parametrize("name, points", [("slope5", SLOPE5_POINTS), ("s4", S4_POINTS)])
def test_course_heights_and_slopes_inside_each_section(name, points):
    ground = terrain.get(name)
    x, height, slope = (np.array(column) for column in zip(*points))
    for y in (-1.7, 0.0, 2.4):
        np.testing.assert_allclose(ground.height_at(x, y), height, atol=ATOL_HEIGHT)
        np.testing.assert_allclose(ground.slope_at(x, y), slope, atol=ATOL_ANGLE)


def test_course_ends_and_plateau_heights():
    slope5, s4 = terrain.get("slope5"), terrain.get("s4")
    assert slope5.course_end_x == 11.0
    assert s4.course_end_x == 7.4
    assert terrain.get("flat").course_end_x is None
    assert float(slope5.height_at(6.5, 0.0)) == pytest.approx(3 * TAN5, abs=ATOL_HEIGHT)
    assert float(s4.height_at(7.4, 0.0)) == pytest.approx(1.4 * TAN5 + 1.2 * TAN9, abs=ATOL_HEIGHT)
    assert float(slope5.height_at(0.0, 0.0)) == 0.0 == float(s4.height_at(0.0, 0.0))
    assert slope5.spawn_x == 0.0


def test_slope_is_right_continuous_at_kinks():
    s4 = terrain.get("s4")
    kinks = np.array([2.0, 3.4, 4.8, 6.0, 7.4], dtype=np.float32)
    entered = np.array([DEG5, 0.0, DEG9, 0.0, 0.0])
    left = np.array([0.0, DEG5, 0.0, DEG9, 0.0])
    np.testing.assert_allclose(s4.slope_at(kinks, 0.0), entered, atol=ATOL_ANGLE)
    np.testing.assert_allclose(s4.slope_at(kinks - 1e-3, 0.0), left, atol=ATOL_ANGLE)
    # Heights are continuous across the kinks.
    np.testing.assert_allclose(s4.height_at(kinks - 1e-4, 0.0), s4.height_at(kinks, 0.0), atol=2e-5)


def test_flat_is_zero_everywhere():
    ground = terrain.get("flat")
    x, y = np.random.default_rng(0).uniform(-500, 500, (2, 1000))
    assert ground.is_flat and ground.extent is None and ground.hfield_shape is None
    np.testing.assert_array_equal(ground.height_at(x, y), 0.0)
    np.testing.assert_array_equal(ground.slope_at(x, y), 0.0)


def test_sections_courses_sum_lengths_as_written():
    ground = terrain.sections([Section(5, 1.4), Section(9, 1.2)], lead_in=1.0)
    assert ground.course_end_x == 3.6
    np.testing.assert_array_equal(ground.x_knots, [-2.0, 1.0, 2.4, 3.6, 6.6])


# --- jit / vmap, and the 2-D heightfield ---------------------------------------------------------


@pytest.mark.parametrize(
    "ground",
    [terrain.get("slope5"), terrain.get("s4"), terrain.heightfield(_bumps, x_range=(-2, 6))],
    ids=["slope5", "s4", "bumps"],
)
def test_height_and_slope_jit_and_vmap(ground):
    x, y = np.random.default_rng(1).uniform([-3, -2.5], [14, 2.5], (64, 2)).T
    for method in (ground.height_at, ground.slope_at):
        eager = method(x, y)
        np.testing.assert_allclose(jax.jit(method)(x, y), eager, atol=1e-6)
        np.testing.assert_allclose(jax.jit(jax.vmap(method))(x, y), eager, atol=1e-6)
        np.testing.assert_allclose(jax.vmap(method, in_axes=(0, None))(x, 0.5), method(x, 0.5))
    assert ground.height_at(x.reshape(8, 8), 0.25).shape == (8, 8)
    assert ground.slope_at(jnp.float32(1.0), 0.0).shape == ()


def test_heightfield_interpolates_bilinearly():
    ground = terrain.heightfield(_bilinear, x_range=(-2, 6), y_range=(-1.5, 1.5), resolution=0.1)
    assert ground.hfield_shape == (31, 81)
    grid = np.meshgrid(ground.x_knots, ground.y_knots)
    np.testing.assert_allclose(ground.heights, _bilinear(*grid))
    x, y = np.random.default_rng(2).uniform([-2, -1.5], [6, 1.5], (200, 2)).T
    np.testing.assert_allclose(ground.height_at(x, y), _bilinear(x, y), atol=ATOL_HEIGHT)
    np.testing.assert_allclose(ground.slope_at(x, y), np.arctan(0.05 + 0.01 * y), atol=ATOL_ANGLE)
    # Outside the grid: edge heights held, ground level.
    assert float(ground.height_at(10.0, 0.0)) == pytest.approx(_bilinear(6.0, 0.0), abs=ATOL_HEIGHT)
    assert float(ground.height_at(0.0, -9)) == pytest.approx(_bilinear(0.0, -1.5), abs=ATOL_HEIGHT)
    assert float(ground.slope_at(10.0, 0.0)) == 0.0


def test_terrain_is_immutable():
    ground = terrain.get("s4")
    with pytest.raises(dataclasses.FrozenInstanceError):
        ground.name = "other"  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        ground.heights[0, 0] = 1.0


def test_default_heightfields_are_modest():
    for ground in (terrain.get("slope5"), terrain.get("s4"), terrain.heightfield(_bumps)):
        nrow, ncol = ground.hfield_shape
        assert nrow * ncol < 50_000, (ground.name, nrow, ncol)
        x_min, x_max, y_min, y_max = ground.extent
        assert x_min <= -2.0 and y_min <= -2.0 and y_max >= 2.0
        assert ground.course_end_x is None or x_max >= ground.course_end_x + 2.0


# --- specs and the registry -----------------------------------------------------------------------


@pytest.mark.parametrize("name", ["flat", "slope5", "s4"])
def test_builtins_round_trip(name):
    ground = terrain.get(name)
    assert ground.name == ground.spec == name
    again = terrain.parse(ground.spec)
    np.testing.assert_array_equal(again.heights, ground.heights)
    assert name in terrain.names()


def test_sections_spec_round_trips_and_matches_builtin():
    s4 = terrain.get("s4")
    spelled = terrain.parse(" sections:5@1.4,0@1.4,9@1.2,0@1.4 ")
    assert spelled.spec == spelled.name == "sections:5@1.4,0@1.4,9@1.2,0@1.4"
    np.testing.assert_array_equal(spelled.x_knots, s4.x_knots)
    np.testing.assert_array_equal(spelled.heights, s4.heights)
    assert spelled.course_end_x == s4.course_end_x
    custom = terrain.sections(
        [Section(-3.25, 2.5), Section(45, 1)], lead_in=0, run_out=1.5, resolution=0.1
    )
    assert custom.spec == "sections:-3.25@2.5,45@1;lead_in=0;run_out=1.5;resolution=0.1"
    again = terrain.parse(custom.spec)
    assert again.spec == custom.spec and again.resolution == 0.1 and again.course_end_x == 3.5
    np.testing.assert_array_equal(again.heights, custom.heights)


@hypothesis.settings(max_examples=50, deadline=None)
@hypothesis.given(
    st.lists(
        st.builds(Section, st.floats(-45.0, 45.0), st.floats(0.001, 20.0)), min_size=1, max_size=10
    ).filter(lambda segments: sum(segment.length_m for segment in segments) <= 200.0)
)
def test_any_sections_course_round_trips(segments):
    ground = terrain.sections(segments)
    again = terrain.parse(ground.spec)
    assert again.spec == ground.spec
    np.testing.assert_array_equal(again.x_knots, ground.x_knots)
    np.testing.assert_array_equal(again.heights, ground.heights)


BAD_SPECS = [
    ("s5", "unknown terrain 's5'; known: flat, s4, slope5"),
    ("", "unknown terrain ''"),
    ("sections", "unknown terrain 'sections'"),
    ("sections:", "no sections in 'sections:'"),
    ("sections:5", "bad section '5' in 'sections:5'"),
    ("sections:5@1.4,9@", "bad section '9@' in 'sections:5@1.4,9@': expected ANGLE_DEG@LENGTH_M"),
    ("sections:5@1.4,,0@1", "bad section '' in"),
    ("sections:5@1@2", "bad section '5@1@2'"),
    ("sections:a@b", "bad section 'a@b'"),
    ("sections:5@-1", "segment 0 length_m must be >= 0.001, got -1.0"),
    ("sections:5@1,0@0", "segment 1 length_m must be >= 0.001, got 0.0"),
    ("sections:5@1,0@1e-300", "segment 1 length_m must be >= 0.001, got 1e-300"),
    ("sections:50@1", "segment 0 angle_deg must be within ±45, got 50.0"),
    ("sections:nan@1", "segment 0 angle_deg must be finite, got nan"),
    ("sections:5@inf", "segment 0 length_m must be finite, got inf"),
    ("sections:5@150,5@60", "total section length 210 m exceeds 200 m"),
    ("sections:5@1;lead_in", "bad option 'lead_in'"),
    ("sections:5@1;speed=2", "bad option 'speed=2'"),
    ("sections:5@1;lead_in=1;lead_in=2", "bad option 'lead_in=2'"),
    ("sections:5@1;run_out=x", "'x' is not a number"),
    ("sections:5@1;lead_in=-1", "lead_in must be in [0, 200] m, got -1.0"),
    ("sections:5@1;run_out=0", "run_out must be in (0, 200] m"),
    ("sections:5@1;resolution=1e-9", "use a coarser resolution"),
    ("sections:5@1;lead_in=1e308", "lead_in must be in [0, 200] m, got 1e+308"),
    ("sections:5@1;run_out=250", "run_out must be in (0, 200] m, got 250.0"),
]


@pytest.mark.parametrize("spec, message", BAD_SPECS)
def test_bad_specs_raise_naming_the_problem(spec, message):
    with pytest.raises(ValueError) as error:
        terrain.get(spec)
    assert message in str(error.value)


SPEC_PIECES = [
    "5",
    "-5",
    "0",
    "1.4",
    "45",
    "46",
    "1e9",
    "1e-300",
    "1e308",
    "nan",
    "inf",
    "-1",
    "x",
    " ",
    "@",
    "@",
    ",",
    ",",
    ";",
    "=",
    "lead_in",
    "run_out",
    "resolution",
    ":",
]


@hypothesis.settings(max_examples=300, deadline=None)
@hypothesis.given(
    st.one_of(
        st.text(max_size=30),
        st.text(max_size=30).map(lambda text: "sections:" + text),
        st.lists(st.sampled_from(SPEC_PIECES), max_size=12).map(lambda p: "sections:" + "".join(p)),
    )
)
def test_fuzzed_specs_give_a_terrain_or_value_error(spec):
    try:
        ground = terrain.parse(spec)
    except ValueError:
        return
    assert isinstance(ground, terrain.Terrain)
    assert terrain.parse(ground.spec).spec == ground.spec


@pytest.mark.parametrize(
    "segments, message",
    [
        ([], "segments is empty"),
        ([Section(5.0, 1.0), (2.0,)], "segment 1: expected a terrain.Section(angle_deg, length_m)"),
        ([(1.0, 5.0)], "plain tuples are refused: sections took (length_m, angle_deg) before"),
        ([Section(5.0, 1.0), Section(0.0, "a")], "segment 1 length_m must be a number, got 'a'"),
        ([Section(5.0, 1.0), Section(float("nan"), 1.0)], "segment 1 angle_deg must be finite"),
        ([Section(5.0, 1.0), Section(0.0, -2.0)], "segment 1 length_m must be >= 0.001, got -2.0"),
        ([Section(-45.5, 1.0)], "segment 0 angle_deg must be within ±45, got -45.5"),
        ([Section(0.0, 100.0), Section(0.0, 100.5)], "total section length 200.5 m exceeds 200 m"),
    ],
)
def test_bad_sections_raise_naming_the_segment(segments, message):
    with pytest.raises(ValueError) as error:
        terrain.sections(segments)
    assert message in str(error.value)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(fn=lambda x, y: 0.0), "fn returned shape ()"),
        (dict(fn=lambda x, y: np.log(x)), "non-finite heights"),
        (dict(fn=_bumps, x_range=(1, 5)), "must contain the spawn x = 0"),
        (dict(fn=_bumps, y_range=(0, 2)), "must contain y = 0"),
        (dict(fn=_bumps, x_range=(-2,)), "x_range must be a (min, max) pair"),
        (dict(fn=_bumps, resolution=0.0), "resolution must be > 0"),
        (dict(fn=_bumps, resolution=1e-4), "use a coarser resolution"),
        (dict(fn=_bumps, x_range=(-1e308, 1e308)), "use a coarser resolution"),
        (dict(fn=_bumps, course_end_x=25.0), "course_end_x 25.0 must lie in x_range"),
    ],
)
def test_bad_heightfields_raise(kwargs, message):
    with pytest.raises(ValueError) as error:
        terrain.heightfield(**kwargs)
    assert message in str(error.value)


@pytest.fixture
def registry(monkeypatch):
    """An isolated copy of the registry, so registrations do not leak between tests."""
    monkeypatch.setattr(terrain.registry, "_REGISTRY", dict(terrain.registry._REGISTRY))


def test_register_and_get_custom_terrain(registry):
    bumps = terrain.heightfield(_bumps, x_range=(-2, 6), name="my bumps")
    terrain.register("bumps", bumps)
    terrain.register("steep", lambda: terrain.sections([Section(20.0, 2.0)]))
    assert {"bumps", "steep"} <= set(terrain.names())
    got = terrain.get("bumps")
    assert got.name == got.spec == "bumps"
    np.testing.assert_array_equal(got.heights, bumps.heights)
    steep = terrain.get("steep")
    assert float(steep.slope_at(3.0, 0.0)) == pytest.approx(math.radians(20), abs=ATOL_ANGLE)
    with pytest.raises(ValueError, match="'bumps' is already registered"):
        terrain.register("bumps", bumps)
    terrain.register("s4", bumps, overwrite=True)
    np.testing.assert_array_equal(terrain.get("s4").heights, bumps.heights)
    for bad_name in ["", "sections", "a:b", "two words", "9lives", "x@1"]:
        with pytest.raises(ValueError, match="bad terrain name"):
            terrain.register(bad_name, bumps)
    with pytest.raises(TypeError):
        terrain.register("number", 5)  # type: ignore[arg-type]
    terrain.register("broken", lambda: "flat")  # type: ignore[arg-type,return-value]
    with pytest.raises(TypeError, match="returned str"):
        terrain.get("broken")


# --- the MuJoCo ground ----------------------------------------------------------------------------

BALL_RADIUS = 0.05


def _compile(ground: terrain.Terrain, balls: list[tuple[float, float]] = ()) -> mujoco.MjModel:
    """The ground plus free spheres (robot-like collision flags) just above it at (x, y)."""
    spec = mujoco.MjSpec()
    ground.attach(spec)
    for x, y in balls:
        z = float(ground.height_at(x, y)) + BALL_RADIUS + 0.01
        body = spec.worldbody.add_body(pos=[x, y, z])
        body.add_freejoint()
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[BALL_RADIUS, 0, 0], contype=1, conaffinity=0
        )
    return spec.compile()


def _ray_heights(model: mujoco.MjModel, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Heights where vertical rays from above hit the ground geom."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    geom_id = np.zeros(1, np.int32)
    down = np.array([0.0, 0.0, -1.0])
    top = 50.0
    hits = []
    for xi, yi in zip(x, y):
        distance = mujoco.mj_ray(model, data, np.array([xi, yi, top]), down, None, 1, -1, geom_id)
        assert geom_id[0] == model.geom(terrain.FLOOR_GEOM).id, (xi, yi)
        hits.append(top - distance)
    return np.array(hits)


def _assert_ground_properties(model: mujoco.MjModel, geom_type: mujoco.mjtGeom) -> None:
    floor = model.geom(terrain.FLOOR_GEOM)
    assert floor.type[0] == geom_type
    assert (floor.contype[0], floor.conaffinity[0], floor.condim[0]) == (0, 1, 3)
    np.testing.assert_allclose(floor.friction, terrain.GROUND_FRICTION)


def test_flat_attaches_a_plane():
    model = _compile(terrain.get("flat"))
    _assert_ground_properties(model, mujoco.mjtGeom.mjGEOM_PLANE)
    assert model.nhfield == 0
    np.testing.assert_allclose(_ray_heights(model, [0.0, 37.0], [0.0, -12.0]), 0.0, atol=1e-9)


COURSES = {
    "slope5": terrain.get("slope5"),
    "s4": terrain.get("s4"),
    "downhill-start": terrain.parse("sections:-7.5@1.3,3@0.77;lead_in=0.3;resolution=0.04"),
    "bumps": terrain.heightfield(_bumps, x_range=(-2, 6), y_range=(-1.5, 1.5), name="bumps"),
}


@pytest.mark.parametrize("name", COURSES)
def test_mujoco_heightfield_matches_height_at(name):
    ground = COURSES[name]
    model = _compile(ground)
    _assert_ground_properties(model, mujoco.mjtGeom.mjGEOM_HFIELD)
    assert 0.0 <= model.hfield_data.min() and model.hfield_data.max() <= 1.0  # MJX needs [0, 1]
    x_min, x_max, y_min, y_max = ground.extent
    rng = np.random.default_rng(3)
    # Grid vertices (exact up to float32) and points between them (MuJoCo's triangles).
    nrow, ncol = ground.hfield_shape
    vertex_x = np.linspace(x_min, x_max, ncol)[1:-1:7]
    vertex_y = np.linspace(y_min, y_max, nrow)[rng.integers(1, nrow - 1, vertex_x.size)]
    np.testing.assert_allclose(
        _ray_heights(model, vertex_x, vertex_y), ground.height_at(vertex_x, vertex_y), atol=1e-4
    )
    x, y = rng.uniform([x_min + 0.01, y_min + 0.01], [x_max - 0.01, y_max - 0.01], (300, 2)).T
    error = np.abs(_ray_heights(model, x, y) - ground.height_at(x, y))
    assert error.max() < 1e-2
    if name in ("slope5", "s4"):  # every kink on a vertex: the profile is reproduced exactly
        assert error.max() < 1e-4
    elif ground.y_knots.size == 1:  # kinks between vertices are cut by <= |Δtan| * resolution / 4
        kink_bound = np.abs(np.diff(np.diff(ground.heights[0]) / np.diff(ground.x_knots))).max()
        assert 1e-4 < error.max() <= kink_bound * ground.resolution / 4 + 1e-5


@pytest.mark.parametrize(
    "name, balls",
    [
        ("slope5", [(1.0, 0.0), (6.5, 1.0), (12.5, -1.5)]),  # lead-in, top plateau, run-out
        ("s4", [(4.1, 0.5), (6.7, -0.5), (9.0, 2.0)]),  # the two 0° sections, run-out
        ("downhill-start", [(-1.0, 0.0), (3.5, 0.0)]),  # below zero after the course
    ],
)
def test_balls_rest_on_the_ground_in_mujoco(name, balls):
    ground = COURSES[name]
    model = _compile(ground, balls)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=500)
    position = data.xpos[1:]
    # No check of x, y: on MuJoCo's (C) heightfields balls creep even on level ground (tilted
    # contact normals at prism edges, also on a constant heightfield); MJX's collider does not.
    clearance = position[:, 2] - BALL_RADIUS - np.asarray(ground.height_at(*position[:, :2].T))
    np.testing.assert_allclose(clearance, 0.0, atol=3e-3)


def test_attach_refuses_a_second_floor():
    spec = mujoco.MjSpec()
    terrain.get("s4").attach(spec)
    with pytest.raises(ValueError, match="already has a geom named 'floor'"):
        terrain.get("slope5").attach(spec)


@pytest.mark.slow
def test_mjx_spheres_rest_on_the_heightfield():
    """MJX reads hfield_data as stored: the [0, 1] data and the geom's z offset must place the
    ground where height_at says, also below z = 0. (Balls creep a few mm here too, so x, y are
    not checked.)"""
    from mujoco import mjx

    ground = COURSES["downhill-start"]
    balls = [(-1.0, 0.0), (3.5, 0.0), (4.5, 1.0), (5.0, -2.2)]
    model = _compile(ground, balls)
    mjx_model = mjx.put_model(model, impl="jax")
    step = functools.partial(mjx.step, mjx_model)
    settle = jax.jit(lambda data: jax.lax.fori_loop(0, 150, lambda _, d: step(d), data))
    data = settle(mjx.make_data(mjx_model))
    position = np.asarray(data.xpos[1:])
    clearance = position[:, 2] - BALL_RADIUS - np.asarray(ground.height_at(*position[:, :2].T))
    np.testing.assert_allclose(clearance, 0.0, atol=3e-3)
