"""The robot stepped in C MuJoCo (`mujoco.mj_step` on an `MjData`), no JAX in the loop: the env's
controller path for sim-to-sim (the mujoco engine of `quadcos.deploy.engines.evaluate`) and
`python -m quadcos.play`.

`HostRobot` steps one robot as `QuadrupedEnv.step` does (command filter, rhythm parameters, phase
and joint targets at every physics step; observation, slope estimate, reward, fall check) with the
NumPy twins of `quadcos.deploy.twins`. A `Pilot` chooses the actions of a `PolicySpec`: a
directory's exported NumPy forward pass (`quadcos.deploy.export`), an exported .npz, an exported
.onnx run with ONNX Runtime, or `fixed:...`, in the env config it was trained with
(`PolicySpec.env_config`). Reset: the env's spawn pose at x = y = 0; episodes differ by their
noise seed.

Two deployment faults, both off by default: observation noise (Gaussian, std `obs_noise`, on each
value the policy sees; the episode's own stream, seeded by its reset seed) and control latency
(`latency_s`, rounded to whole physics steps L: the command filter at physics step t of the
episode moves towards the action computed at the control step that began L physics steps
earlier, zero before the first. For L below a control step this is the MJX env's randomised
`latency_steps`: the previous action for the first L substeps of each control step, then the
new one; a latency of one control step acts each action one step late; with the env's
`randomization.delay_drive` the drive's scales are as late as the action, as in the env).

The constraint solver: `physics="reference"` (the default) runs the MJCF's own solver iterations
(MuJoCo's default: 100 Newton iterations, 50 line-search) at the training step, cone and
contacts: the converged physics a policy has to transfer to. `physics="training"` runs the
iterations the env trained with (the robot preset's shortcut, e.g. Go1's 4 / 8): C MuJoCo's solver
stopped that early is not MJX-Warp's and can blow up under a fast gait (experiments/robots). For
the paper's robot, whose preset keeps the MJCF's iterations, the two are the same. `physics="N/M"`
runs N solver and M line-search iterations (the same step, cone and contacts), to find where the
solver a policy trained with stops transferring.
"""

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NamedTuple

import ml_collections
import mujoco
import numpy as np

from quadcos import env as env_lib
from quadcos import robot
from quadcos import terrain as terrain_lib
from quadcos.deploy import export, host_commands, solver, twins
from quadcos.deploy.numpy_policy import NumpyPolicy
from quadcos.deploy.onnx_policy import OnnxPolicy
from quadcos.env import commands as env_commands
from quadcos.env.layout import Layout, blown_up
from quadcos.equations import oscillator, reward, slope
from quadcos.evaluation import sources

_CORNER_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])


@dataclasses.dataclass(frozen=True)
class Pilot:
    """What chooses actions in C MuJoCo: the policy of a `PolicySpec` as NumPy (a directory or
    an exported .npz) or ONNX Runtime (an exported .onnx), None for fixed parameters and a gait
    (`gait:DIR`, the zero action), and the env config it runs in (`PolicySpec.env_config`)."""

    spec: sources.PolicySpec
    config: ml_collections.ConfigDict
    policy: NumpyPolicy | OnnxPolicy | None = None

    @classmethod
    def load(
        cls, spec: sources.PolicySpec | str, env_overrides: Mapping[str, Any] | None = None
    ) -> "Pilot":
        """The pilot of `spec` (a --policy string is parsed) in its env config with
        `env_overrides` (e.g. {"robot": ...} for fixed parameters; a trained policy drives its
        own robot).

        Raises:
          FileNotFoundError, ValueError: no policy there, a file that is not a quadcos policy,
            or an env config this quadcos cannot build.
        """
        spec = sources.PolicySpec.parse(spec) if isinstance(spec, str) else spec
        config = spec.env_config(env_overrides)
        if spec.kind in ("fixed", "gait"):
            return cls(spec, config)
        policy = OnnxPolicy.load(spec.path) if spec.kind == "onnx" else export.numpy_policy(spec)
        return cls(spec, config, policy)

    @property
    def name(self) -> str:
        """The --policy string."""
        return self.spec.text

    def actor(self) -> Callable[[np.ndarray], np.ndarray]:
        """obs -> (action_size,) action; fixed parameters: the constant action commanding them;
        a gait: the zero action (the action centre)."""
        if self.policy is not None:
            return self.policy
        if self.spec.kind == "gait":
            zeros = np.zeros(env_lib.action_size(self.config))
            return lambda obs: zeros
        centre = oscillator.action_centre(self.config.action_centre, self.config.period_min)
        action = np.asarray(
            oscillator.parameters_to_action(
                self.spec.fixed_parameters,
                self.config.period_min,
                centre,
                env_lib.rhythm_scales(self.config),
            ),
            np.float64,
        )
        action = np.pad(action, (0, env_lib.action_size(self.config) - action.size))
        return lambda obs: action


