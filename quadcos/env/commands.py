"""Velocity commands (issue 58): a forward speed v* (m/s) and a yaw rate ω* (rad/s) the policy
is asked to follow — drawn at random for training, or from a fixed schedule for evaluation.

A command spec is one string, parsed in `command_spec` and nowhere else (`parse_commands`):
- "" — no command: the paper's task (walk forward along +x), the observation unchanged;
- "random" — v* ~ U(speed_min, speed_max), ω* ~ U(−yaw_rate_max, yaw_rate_max) (ω* = 0 with
  probability `zero_yaw_rate_probability`; both 0, standing, with `zero_command_probability`),
  drawn at every reset and again every `resample_seconds` of an episode;
- a schedule "v,ω@s;v,ω@s;..." — e.g. "0.5,0@5;1.0,0@5;0.6,0.4@5;0,0@5": v* = 0.5 m/s, ω* = 0
  for the first 5 s, then 1.0 m/s for 5 s, ...; after the last segment its command holds.

The commanded heading ψ* (rad) integrates ω*: ψ* ← ψ* + ω*·dt every control step, starting at the
robot's heading at reset (0), leashed within `heading_leash` of the robot's yaw so that a robot
that turns too slowly is not charged for ever more accumulated lag. The reward's forward and yaw
terms track v* along ψ* and ψ* itself (`quadcos.equations.reward`); with ω* = 0 and a robot within
the leash, ψ* stays exactly 0 and the yaw term is Eq. 12's −w4 |yaw|.

`tracking="yaw_rate"` tracks the robot's own motion instead: the step's progress along the
robot's own heading at the step's start, and the yaw term is −w4 |ω − ω*| for the step's yaw rate ω
(rad/s), or with `yaw_rate_tau` > 0 that rate low-passed over τ (`tracked_yaw_rate`); with
`speed_tau` > 0 the forward term tracks the progress low-passed alike (`Command.tracked_speed`).
ψ* is a state the policy does not observe; a reward that depends on it leaves the critic
guessing (experiments/commands). The low-passed rates are filter states it does not observe
either (unless `observed_speed_tau`), but each follows the motion it sees within τ.

Pure functions of arrays (jit / vmap-able, one robot; batch with `jax.vmap`); the spec's parser
is `command_spec`'s; nothing here touches MuJoCo.
"""

import logging
import math
from typing import Any

import flax.struct
import jax
import jax.numpy as jnp
import ml_collections
import numpy as np

from quadcos.env.command_spec import RANDOM, CommandSpec, Segment, parse_commands
from quadcos.equations.reward import wrap_angle

TRACKING = ("heading", "yaw_rate")  # what the reward's yaw term tracks (module docstring)
GRAVITY = 9.81  # m/s²
# The Froude number v² / (g h) of the fastest commanded walk of a robot without a preset, h its hip
# height: 0.25 sits below the walk–trot transition of animals (~0.5, Alexander 1984) and gives
# Go1-sized robots (h ≈ 0.28 m) 0.8 m/s, the paper's robot (h = 0.67 m) 1.2 m/s.
DEFAULT_FROUDE = 0.25
# m: the turning radius at full speed of a robot without a preset (ω*_max = v*_max / radius):
# the Go1 and ANYmal C ranges (1.0 m/s, 0.5 rad/s; 0.8 m/s, 0.4 rad/s) both turn 2 m.
DEFAULT_TURN_RADIUS = 2.0
# The hip-swing scales at which the feed-forward's speed map is measured (`speed_map`).
SPEED_MAP_SCALES = (0.25, 0.5, 0.75, 1.0)
# The drive's gain (`corrected_gain`): its range, and the least v* (m/s) it is corrected at.
GAIN_RANGE = (0.5, 2.0)
GAIN_MIN_SPEED = 0.1
logger = logging.getLogger(__name__)


