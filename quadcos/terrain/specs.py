"""Terrain specs, the CLI's `--terrain`: a registered name, `sections:...`, `random:...`,
`testset:SEED`, `heightfield:FILE.npy;...` or `MODULE:NAME`."""

from quadcos.terrain import courses, external, registry
from quadcos.terrain.builders import _SECTIONS_DEFAULTS, _SECTIONS_PREFIX, Section, sections
from quadcos.terrain.ground import Terrain

_SECTIONS_FORMAT = (
    "sections:ANGLE_DEG@LENGTH_M[,ANGLE_DEG@LENGTH_M...][;lead_in=M][;run_out=M][;resolution=M]"
)


def parse(spec: str) -> Terrain:
    """Builds a terrain from a spec string (the CLI's --terrain).

    Accepted, surrounding whitespace ignored:
      - a registered name (`flat`, `slope5`, `s4`, ...); the terrain comes back with `name` and
        `spec` set to that name;
      - `sections:ANGLE_DEG@LENGTH_M,...` with optional `;lead_in=M`, `;run_out=M`,
        `;resolution=M` (see `sections`), e.g. `sections:5@1.4,0@1.4,9@1.2,0@1.4`;
      - `MODULE:NAME` (a terrain from the user's module) and `heightfield:FILE.npy;...` (heights
        from a NumPy file): see `quadcos.terrain.external`.

    Raises:
      ValueError: unknown name or malformed sections spec, naming the bad token.
      TypeError: `spec` is not a string; `registry.NotATerrain` (also a ValueError): a
        registered factory or `MODULE:NAME` gave no Terrain.
    """
    if not isinstance(spec, str):
        raise TypeError(f"terrain spec must be a string, got {type(spec).__name__}")
    text = spec.strip()
    if text.startswith(_SECTIONS_PREFIX):
        return _parse_sections(text)
    if (lanes := courses.parse(text)) is not None:
        return lanes
    if (from_outside := external.parse_external(text)) is not None:
        return from_outside
    if (named := registry.registered(text)) is None:
        raise ValueError(
            f"unknown terrain {spec!r}; known: {', '.join(registry.names())}, {_SECTIONS_FORMAT},"
            f" {courses.RANDOM_FORMAT}, {courses.TESTSET_FORMAT},"
            f" {external.HEIGHTFIELD_FORMAT} or {external.MODULE_FORMAT}"
        )
    return named


def get(name_or_spec: str) -> Terrain:
    """The terrain for a registered name or a spec string; see `parse`."""
    return parse(name_or_spec)


def _parse_sections(spec: str) -> Terrain:
    body, *option_tokens = spec.removeprefix(_SECTIONS_PREFIX).split(";")
    if not body.strip():
        raise ValueError(f"no sections in {spec!r}: expected {_SECTIONS_FORMAT}")
    segments = []
    for token in body.split(","):
        angle_deg, at, length = token.partition("@")
        try:
            if not at:
                raise ValueError
            segments.append(Section(float(angle_deg), float(length)))
        except ValueError:
            raise ValueError(
                f"bad section {token!r} in {spec!r}: expected ANGLE_DEG@LENGTH_M"
            ) from None
    options: dict[str, float] = {}
    for token in option_tokens:
        key, equals, value = (part.strip() for part in token.partition("="))
        if not equals or key not in _SECTIONS_DEFAULTS or key in options:
            raise ValueError(
                f"bad option {token!r} in {spec!r}: expected at most one each of"
                " lead_in=M, run_out=M, resolution=M"
            )
        try:
            options[key] = float(value)
        except ValueError:
            raise ValueError(
                f"bad option {token!r} in {spec!r}: {value!r} is not a number"
            ) from None
    try:
        return sections(segments, **options)
    except ValueError as error:
        raise ValueError(f"bad terrain spec {spec!r}: {error}") from None
