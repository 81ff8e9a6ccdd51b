"""Courses side by side: one heightfield of lanes, a random course family and the held-out test set.

MJX simulates one model for a whole batch, so robots on different courses share one ground: lane
i is a band along x centred at y = `Lane.y` on which the ground follows course i's sections and
does not vary with y. The robots of lane i spawn on its centre line; observations hold no
position and Eq. 11 sees only y differences, so the lane's offset reaches neither.

Layout across y, in heightfield cells of `y_cell` m (`cells` = lane_width / y_cell per lane):

    row i·cells       boundary: the mean of lanes i − 1 and i (a ramp between them)
    rows i·cells + 1 … i·cells + cells − 1: lane i's profile, the same in every row

so within a lane's band (half-width (cells/2 − 1)·y_cell, 0.75 m by default) both `height_at` /
`slope_at` (bilinear between identical rows) and MuJoCo's triangulated heightfield are exactly the
course's piecewise-linear profile, provided every kink lies on an x vertex (section lengths are
whole multiples of `resolution` in the random families).

Specs (`--terrain`), parsed by `parse`:

- `random:max_deg=12,sections=3-5,len=1-3,seed=K[,lanes=64]`: `lanes` random courses in order of
  difficulty, lane i's slopes drawn up to max_deg·(i+1)/lanes (the training family; the course
  curriculum of `quadcos.training.curriculum` moves robots up the lanes as they succeed);
- `testset:SEED`: 64 random courses (3–6 sections of 1–3 m, slopes of 2–11°, each with an uphill
  and a downhill), then flat (a 10-m level course), slope5 and s4 — drawn from a random stream that no `random:`
  family uses, whatever its seed.
"""

import math
from collections.abc import Sequence

import numpy as np

from quadcos.terrain import builders, registry
from quadcos.terrain.builders import Section
from quadcos.terrain.ground import Lane, Terrain

RANDOM_PREFIX = "random:"
TESTSET_PREFIX = "testset:"
RANDOM_FORMAT = "random:max_deg=DEG,sections=MIN-MAX,len=MIN-MAX,seed=K[,lanes=N]"
TESTSET_FORMAT = "testset:SEED"
_RANDOM_DEFAULTS = {"max_deg": 12.0, "sections": (3, 5), "len": (1.0, 3.0), "seed": 0, "lanes": 64}
_MAX_LANES = 256
_TEST_COURSES = 64
_TEST_SETTINGS = {"max_deg": 11.0, "sections": (3, 6), "len": (1.0, 3.0)}
_TEST_NAMED = ("flat", "slope5", "s4")
_TEST_FLAT_M = 10.0  # m: the test set's level course
_MIN_TEST_DEG = 2.0  # a test course's slopes are at least this steep
_TRAIN_STREAM, _TEST_STREAM = 0, 1  # first word of the random generator's seed sequence