def default_config() -> ml_collections.ConfigDict:
    """The env's `commands` config: off by default (the paper's task)."""
    config = ml_collections.ConfigDict()
    config.spec = ""  # "" (off), "random", or a schedule "v,ω@s;..." (parse_commands)
    # m/s: v* ~ U(speed_min, speed_max); speed_max 0 = the robot's (robot preset, else from its
    # hip height: speed_range).
    config.speed_min = 0.0
    config.speed_max = 0.0
    config.yaw_rate_max = 0.0  # rad/s: ω* ~ U(−max, max); 0 = the robot's (yaw_rate_range)
    config.zero_yaw_rate_probability = 0.1  # share of draws with ω* = 0 (walking straight)
    config.zero_command_probability = 0.0  # share of draws with v* = ω* = 0 (standing)
    config.resample_seconds = 5.0  # s: a random command is drawn anew this often in an episode
    config.heading_leash = 0.5  # rad: the most the commanded heading ψ* may lead or trail the yaw
    config.tracking = "heading"  # or "yaw_rate" (TRACKING; the module docstring)
    # s: > 0 (tracking "yaw_rate") the yaw term charges the yaw rate low-passed over this time
    # constant (`low_passed_speed`), the turn over a stride or two as the tracking metric's 0.5-s
    # windows measure it, not each step's sway within a stride; 0: the step's own yaw rate
    config.yaw_rate_tau = 0.0
    # s: > 0 (tracking "yaw_rate") the forward term tracks the speed low-passed over this time
    # constant: |d − c| of each step's progress d charges a mean error only in part where the
    # speed swings within a stride (docs/env.md, "Low-passed speed"); 0: each step's progress
    config.speed_tau = 0.0
    # s: > 0 observes the robot's speed along its own heading, low-passed over this time constant
    # (`Command.speed`), before (v*, ω*); 0: not observed (the policy sees the torso's velocity
    # in the world frame only, as the paper's state has it)
    config.observed_speed_tau = 0.0
    # True observes the drive's state before (v*, ω*), after the observed speed: its speed gain g,
    # heading correction s (rad/s) and the reward's low-passed yaw rate (rad/s; `Command`), which
    # the reward depends on and the policy's other observations do not show
    config.observe_drive = False
    # The command's feed-forward (beyond the paper), off by default: each side's hip swing scaled
    # by its commanded speed, a differential drive (`drive_scales`), before the policy acts.
    config.feed_forward = False
    config.reference_speed = 0.0  # m/s: v_ref, the unscaled rhythm's speed; 0 = speed_max
    # m/s: the speeds measured at the hip-swing scales SPEED_MAP_SCALES, which the drive inverts
    # (a stride's speed is not proportional to its scale); (): v_ref × each scale
    config.speed_map = ()
    # m: b, the effective half track (negative: the gait turns away from its longer strides);
    # 0 = the robot's (mean |hip y|)
    config.half_track = 0.0
    config.scale_max = 1.5  # the largest |scale| of a side's hip swing
    # rad/s: > 0 caps the yaw rate the drive asks of the sides, after its gain and heading loop
    # (`drive_scales`): past what a gait turns by, side differences turn it no faster (on low
    # friction hardly at all) and the loops wind a lagging turn up to the strides' clip; 0: no cap
    config.turn_max = 0.0
    # 1/s: > 0 closes the feed-forward's loop on speed: the drive asks for g·(v*, ω*), the gain g
    # moved each control step by this rate × the relative speed error (`corrected_gain`); 0: g = 1
    config.speed_gain_rate = 0.0
    # 1/s: > 0 closes the drive's loop on heading: it turns at ω* + k·(ψ* − yaw) for this k, ψ* the
    # integrated ω* on its leash (`steering`); 0: it turns at ω*
    config.heading_gain = 0.0
    return config


def speed_range(
    speed_max: float | None, hip_height: float, froude: float = DEFAULT_FROUDE
) -> float:
    """m/s: the fastest commanded speed of a robot: `speed_max` where its preset gives one, else
    √(Fr·g·h) for its hip height h (m; the base above the ground standing) at Froude number Fr,
    rounded down to 0.1 m/s (at least 0.1)."""
    if speed_max is not None:
        return float(speed_max)
    return max(0.1, math.floor(10 * math.sqrt(froude * GRAVITY * hip_height)) / 10)


