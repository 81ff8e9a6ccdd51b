"""The command spec (`quadcos.env.commands`): one string, "" (off), "random", or a schedule
"v,ω@s;v,ω@s;..." of segments, parsed here and nowhere else (`parse_commands`)."""

import dataclasses
import math

RANDOM = "random"


@dataclasses.dataclass(frozen=True)
class Segment:
    """One segment of a command schedule: v* (m/s), ω* (rad/s) for `seconds`."""

    speed: float
    yaw_rate: float
    seconds: float


@dataclasses.dataclass(frozen=True)
class CommandSpec:
    """A parsed command spec: `mode` "off", "random" or "schedule" (then `schedule`'s segments)."""

    mode: str
    schedule: tuple[Segment, ...] = ()

    @property
    def enabled(self) -> bool:
        return self.mode != "off"


def parse_commands(spec: str) -> CommandSpec:
    """The command spec `spec` ("", "random" or "v,ω@s;...": see the module docstring).

    Raises:
      ValueError: naming the bad segment, e.g. "command segment 2 '1.0@5': expected v,ω@seconds".
    """
    if not isinstance(spec, str):
        raise ValueError(f"a command spec must be a string; got {spec!r}")
    text = spec.strip()
    if not text:
        return CommandSpec("off")
    if text == RANDOM:
        return CommandSpec(RANDOM)
    segments = []
    for index, part in enumerate(text.split(";"), start=1):
        part = part.strip()
        where = f"command segment {index} {part!r} of {spec!r}"
        command, at, seconds = part.partition("@")
        values = command.split(",")
        if not at or len(values) != 2:
            raise ValueError(f"{where}: expected v,ω@seconds (e.g. 0.5,0@5), or the spec 'random'")
        try:
            speed, yaw_rate, duration = (float(v) for v in (*values, seconds))
        except ValueError:
            raise ValueError(f"{where}: v, ω and seconds must be numbers") from None
        if not all(math.isfinite(v) for v in (speed, yaw_rate, duration)):
            raise ValueError(f"{where}: v, ω and seconds must be finite")
        if duration <= 0:
            raise ValueError(f"{where}: seconds must be > 0")
        segments.append(Segment(speed, yaw_rate, duration))
    return CommandSpec("schedule", tuple(segments))