def lanes(
    courses: Sequence[tuple[str, Sequence[Section]]],
    *,
    lead_in: float = 2.0,
    run_out: float = 20.0,
    resolution: float = 0.05,
    lane_width: float = 2.0,
    y_cell: float = 0.25,
    name: str = "lanes",
    spec: str | None = None,
) -> Terrain:
    """One terrain holding `courses` side by side in y, lane i for courses[i].

    Args:
      courses: (name, sections) per lane; no sections is level ground (unbounded, no course end).
      lead_in: flat ground between the spawn point x = 0 and each course's first section, m.
      run_out: flat ground after the longest course, m (shorter courses get more).
      resolution: x cell of the heightfield, m.
      lane_width: distance between lane centres, m; a whole number (>= 4) of `y_cell`s.
      y_cell: y cell of the heightfield, m.
      name, spec: the terrain's display name and spec (default: `name`).

    Raises:
      ValueError: no courses, a bad section, or a lane width that is not 4 or more y cells.
    """
    if not courses:
        raise ValueError("courses is empty; expected at least one (name, sections) pair")
    cells = round(lane_width / y_cell)
    if cells < 4 or not math.isclose(cells * y_cell, lane_width):
        raise ValueError(
            f"lane_width {lane_width} m must be a whole number (>= 4) of y_cell {y_cell} m"
        )
    profiles = []
    for course_name, sections in courses:
        if not sections:
            profiles.append((course_name, None, np.array([0.0]), np.array([0.0])))
            continue
        course = builders.sections(sections, lead_in=lead_in, run_out=1.0, resolution=resolution)
        knots, heights = course.x_knots[1:-1], course.heights[0, 1:-1]  # spawn-side flat held
        profiles.append((course_name, course.course_end_x, knots, heights))
    ends = [end for _, end, _, _ in profiles if end is not None]
    x_max = max(ends, default=lead_in) + run_out
    back = -builders._BACK_RUN  # the flat ground behind the spawn points of sections courses
    x_knots = np.unique(np.concatenate([[back, x_max], *(p[2] for p in profiles)]))
    lane_rows = np.stack([np.interp(x_knots, knots, heights) for _, _, knots, heights in profiles])

    count = len(courses)
    y_min = -count * lane_width / 2
    y_knots, rows, lane_list = [], [], []
    for i, (course_name, end, _, _) in enumerate(profiles):
        below = lane_rows[max(i - 1, 0)]
        y_knots += [y_min + i * lane_width + k * y_cell for k in (0, 1, cells - 1)]
        rows += [(below + lane_rows[i]) / 2, lane_rows[i], lane_rows[i]]
        lane_list.append(Lane(course_name, y_min + (i + 0.5) * lane_width, end))
    y_knots.append(y_min + count * lane_width)
    rows.append(lane_rows[-1])
    return Terrain(
        name=name,
        spec=name if spec is None else spec,
        x_knots=x_knots,
        y_knots=np.array(y_knots),
        heights=np.stack(rows),
        resolution=resolution,
        course_end_x=max(ends, default=None),
        y_resolution=y_cell,
        lanes=tuple(lane_list),
    )


def random_sections(
    rng: np.random.Generator,
    *,
    max_deg: float,
    sections: tuple[int, int],
    length: tuple[float, float],
    min_deg: float = 0.0,
    resolution: float = 0.05,
) -> list[Section]:
    """One random course: `sections` (min, max) sections, each up, down (slope in [min_deg,
    max_deg]°) or flat, of `length` (min, max) m rounded to whole `resolution`s; a course of two
    or more sections has at least one uphill and one downhill, and no two flats in a row."""
    count = int(rng.integers(sections[0], sections[1] + 1))
    while True:
        kinds = rng.choice([1, -1, 0], size=count, p=[0.4, 0.4, 0.2])
        flat_pair = ((kinds[1:] == 0) & (kinds[:-1] == 0)).any()  # would be one section
        if count < 2 or (1 in kinds and -1 in kinds and not flat_pair):
            break
    magnitudes = rng.uniform(min_deg, max_deg, size=count)
    lengths = np.maximum(np.round(rng.uniform(*length, size=count) / resolution), 1) * resolution
    return [
        Section(round(float(kind * magnitude), 2), round(float(section_length), 6))
        for kind, magnitude, section_length in zip(kinds, magnitudes, lengths)
    ]


def random_family(
    *,
    max_deg: float = 12.0,
    sections: tuple[int, int] = (3, 5),
    length: tuple[float, float] = (1.0, 3.0),
    seed: int = 0,
    num_lanes: int = 64,
) -> Terrain:
    """The training family `random:...`: `num_lanes` random courses, lane i's slopes up to
    max_deg·(i+1)/num_lanes, so that the lanes run from nearly level to `max_deg`."""
    _check_random(max_deg, sections, length, seed, num_lanes)
    rng = np.random.default_rng([_TRAIN_STREAM, seed])
    courses = [
        (
            f"course{i}",
            random_sections(
                rng, max_deg=max_deg * (i + 1) / num_lanes, sections=sections, length=length
            ),
        )
        for i in range(num_lanes)
    ]
    spec = (
        f"{RANDOM_PREFIX}max_deg={builders._format_number(max_deg)},"
        f"sections={sections[0]}-{sections[1]},"
        f"len={builders._format_number(length[0])}-{builders._format_number(length[1])},"
        f"seed={seed},lanes={num_lanes}"
    )
    return lanes(courses, name=spec, spec=spec)