def yaw_rate_range(yaw_rate_max: float | None, speed_max: float) -> float:
    """rad/s: the fastest commanded turn: `yaw_rate_max` where the robot's preset gives one, else
    a turn of DEFAULT_TURN_RADIUS at the fastest speed (v*_max / 2 m)."""
    if yaw_rate_max is not None:
        return float(yaw_rate_max)
    return speed_max / DEFAULT_TURN_RADIUS


def validate(config: ml_collections.ConfigDict) -> CommandSpec:
    """The parsed spec of a (resolved) `commands` config; raises ValueError naming a bad value."""
    parsed = parse_commands(config.spec)
    if not 0 <= config.speed_min <= config.speed_max < math.inf:
        raise ValueError(
            "commands.speed_min and commands.speed_max must satisfy 0 <= min <= max < inf; got"
            f" {config.speed_min}, {config.speed_max}"
        )
    for name in ("zero_yaw_rate_probability", "zero_command_probability"):
        if not 0 <= config[name] <= 1:
            raise ValueError(f"commands.{name} must be in [0, 1]; got {config[name]}")
    if not 0 < config.resample_seconds < math.inf:
        raise ValueError(
            f"commands.resample_seconds must be finite and > 0; got {config.resample_seconds}"
        )
    if not 0 < config.heading_leash <= math.pi:
        raise ValueError(
            f"commands.heading_leash must be in (0, π] rad; got {config.heading_leash}"
        )
    if config.tracking not in TRACKING:
        raise ValueError(
            f"commands.tracking must be one of {', '.join(TRACKING)}; got {config.tracking!r}"
        )
    for tau in ("yaw_rate_tau", "speed_tau"):
        if config[tau] > 0 and config.tracking != "yaw_rate":
            raise ValueError(
                f"commands.{tau} needs commands.tracking='yaw_rate'; got {config.tracking!r}"
            )
    keys = ("reference_speed", "scale_max", "turn_max", "speed_gain_rate", "heading_gain")
    for key in ("yaw_rate_max", "observed_speed_tau", *keys, "yaw_rate_tau", "speed_tau"):
        if not 0 <= config[key] < math.inf:
            raise ValueError(f"commands.{key} must be finite and >= 0; got {config[key]}")
    if not math.isfinite(config.half_track):
        raise ValueError(f"commands.half_track must be finite; got {config.half_track}")
    if config.speed_map:
        speed_map(config)  # raises naming a bad map
    return parsed


def followed(spec: str, config: ml_collections.ConfigDict) -> CommandSpec:
    """The parsed spec `spec` that an env of `commands` config `config` follows instead of its
    own (`QuadrupedEnv.with_commands`, `deploy.host_commands.follow`); logs a warning for a
    scheduled command outside the ranges `config` was trained on (where it gives them).

    Raises:
      ValueError: a bad or empty spec, or a config without commands (its policy observes none).
    """
    parsed = parse_commands(spec)
    if not parse_commands(config.spec).enabled:
        raise ValueError(
            f"commands {spec!r}: the policy was not trained with velocity commands (its env's"
            f" commands.spec is {config.spec!r}): it observes no command, so it follows none"
        )
    if not parsed.enabled:
        raise ValueError(
            f"commands {spec!r}: give {RANDOM!r} or a schedule 'v,ω@s;...'; a policy trained"
            " with commands cannot run without them"
        )
    limits = (config.speed_min, config.speed_max, config.yaw_rate_max)
    for index, segment in enumerate(parsed.schedule, 1):
        speed_out = not limits[0] - 1e-6 <= segment.speed <= limits[1] + 1e-6
        turn_out = abs(segment.yaw_rate) > limits[2] + 1e-6
        if limits[1] > 0 and limits[2] > 0 and (speed_out or turn_out):
            logger.warning(
                "commands %r: segment %d (v* %g m/s, ω* %g rad/s) is outside the ranges the"
                " policy was trained on (v* %g–%g m/s, |ω*| <= %g rad/s)",
                spec, index, segment.speed, segment.yaw_rate, *limits,
            )
    return parsed