class StepResult(NamedTuple):
    """What one control step yields (the env's obs, metrics and done, for one robot)."""

    obs: np.ndarray
    body: slope.Attitude  # from the IMU
    slope_estimate: float  # rad, Eq. 5
    slope_truth: float  # rad, the ground under the torso
    forward_speed: float  # m/s over the step
    reward_terms: dict[str, float]
    fell: bool


class HostRobot:
    """One robot on a terrain in C MuJoCo under the env's controller path (`QuadrupedEnv.step`);
    `latency_s`: the control latency, s; `physics`: "reference", "training" or "N/M" solver
    iterations (module docstring); `commands`: a command spec followed instead of the config's
    own (`quadcos.deploy.host_commands`; None: the config's); `friction` > 0: every geom's
    sliding friction, as the env's randomisation draws one (0: the MJCF's).

    Raises:
      ValueError: a latency or friction that is negative or not finite, an unknown `physics`, or
        commands for a config without them.
    """

    def __init__(
        self,
        terrain: terrain_lib.Terrain | str,
        config: ml_collections.ConfigDict,
        latency_s: float = 0.0,
        physics: str = "reference",
        commands: str | None = None,
        friction: float = 0.0,
    ):
        if not (math.isfinite(latency_s) and latency_s >= 0):
            raise ValueError(f"the latency must be >= 0 s and finite; got {latency_s}")
        if not (math.isfinite(friction) and friction >= 0):
            raise ValueError(f"the friction must be >= 0 and finite; got {friction}")
        self.terrain = terrain_lib.get(terrain) if isinstance(terrain, str) else terrain
        self.robot = robot.load(config.robot)
        config = host_commands.follow(env_lib.resolve(config), commands)
        self.config = config
        commanded = env_commands.parse_commands(config.commands.spec).enabled
        self.commands = host_commands.HostCommands(config.commands) if commanded else None
        iterations, ls_iterations = solver.iterations(physics, config)
        self.model = robot.build_model(
            self.terrain,
            self.robot,
            timestep=config.physics_dt,
            solver_iterations=iterations,
            ls_iterations=ls_iterations,
            servo=env_lib.servo_gains(config),
        )
        if friction > 0:
            self.model.geom_friction[:, 0] = friction
        self.physics = {
            "solver": physics,
            "timestep": float(self.model.opt.timestep),
            "iterations": int(self.model.opt.iterations),
            "ls_iterations": int(self.model.opt.ls_iterations),
            "cone": "elliptic"
            if self.model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
            else "pyramidal",
            "friction": friction or None,
        }
        self.layout = Layout.of(self.robot.description, self.model, xp=np)
        self.data = mujoco.MjData(self.model)
        self.substeps = round(config.control_dt / config.physics_dt)
        self.dt = self.substeps * config.physics_dt
        self.latency_s = latency_s
        self.latency_steps = round(latency_s / config.physics_dt)  # physics steps
        self._queue_length = -(-self.latency_steps // self.substeps)  # earlier actions still due
        tau = config.action_filter_tau
        self._blend = 1.0 - math.exp(-config.physics_dt / tau) if tau > 0 else 1.0
        speed_tau = config.survival_speed_tau
        self._speed_blend = 1.0 - math.exp(-self.dt / speed_tau) if speed_tau > 0 else 1.0
        self.action_size = env_lib.action_size(config)
        self.action_centre = oscillator.action_centre(config.action_centre, config.period_min)
        self._rhythm_scales = env_lib.rhythm_scales(config)
        self.weights = reward.RewardWeights(**config.reward.to_dict())
        self._torso = self.model.body(self.robot.description.root_body).id
        self.phase, self.command, self.mean_speed = 0.0, np.zeros(self.action_size), 0.0
        self._pending = [np.zeros(self.action_size)] * self._queue_length
        # the drive as late as the action (the env's `randomization.delay_drive`)
        self._late_drive = self.commands is not None and config.commands.feed_forward
        self._late_drive &= bool(config.randomization.delay_drive)

    def reset(self, seed: int | Sequence[int], x: float = 0.0, y: float = 0.0) -> np.ndarray:
        """`QuadrupedEnv.reset_at`: standing at (x, y), pitched with the ground, joints perturbed
        by U(±reset_joint_noise) from `np.random.default_rng(seed)`. Returns the observation."""
        noise, layout = self.config.reset_joint_noise, self.layout
        joints = layout.home + np.random.default_rng(seed).uniform(-noise, noise, layout.home.size)
        ground_slope = float(twins.slope_at(self.terrain, x, y))
        height = twins.height_at(self.terrain, x, y) + layout.standing_height / math.cos(
            ground_slope
        )
        mujoco.mj_resetData(self.model, self.data)
        qpos = self.data.qpos
        qpos[layout.position] = x, y, height + env_lib._SPAWN_CLEARANCE  # noqa: SLF001
        half = ground_slope / 2
        qpos[layout.quaternion] = math.cos(half), 0.0, -math.sin(half), 0.0
        qpos[layout.joint_qpos] = joints
        self.data.ctrl[:] = layout.controls(joints, self.data)
        mujoco.mj_forward(self.model, self.data)
        self.phase, self.command, self.mean_speed = 0.0, np.zeros(self.action_size), 0.0
        self._pending = [np.zeros(self.action_size)] * self._queue_length
        if self.commands is not None:
            self.commands.start(seed)
            self._pending_driven = [self.commands.driven()] * self._queue_length
        return self._observe()[0]

    def rhythm_parameters(self) -> oscillator.RhythmParameters | None:
        """The parameters the current command sets (None for the joint controller)."""
        if self.config.controller != "oscillator":
            return None
        return twins.action_to_parameters(
            self.command[: oscillator.RHYTHM_SIZE],
            self.config.period_min,
            self.action_centre,
            self._rhythm_scales,
        )

    def step(self, action: np.ndarray) -> StepResult:
        """One control period: `substeps` mj_steps under the controller (the command filter
        moving towards the action due after the latency), then observe, reward and check for a
        fall."""
        x_last, y_last, _ = self.data.qpos[self.layout.position]
        time_before = self.data.time
        yaw_before = twins.attitude(self.layout.orientation(self.data)).yaw
        actions = [*self._pending, np.clip(np.asarray(action, np.float64), -1.0, 1.0)]
        late = [*self._pending_driven, self.commands.driven()] if self._late_drive else None
        previous = self.command
        period = oscillator.FIXED_TROT.period
        for index in range(self.substeps):
            due = self._queue_length + (index - self.latency_steps) // self.substeps
            self.command = self.command + self._blend * (actions[due] - self.command)
            params = self.rhythm_parameters()
            targets = self._joint_targets(params, late[due] if late else None)
            self.data.ctrl[:] = self.layout.controls(targets, self.data)
            mujoco.mj_step(self.model, self.data)
            period = period if params is None else params.period
            self.phase = twins.advance_phase(self.phase, period, self.config.physics_dt)
        self._pending = actions[len(actions) - self._queue_length :]
        if late:
            self._pending_driven = late[len(late) - self._queue_length :]
        if self.config.oscillator_form == "literal":
            self.phase = math.fmod(oscillator.TWO_PI * self.data.time / period, oscillator.TWO_PI)
        tracking = {}
        x, y, _ = self.data.qpos[self.layout.position]
        # m along the heading at the step's start (the env's _track and _moved_forward)
        along = (x - x_last) * math.cos(yaw_before) + (y - y_last) * math.sin(yaw_before)
        if self.commands is not None:  # the env's _track: before the observation that shows it
            yaw = twins.attitude(self.layout.orientation(self.data)).yaw
            tracking = self.commands.track(
                yaw, yaw_before, time_before, self.data.time, self.dt, along
            )
        obs, body, slope_estimate = self._observe()
        slope_truth = float(twins.slope_at(self.terrain, x, y))
        fell = bool(blown_up(self.data.qpos, self.data.qvel, np)) or self._fell(body, slope_truth)
        forward_speed = (x - x_last) / self.dt
        moving_speed = forward_speed  # QuadrupedEnv._moved_forward
        if self.config.survival_speed_frame == "heading":
            moving_speed = along / self.dt
        self.mean_speed += self._speed_blend * (moving_speed - self.mean_speed)
        terms = twins.reward_terms(
            x_now=x,
            x_last=x_last,
            y_now=y,
            y_last=y_last,
            body=body,
            slope_estimate=slope_estimate,
            fell=fell,
            moving=self._moving(self.mean_speed, tracking),
            weights=self.weights,
            variant=self.config.reward_variant,
            max_progress=env_lib.max_progress(self.config, self.dt),
            action_change=self.command - previous if self.weights.action_rate else None,
            **tracking,
        )
        return StepResult(obs, body, slope_estimate, slope_truth, forward_speed, terms, fell)

    def _moving(self, mean_speed: float, tracking: dict[str, float]) -> bool:
        """`QuadrupedEnv._moving`: whether the step earns Eq. 9's r_s."""
        min_speed = self.config.survival_min_speed
        if min_speed == 0:
            return True
        if tracking:
            min_speed = min(min_speed, 0.5 * tracking["commanded_progress"] / self.dt)
        return mean_speed >= min_speed

    def _joint_targets(
        self, params: oscillator.RhythmParameters | None, driven: np.ndarray | None = None
    ) -> np.ndarray:
        """`QuadrupedEnv.joint_targets` of the current command and phase; the drive asked for
        `driven` (v, ω) where given, else the commands' current."""
        if params is None:
            return self.layout.home + env_lib.JOINT_TARGET_BOUND * np.clip(self.command, -1.0, 1.0)
        phase = self.phase
        if self.config.oscillator_form == "literal":
            phase = oscillator.TWO_PI * self.data.time / params.period
        config, posture = self.config, oscillator.RHYTHM_SIZE
        turn = self.command[posture + oscillator.POSTURE_SIZE * (config.posture_bound > 0) :]
        phases = twins.trot_phases(params.phi1, params.phi3)
        swing = twins.rhythm_at_phase(phase, params.amplitude_hip, params.amplitude_knee, phases)
        if config.turn_mode == "hip_amplitude_difference":
            swing = twins.hip_amplitude_difference(swing, turn[0], config.turn_bound)
        if self.commands is not None and config.commands.feed_forward:
            drive = config.commands
            scales = twins.drive_scales(
                self.commands.driven() if driven is None else driven,
                env_commands.speed_map(drive),
                drive.half_track,
                drive.scale_max,
                drive.turn_max,
            )
            swing = twins.side_scaled(swing, scales)
        ramp = twins.start_ramp(self.data.time, config.start_ramp_s)
        targets = swing
        if config.posture_bound > 0:
            offsets = self.command[posture : posture + oscillator.POSTURE_SIZE]
            targets = targets + twins.posture_offsets(offsets, config.posture_bound)
        targets = self.layout.rhythm_targets(targets * ramp)
        if config.turn_mode == "abduction_stride":
            abduction = twins.abduction_stride(swing * ramp, turn[0], config.turn_bound)
            targets = targets + self.layout.abduction_targets(abduction)
        return targets

    def _observe(self) -> tuple[np.ndarray, slope.Attitude, float]:
        """`QuadrupedEnv._observe`: (obs, attitude, slope estimate)."""
        layout = self.layout
        quaternion = layout.orientation(self.data)
        body = twins.attitude(quaternion)
        joints = self.data.qpos[layout.joint_qpos]
        slope_estimate = twins.estimate_slope(layout.foot_positions(self.data), quaternion)
        parts = [self.data.qvel[layout.linear_velocity], [body.pitch, body.yaw, body.roll], joints]
        if self.config.observe_slope:
            parts.append([slope_estimate])
        if self.config.observe_phase:
            parts.append([math.cos(self.phase), math.sin(self.phase)])
        if self.config.action_filter_tau > 0:
            parts.append(self.command)
        if self.config.observe_angular_velocity:
            parts.append(self.data.qvel[layout.angular_velocity])
        if self.commands is not None:
            commands = self.commands
            if self.config.commands.observed_speed_tau > 0:
                parts.append([commands.speed])
            if self.config.commands.observe_drive:
                parts.append([commands.gain, commands.correction, commands.yaw_rate])
            parts.append(commands.velocity)
        return np.concatenate(parts), body, slope_estimate

    def _fell(self, body: slope.Attitude, slope_truth: float) -> bool:
        """`env.layout.fallen`'s twin: torso too low, attitude beyond limits, or a torso corner
        below the ground."""
        layout = self.layout
        x, y, z = self.data.qpos[layout.position]
        config = self.config
        rotation = self.data.xmat[self._torso].reshape(3, 3)
        box = layout.torso_centre + _CORNER_SIGNS * layout.torso_half_size
        corners = self.data.xpos[self._torso] + box @ rotation.T
        ground = twins.height_at(self.terrain, corners[:, 0], corners[:, 1])
        return bool(
            z - twins.height_at(self.terrain, x, y) < config.fall_min_height
            or abs(body.roll) > config.fall_max_roll
            or abs(body.pitch - slope_truth) > config.fall_max_pitch_error
            or (corners[:, 2] - ground).min() < 0.0
        )