def testset(seed: int) -> Terrain:
    """`testset:SEED`: 64 random courses from the test stream (see the module doc), then flat,
    slope5 and s4, one lane each."""
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"testset seed must be an integer >= 0, got {seed!r}")
    rng = np.random.default_rng([_TEST_STREAM, seed])
    settings = _TEST_SETTINGS
    courses = [
        (
            f"test{i}",
            random_sections(
                rng,
                max_deg=settings["max_deg"],
                sections=settings["sections"],
                length=settings["len"],
                min_deg=_MIN_TEST_DEG,
            ),
        )
        for i in range(_TEST_COURSES)
    ]
    for named in _TEST_NAMED:  # flat as a 10-m level course: its robots stop at its end
        course = registry.registered(named)
        courses.append((named, course_sections(course) or [Section(0.0, _TEST_FLAT_M)]))
    spec = f"{TESTSET_PREFIX}{seed}"
    return lanes(courses, name=spec, spec=spec)


def course_sections(course: Terrain) -> list[Section]:
    """The sections of a single-lane sections course (none for flat ground)."""
    if course.is_flat:
        return []
    if course.y_knots.size != 1 or course.course_end_x is None:
        raise ValueError(f"terrain {course.name!r} is not a sections course")
    inside = (course.x_knots > 0) & (course.x_knots <= course.course_end_x)
    knots, heights = course.x_knots[inside], course.heights[0, inside]
    sections: list[Section] = []
    for length, rise in zip(np.diff(knots), np.diff(heights)):
        angle = float(np.rad2deg(np.arctan(rise / length)))
        if sections and abs(sections[-1].angle_deg - angle) < 1e-4:  # one section cut by knots
            sections[-1] = Section(sections[-1].angle_deg, sections[-1].length_m + float(length))
        else:
            sections.append(Section(angle, float(length)))
    return [Section(round(a, 6), round(n, 9)) for a, n in sections]


def parse(spec: str) -> Terrain | None:
    """The terrain of a `random:...` or `testset:SEED` spec; None for other specs.

    Raises:
      ValueError: a malformed spec, naming the bad token and the expected format.
    """
    if spec.startswith(TESTSET_PREFIX):
        text = spec.removeprefix(TESTSET_PREFIX).strip()
        if not text.isdigit():
            raise ValueError(f"bad terrain spec {spec!r}: expected {TESTSET_FORMAT}, SEED >= 0")
        return testset(int(text))
    if not spec.startswith(RANDOM_PREFIX):
        return None
    options = dict(_RANDOM_DEFAULTS)
    given = set()
    for token in filter(None, spec.removeprefix(RANDOM_PREFIX).split(",")):
        key, equals, value = (part.strip() for part in token.partition("="))
        if not equals or key not in options or key in given:
            raise ValueError(f"bad option {token!r} in {spec!r}: expected {RANDOM_FORMAT}")
        given.add(key)
        try:
            if key in ("sections", "len"):
                low, dash, high = value.partition("-")
                cast = int if key == "sections" else float
                options[key] = (cast(low), cast(high)) if dash else (cast(low), cast(low))
            else:
                options[key] = float(value) if key == "max_deg" else int(value)
        except ValueError:
            raise ValueError(f"bad option {token!r} in {spec!r}: expected {RANDOM_FORMAT}") from None
    try:
        return random_family(
            max_deg=options["max_deg"],
            sections=options["sections"],
            length=options["len"],
            seed=options["seed"],
            num_lanes=options["lanes"],
        )
    except ValueError as error:
        raise ValueError(f"bad terrain spec {spec!r}: {error}") from None


def _check_random(
    max_deg: float, sections: tuple[int, int], length: tuple[float, float], seed: int, lanes: int
) -> None:
    if not 0 < max_deg <= 45:
        raise ValueError(f"max_deg must be in (0, 45], got {max_deg}")
    if not 1 <= sections[0] <= sections[1] <= 20:
        raise ValueError(f"sections must be MIN-MAX with 1 <= MIN <= MAX <= 20, got {sections}")
    if not 0.1 <= length[0] <= length[1] <= 20:
        raise ValueError(f"len must be MIN-MAX m with 0.1 <= MIN <= MAX <= 20, got {length}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    if not 1 <= lanes <= _MAX_LANES:
        raise ValueError(f"lanes must be in 1..{_MAX_LANES}, got {lanes}")