def speed_map(config: ml_collections.ConfigDict) -> tuple[float, ...]:
    """The speeds (m/s) of the gait at the hip-swing scales SPEED_MAP_SCALES: `config.speed_map`
    (an env `commands` config), or v_ref × each scale where it is empty."""
    if not config.speed_map:
        return tuple(config.reference_speed * scale for scale in SPEED_MAP_SCALES)
    try:
        speeds = tuple(float(value) for value in config.speed_map)
    except (TypeError, ValueError):
        speeds = ()
    increasing = all(a < b for a, b in zip((0.0, *speeds), speeds, strict=False))
    if len(speeds) != len(SPEED_MAP_SCALES) or not increasing or not math.isfinite(speeds[-1]):
        raise ValueError(
            f"commands.speed_map must be {len(SPEED_MAP_SCALES)} increasing speeds > 0 (m/s at"
            f" the scales {SPEED_MAP_SCALES}); got {config.speed_map!r}"
        )
    return speeds


def drive_map(config: ml_collections.ConfigDict) -> np.ndarray | None:
    """(5,) float32: a `commands` config's speed map (m/s at SPEED_MAP_SCALES) and half track b
    (m), what its feed-forward reads of the searched gait; None with the feed-forward off."""
    if not config.feed_forward:
        return None
    return np.asarray([*speed_map(config), config.half_track], np.float32)


def drive(config: ml_collections.ConfigDict, velocity: jax.Array, mapping: jax.Array) -> jax.Array:
    """(..., 2) `drive_scales` for velocity commands (..., 2) through a drive map `mapping`
    (`drive_map`: traced where a trainer passes it) and a `commands` config's clip."""
    return drive_scales(
        velocity, tuple(mapping[:-1]), mapping[-1], config.scale_max, config.turn_max
    )


def drive_scales(
    velocity: Any,
    speeds: tuple[float, ...],
    half_track: Any,
    scale_max: float,
    turn_max: float = 0.0,
    xp: Any = jnp,
) -> Any:
    """(..., 2) the feed-forward's scales of the left and right hips' swing for commands (..., 2)
    (v*, ω*) (m/s, rad/s): each side's commanded speed, v* ∓ ω*·b for half track b (m), ω* capped
    at ±`turn_max` where that is > 0, turned into the scale that walks it by the speed map
    `speeds` (m/s at SPEED_MAP_SCALES, `speed_map`), clipped to ±`scale_max` — a differential
    drive: a side's stride, and so its speed, grows with its hip amplitude. (0, 0) at v* = ω* = 0
    (trotting in place); opposite signs turn on the spot (a negative scale strides backwards).
    With `xp` numpy or jax.numpy."""
    speed, yaw_rate = velocity[..., 0], velocity[..., 1]
    if turn_max > 0:
        yaw_rate = xp.clip(yaw_rate, -turn_max, turn_max)
    sides = xp.stack([speed - yaw_rate * half_track, speed + yaw_rate * half_track], axis=-1)
    return xp.clip(side_scale(sides, speeds, xp), -scale_max, scale_max)


def side_scale(speed: Any, speeds: tuple[float, ...], xp: Any = jnp) -> Any:
    """The hip-swing scale that walks a side at `speed` (m/s), with `xp` numpy or jax.numpy: the
    speed map `speeds` (at SPEED_MAP_SCALES) inverted piecewise-linearly from (0, 0), past its last
    point at the map's mean speed per scale (a map that levels off would otherwise ask for the
    largest strides), odd in the speed. A map v_ref × each scale gives speed / v_ref."""
    knot_speeds, knot_scales = (0.0, *speeds), (0.0, *SPEED_MAP_SCALES)
    magnitude = xp.abs(speed)
    inside = xp.interp(magnitude, xp.asarray(knot_speeds), xp.asarray(knot_scales))
    beyond = magnitude * (knot_scales[-1] / knot_speeds[-1])
    return xp.sign(speed) * xp.where(magnitude > knot_speeds[-1], beyond, inside)


