"""Velocity commands for one robot in C MuJoCo: `quadcos.env.commands.Plan` and the env's
`_track` with NumPy, no JAX in the loop (`quadcos.deploy.host_robot.HostRobot`).

The command (v* m/s, ω* rad/s) follows a spec as the env's does: "random" draws v* ~
U(speed_min, speed_max), ω* ~ U(±yaw_rate_max) (0 with probability `zero_yaw_rate_probability`;
both 0 with `zero_command_probability`) at every reset and again each time the episode crosses a
multiple of `resample_seconds` (the draws are NumPy's, from the episode's reset seed, not the MJX
env's JAX stream: the same distribution, other numbers); a schedule gives its segment at the
episode's time. The commanded heading ψ* integrates ω* as the env's (`commands.advance_heading`).
`steer` holds a command given by hand (`quadcos.play`'s keys) until the next reset.
"""

from collections.abc import Sequence

import ml_collections
import numpy as np

from quadcos.deploy import twins
from quadcos.env import commands as env_commands

COMMAND_SIZE = 2  # v* (m/s), ω* (rad/s): the last values of a commanded policy's observation


def follow(config: ml_collections.ConfigDict, spec: str | None) -> ml_collections.ConfigDict:
    """`config` (an env config) following command spec `spec` instead of its own, as
    `QuadrupedEnv.with_commands`; None: `config` itself.

    Raises:
      ValueError: a bad spec, "", or a config without commands (its policy observes none).
    """
    if spec is None:
        return config
    env_commands.followed(spec, config.commands)
    config = ml_collections.ConfigDict(config.to_dict())
    config.commands.spec = spec
    return config


class HostCommands:
    """One robot's command under a resolved env `commands` config (`quadcos.env.resolve`)."""

    def __init__(self, config: ml_collections.ConfigDict):
        self.config = config
        self.spec = env_commands.validate(config)
        segments = self.spec.schedule or (env_commands.Segment(0.0, 0.0, 1.0),)
        self._velocities = np.array([(s.speed, s.yaw_rate) for s in segments])
        self._ends = np.cumsum([s.seconds for s in segments])[:-1]
        self.velocity, self.heading, self.held = np.zeros(COMMAND_SIZE), 0.0, False
        self.speed = 0.0  # m/s: the observed speed (`env.commands.low_passed_speed`)
        self.gain = 1.0  # the drive's speed gain (`env.commands.corrected_gain`)
        self.correction = 0.0  # rad/s: the drive's heading correction (`env.commands.steering`)
        self.yaw_rate = 0.0  # rad/s: the low-passed yaw rate (`env.commands.Command.yaw_rate`)
        self.tracked_speed = 0.0  # m/s: the forward term's (`env.commands.Command.tracked_speed`)
        self._rng = np.random.default_rng(0)

    def start(self, seed: int | Sequence[int]) -> None:
        """An episode's first command (t = 0), its draws seeded by the reset seed `seed`."""
        self._rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(2)[1])
        self.velocity, self.heading, self.held = self._at(0.0), 0.0, False
        self.speed, self.gain, self.correction, self.yaw_rate = 0.0, 1.0, 0.0, 0.0
        self.tracked_speed = 0.0

    def steer(self, velocity: Sequence[float]) -> None:
        """Follow (v*, ω*) `velocity` from now until the next `start`."""
        self.velocity, self.held = np.asarray(velocity, np.float64), True

    def track(
        self,
        yaw: float,
        yaw_before: float,
        time_before: float,
        time_now: float,
        dt: float,
        moved: float,
    ) -> dict[str, float]:
        """The reward's command arguments for a control step of `dt` s from `time_before` to
        `time_now` (s) in which the yaw went from `yaw_before` to `yaw` (rad) and the robot moved
        `moved` m along its heading at the step's start, as the env's `commands.Plan.step`; then
        the command moves on to the next step's."""
        tau, rate = self.config.observed_speed_tau, self.config.speed_gain_rate
        self.speed = env_commands.low_passed_speed(self.speed, moved, dt, tau)
        self.gain = float(
            env_commands.corrected_gain(self.gain, self.velocity[0], moved, dt, rate, np)
        )
        progress, yaw_rate = self.velocity[0] * dt, self.velocity[1]
        if self.config.tracking == "heading" or self.config.heading_gain > 0:
            leash = self.config.heading_leash
            self.heading = twins.advance_heading(self.heading, yaw_rate, yaw, dt, leash)
        self.correction = float(
            env_commands.steering(self.heading, yaw, self.config.heading_gain, np)
        )
        turn, yaw_tau = twins.wrap_angle(yaw - yaw_before), self.config.yaw_rate_tau
        self.yaw_rate = env_commands.low_passed_speed(self.yaw_rate, turn, dt, yaw_tau)
        tracking = {"heading": self.heading, "commanded_progress": progress}
        if self.config.tracking == "yaw_rate":
            tracking["heading"] = yaw_before
            turned = env_commands.tracked_yaw_rate(self.yaw_rate, turn, dt, yaw_tau)
            tracking["yaw_rate_error"] = turned - yaw_rate
        speed_tau = self.config.speed_tau
        self.tracked_speed = env_commands.low_passed_speed(self.tracked_speed, moved, dt, speed_tau)
        if speed_tau > 0:
            tracking["tracked_progress"] = self.tracked_speed * dt
        if self.held:
            return tracking
        if self.spec.mode != env_commands.RANDOM:
            self.velocity = self._at(time_now)
        else:
            period = self.config.resample_seconds
            if np.floor(time_now / period) > np.floor(time_before / period):
                self.velocity = self._at(time_now)
        return tracking

    def driven(self) -> np.ndarray:
        """(2,) the velocity the drive is asked for: g·(v*, ω* + s) (`env.commands.driven`)."""
        return env_commands.driven(self.velocity, self.gain, np, self.correction)

    def _at(self, time: float) -> np.ndarray:
        """(2,) a fresh draw ("random") or the schedule's segment at `time` (s)."""
        if self.spec.mode == env_commands.RANDOM:
            config = self.config
            speed = self._rng.uniform(config.speed_min, config.speed_max)
            yaw_rate = self._rng.uniform(-config.yaw_rate_max, config.yaw_rate_max)
            straight = self._rng.uniform() < config.zero_yaw_rate_probability
            # (a draw only where standing is asked for: the stream of a config without it)
            standing = config.zero_command_probability and (
                self._rng.uniform() < config.zero_command_probability
            )
            return np.zeros(2) if standing else np.array([speed, 0.0 if straight else yaw_rate])
        return self._velocities[np.searchsorted(self._ends, time, side="right")].copy()