@flax.struct.dataclass
class Command:
    """A robot's command in the env state: what it is asked to do now, and its heading target."""

    velocity: jax.Array  # (2,): v* (m/s), ω* (rad/s)
    heading: jax.Array  # () rad: ψ*, the integrated ω* (leashed to the yaw)
    rng: jax.Array  # the key of the robot's next random draw
    # (2,): the command of the robot's first state. Brax's auto-reset restarts an env from its first
    # state (observation included) and keeps `info`: its episodes all start with this command, so
    # that the first observation tells the truth (`restart`); later draws differ.
    initial: jax.Array
    # () m/s: the robot's progress along its heading per second, low-passed over
    # `observed_speed_tau` (`low_passed_speed`); 0 at a reset
    speed: jax.Array
    # () the drive's speed gain g (`corrected_gain`): the feed-forward walks g·v*; 1 at a reset
    gain: jax.Array
    # () rad/s: the drive's heading correction (`steering`), added to ω*; 0 at a reset
    correction: jax.Array
    # () rad/s: the robot's yaw rate low-passed over `yaw_rate_tau` (`low_passed_speed`); 0 at a
    # reset, and throughout for τ = 0
    yaw_rate: jax.Array
    # () m/s: the robot's progress along its heading per second, low-passed over `speed_tau` (the
    # forward term's); 0 at a reset, and throughout for τ = 0
    tracked_speed: jax.Array

    def driven(self) -> jax.Array:
        """(..., 2) the velocity the drive is asked for: g·(v*, ω* + s) (`driven`)."""
        return driven(self.velocity, self.gain, jnp, self.correction)


class Plan:
    """A parsed spec made into arrays for the env's step (fixed data, like the env)."""

    def __init__(self, spec: CommandSpec, config: ml_collections.ConfigDict):
        self.spec = spec
        self.config = config
        segments = spec.schedule or (Segment(0.0, 0.0, 1.0),)
        self._velocities = jnp.asarray([(s.speed, s.yaw_rate) for s in segments], jnp.float32)
        ends = [0.0]
        for segment in segments:
            ends.append(ends[-1] + segment.seconds)
        self._ends = jnp.asarray(ends[1:-1], jnp.float32)  # where each segment but the last ends

    def start(self, rng: jax.Array) -> Command:
        """The command at an episode's start (t = 0)."""
        rng, draw_key = jax.random.split(rng)
        velocity = self.at(draw_key, jnp.zeros(()))
        zero, one = jnp.zeros(()), jnp.ones(())
        return Command(
            velocity=velocity,
            heading=zero,
            rng=rng,
            initial=velocity,
            speed=zero,
            gain=one,
            correction=zero,
            yaw_rate=zero,
            tracked_speed=zero,
        )

    def restart(self, command: Command, just_reset: jax.Array) -> Command:
        """`command`, or where `just_reset` (an auto-reset restored the first state) its first
        one again, the heading, the observed speed, the low-passed yaw rate and speed and the
        drive's correction back at 0, its gain at 1."""
        return command.replace(
            velocity=jnp.where(just_reset, command.initial, command.velocity),
            heading=jnp.where(just_reset, 0.0, command.heading),
            speed=jnp.where(just_reset, 0.0, command.speed),
            gain=jnp.where(just_reset, 1.0, command.gain),
            correction=jnp.where(just_reset, 0.0, command.correction),
            yaw_rate=jnp.where(just_reset, 0.0, command.yaw_rate),
            tracked_speed=jnp.where(just_reset, 0.0, command.tracked_speed),
        )

    def at(self, key: jax.Array, time: jax.Array) -> jax.Array:
        """(2,) the command at episode time `time` (s): a fresh draw ("random") or the
        schedule's segment."""
        if self.spec.mode == RANDOM:
            return sample(key, self.config)
        return schedule_at(self._velocities, self._ends, time)

    def step(
        self,
        command: Command,
        yaw: jax.Array,
        yaw_before: jax.Array,
        dt: float,
        time_before: jax.Array,
        time_now: jax.Array,
        moved: jax.Array,
    ) -> tuple[dict[str, jax.Array], Command]:
        """The reward's command arguments for a control step of `dt` s from `time_before` to
        `time_now` in which the robot's yaw went from `yaw_before` to `yaw` (rad) and it moved
        `moved` m along its heading at the step's start: the commanded progress v*·dt (m) and
        the heading ψ* advanced on its leash, or with `tracking="yaw_rate"` the heading at the
        step's start, the yaw-rate error ω − ω* (rad/s, ω as `tracked_yaw_rate`) and with
        `speed_tau` the progress the forward term tracks (m: `Command.tracked_speed` × dt); and the
        command after the step (`advance`), its observed speed and yaw rate low-passed
        (`low_passed_speed`), its drive's gain corrected (`corrected_gain`) and its heading
        correction set (`steering`)."""
        speed = low_passed_speed(command.speed, moved, dt, self.config.observed_speed_tau)
        rate = self.config.speed_gain_rate
        gain = corrected_gain(command.gain, command.velocity[0], moved, dt, rate, jnp)
        command = command.replace(speed=speed, gain=gain)
        yaw_rate, progress = command.velocity[1], command.velocity[0] * dt
        heading = command.heading
        if self.config.tracking == "heading" or self.config.heading_gain > 0:
            heading = advance_heading(heading, yaw_rate, yaw, dt, self.config.heading_leash)
        correction = steering(heading, yaw, self.config.heading_gain, jnp)
        command = command.replace(heading=heading, correction=correction)
        turn, tau = wrap_angle(yaw - yaw_before), self.config.yaw_rate_tau
        command = command.replace(yaw_rate=low_passed_speed(command.yaw_rate, turn, dt, tau))
        speed_tau = self.config.speed_tau
        tracked_speed = low_passed_speed(command.tracked_speed, moved, dt, speed_tau)
        command = command.replace(tracked_speed=tracked_speed)
        tracking = {"heading": heading, "commanded_progress": progress}
        if self.config.tracking == "yaw_rate":
            tracking["heading"] = yaw_before
            turned = tracked_yaw_rate(command.yaw_rate, turn, dt, tau)
            tracking["yaw_rate_error"] = turned - yaw_rate
        if speed_tau > 0:
            tracking["tracked_progress"] = tracked_speed * dt
        return tracking, self.advance(command, time_before, time_now)

    def advance(self, command: Command, time_before: jax.Array, time_now: jax.Array) -> Command:
        """The command after a control step from `time_before` to `time_now` (s): a random
        command is drawn anew where the step crossed a multiple of `resample_seconds`; a
        schedule's is its segment at `time_now`."""
        if self.spec.mode != RANDOM:
            return command.replace(velocity=self.at(command.rng, time_now))
        period = self.config.resample_seconds
        crossed = jnp.floor(time_now / period) > jnp.floor(time_before / period)
        rng, draw_key = jax.random.split(command.rng)
        velocity = jnp.where(crossed, sample(draw_key, self.config), command.velocity)
        return command.replace(velocity=velocity, rng=rng)


def sample(key: jax.Array, config: ml_collections.ConfigDict) -> jax.Array:
    """(2,) one random command: v* ~ U(speed_min, speed_max), ω* ~ U(−yaw_rate_max,
    yaw_rate_max), ω* = 0 with probability `zero_yaw_rate_probability`, both 0 with
    `zero_command_probability` (a resolved config). The standing draw's key is folded from `key`,
    not split from it: without it the draws are those of a config that has none. It folds in 3:
    fold_in(key, i) is split(key, n)[i] (JAX's partitionable threefry), and 0–2 are the others'."""
    speed_key, yaw_key, straight_key = jax.random.split(key, 3)
    speed = jax.random.uniform(speed_key, (), minval=config.speed_min, maxval=config.speed_max)
    bound = config.yaw_rate_max
    yaw_rate = jax.random.uniform(yaw_key, (), minval=-bound, maxval=bound)
    straight = jax.random.uniform(straight_key) < config.zero_yaw_rate_probability
    velocity = jnp.stack([speed, jnp.where(straight, 0.0, yaw_rate)])
    standing = jax.random.uniform(jax.random.fold_in(key, 3)) < config.zero_command_probability
    return jnp.where(standing, 0.0, velocity)


def low_passed_speed(speed: Any, progress: Any, dt: float, tau: float) -> Any:
    """The observed speed (m/s) after a control step of `dt` s that moved the robot `progress` m
    along its heading: `speed` moved towards progress / dt by 1 − exp(−dt / τ), a first-order
    filter of time constant `tau` s that smooths a gait's speed over its strides; `speed` as it
    was for τ = 0 (not observed). The yaw rate (rad/s) of a turn of `progress` rad alike
    (`Command.yaw_rate`). NumPy or JAX alike."""
    if tau <= 0:
        return speed
    return speed + (1.0 - math.exp(-dt / tau)) * (progress / dt - speed)


def tracked_yaw_rate(low_passed: Any, turn: Any, dt: float, tau: float) -> Any:
    """rad/s: the yaw rate the yaw term tracks after a control step of `dt` s that turned the robot
    `turn` rad: the `low_passed` rate (this step's turn included) for `tau` > 0, else turn / dt."""
    return low_passed if tau > 0 else turn / dt


def corrected_gain(
    gain: Any, commanded: Any, progress: Any, dt: float, rate: float, xp: Any = jnp
) -> Any:
    """The drive's gain g after a control step of `dt` s in which the robot, asked for v* =
    `commanded` m/s, moved `progress` m along its heading: g + rate·dt·(v* − progress/dt) / v*,
    an integral controller on the relative speed error (a robot that walks its strides faster
    than the speed map says gets shorter ones), held where v* < GAIN_MIN_SPEED (trotting in
    place has no speed to correct) and kept within GAIN_RANGE; `gain` itself for rate 0. With
    `xp` numpy or jax.numpy."""
    if rate <= 0:
        return gain
    moving = commanded >= GAIN_MIN_SPEED
    error = (commanded - progress / dt) / xp.maximum(commanded, GAIN_MIN_SPEED)
    return xp.clip(gain + xp.where(moving, rate * dt * error, 0.0), *GAIN_RANGE)


def steering(heading: Any, yaw: Any, gain: float, xp: Any = jnp) -> Any:
    """rad/s: the drive's heading correction k·(ψ* − yaw) for the commanded heading ψ* `heading`
    and the robot's `yaw` (rad; the difference wrapped to [−π, π], at most the leash) and the
    heading gain k = `gain` (1/s): a proportional loop on the heading, which turns a slow wobble
    of the yaw rate about ω* back onto the commanded course; 0 for k = 0. With `xp` numpy or
    jax.numpy."""
    if gain <= 0:
        return xp.zeros_like(xp.asarray(heading))
    error = xp.mod(xp.asarray(heading) - yaw + math.pi, 2 * math.pi) - math.pi
    return gain * error


def driven(velocity: Any, gain: Any, xp: Any = jnp, correction: Any = 0.0) -> Any:
    """(..., 2) the velocity the drive is asked for: g·(v*, ω* + s) for commands (..., 2) (v*,
    ω*), the drive's speed gain g (`corrected_gain`) and heading correction s (rad/s,
    `steering`): a robot whose strides walk faster than the speed map says turns faster by its
    side differences too; with `xp` numpy or jax.numpy."""
    correction = xp.asarray(correction)
    corrected = xp.stack([velocity[..., 0], velocity[..., 1] + correction], axis=-1)
    return corrected * xp.asarray(gain)[..., None]


def schedule_at(velocities: jax.Array, ends: jax.Array, time: jax.Array) -> jax.Array:
    """(2,) the schedule's command at `time` (s): `velocities` (k, 2) per segment, `ends` (k−1,)
    the times (s) at which all segments but the last end; the last holds."""
    index = jnp.searchsorted(ends, time, side="right")
    return velocities[index]


def advance_heading(
    heading: jax.Array, yaw_rate: jax.Array, yaw: jax.Array, dt: float, leash: float
) -> jax.Array:
    """ψ* after a control step of `dt` s: ψ* + ω*·dt, moved back to within `leash` rad of the
    robot's yaw (rad) where it got further away; in [−π, π]. Exactly 0 while ω* = 0, ψ* = 0 and
    |yaw| ≤ leash."""
    target = wrap_angle(heading + yaw_rate * dt)
    lag = wrap_angle(target - yaw)
    leashed = wrap_angle(yaw + jnp.clip(lag, -leash, leash))
    return jnp.where(jnp.abs(lag) > leash, leashed, target)
