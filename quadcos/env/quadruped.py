"""The quadruped env: Brax `Env` API over MuJoCo MJX (JAX or Warp physics, see quadcos.backends).

One step (paper Fig. 3): action → (low-pass command filter) → rhythm-controller parameters
(§3.3) → joint targets at every physics substep (Eq. 3) → MJX physics → proprioceptive slope
estimate (Eq. 5) → reward (Eqs. 8–13) and fall check. `controller="joint"` replaces the
oscillator by joint targets straight from the (filtered) action (the "DRL-only" baseline of §5).
The action → joint targets part is `quadcos.env.controller`'s.
"""

import functools
import math
from typing import Any

import jax
import jax.numpy as jnp
import ml_collections
import numpy as np

from quadcos import robot
from quadcos import terrain as terrain_lib
from quadcos._util.quiet import warp_absence_unprinted
from quadcos.env import backends, commands, controller, observation, randomization
from quadcos.env.config import (
    action_size,
    default_config,
    max_progress,
    resolve,
    servo_gains,
    validate_config,
)
from quadcos.env.layout import Layout, blown_up, fallen
from quadcos.equations import oscillator, reward, slope

# The first import of MJX in a quadcos process (brax imports it too).
with warp_absence_unprinted():
    from brax.envs import base
    from mujoco import mjx


class QuadrupedEnv(base.Env):
    """The paper's quadruped on a terrain, as a Brax env. Holds only fixed data.

    Observation (paper §3.3): (v_x, v_y, v_z, pitch, yaw, roll, ξ1..ξ8) — world-frame torso
    velocity (m/s), attitude (rad, pitch nose-up), joint angles (rad, Eq. 3 order); optionally the
    slope estimate and (cos ψ, sin ψ); the filtered action (the controller's command) when
    `action_filter_tau` > 0; the velocity command (v* m/s, ω* rad/s) when `commands.spec` is
    set. Action: [−1, 1]^5 = (A_k, A_h, T, φ1, φ3) for the oscillator controller (then front and
    hind hip offsets with `posture_bound` > 0, then the turn value with a `turn_mode`), [−1, 1]^8
    joint targets (×0.5 rad) for the joint controller.
    """

    def __init__(
        self,
        terrain: terrain_lib.Terrain | str = "flat",
        config: ml_collections.ConfigDict | None = None,
    ):
        config = default_config() if config is None else config
        validate_config(config)
        self.robot = robot.load(config.robot)
        config = resolve(config)
        self.terrain = terrain_lib.get(terrain) if isinstance(terrain, str) else terrain
        self.config = config
        extent = self.terrain.extent
        if extent is not None and config.spawn_x_max > extent[1] - _SPAWN_MARGIN:
            raise ValueError(
                f"spawn_x_max {config.spawn_x_max} m puts robots within {_SPAWN_MARGIN} m of the"
                f" end of terrain {self.terrain.name!r} (x = {extent[1]:g} m)"
            )
        self.mj_model = robot.build_model(
            self.terrain,
            self.robot,
            timestep=config.physics_dt,
            solver_iterations=config.solver_iterations,
            ls_iterations=config.ls_iterations,
            cone=config.cone,
            servo=servo_gains(config),
        )
        self.impl = backends.resolve_impl(config.impl, self.robot.preset.gpu_physics)
        self.randomized = bool(config.randomization.enabled)
        # robots in robustness conditions (`randomization.conditions`), each's index in its info
        self.conditioned = self.randomized and bool(
            randomization.condition_names(config.randomization.conditions)
        )
        self.model = backends.put_model(self.mj_model, self.impl, config.warp)
        # XLA options for the programs that step these envs (read by the trainer).
        self.compiler_options = backends.compiler_options(self.impl, config.warp)
        self.substeps = round(config.control_dt / config.physics_dt)
        self.substep_unroll = min(config.substep_unroll, self.substeps)  # lax.scan's unroll
        tau = config.survival_speed_tau
        self._speed_blend = 1.0 - math.exp(-self.dt / tau) if tau > 0 else 1.0
        self.weights = reward.RewardWeights(**config.reward.to_dict())
        self.commands = commands.Plan(commands.validate(config.commands), config.commands)
        self.action_centre = oscillator.action_centre(config.action_centre, config.period_min)
        # What a searched gait sets, as data a trainer puts in the state (`GAIT_KEY`, `gait`): the
        # action map around the centre and the feed-forward's speed map and half track.
        self.action_map = oscillator.action_map(config.period_min, self.action_centre)
        self.drive_map = commands.drive_map(config.commands) if self.commanded else None
        # the drive late by the latency as the action is (`randomization.delay_drive`)
        self._late_drive = self.randomized and self.commanded and config.commands.feed_forward
        self._late_drive &= bool(config.randomization.delay_drive)
        self.layout = Layout.of(self.robot.description, self.mj_model)
        self._torso_body = self.mj_model.body(self.robot.description.root_body).id

    # --- Brax Env API -------------------------------------------------------------------------

    @functools.cached_property
    def observation_size(self) -> int:
        """The observation's length (`quadcos.env.observation`)."""
        return observation.size(self.config, self.layout, self.action_size, self.commanded)

    @property
    def action_size(self) -> int:
        return action_size(self.config)

    @property
    def backend(self) -> str:
        return "mjx"

    @property
    def dt(self) -> float:
        return self.substeps * self.config.physics_dt

    def reset(self, rng: jax.Array) -> base.State:
        """A standing robot at the spawn point (0, 0) — or at x ~ U(0, `spawn_x_max`) — joints
        perturbed by `reset_joint_noise`; on a lane terrain (`quadcos.courses`), on a random
        lane."""
        lane = jnp.zeros((), jnp.int32)
        if self.terrain.num_lanes > 1:
            rng, rng_lane = jax.random.split(rng)
            lane = jax.random.randint(rng_lane, (), 0, self.terrain.num_lanes)
        return self.reset_on_lane(rng, lane)

    def reset_on_lane(self, rng: jax.Array, lane: jax.Array) -> base.State:
        """`reset` on lane `lane` (its centre line; x ~ U(0, `spawn_x_max`) at most to its end)."""
        x = jnp.zeros(())
        if self.config.spawn_x_max > 0:
            rng, rng_x = jax.random.split(rng)
            end = jnp.asarray(self.terrain.lane_end_x, jnp.float32)[lane]
            x = jax.random.uniform(rng_x, (), maxval=jnp.minimum(self.config.spawn_x_max, end))
        return self.reset_at(rng, x, jnp.asarray(self.terrain.lane_y, jnp.float32)[lane])

    def reset_at(self, rng: jax.Array, x: jax.Array, y: jax.Array) -> base.State:
        """A standing robot at (x, y): feet on the ground, torso pitched with the ground's slope."""
        noise = self.config.reset_joint_noise
        layout = self.layout
        joints = layout.home + jax.random.uniform(
            rng, layout.home.shape, minval=-noise, maxval=noise
        )
        ground_slope = self.terrain.slope_at(x, y)
        # Legs perpendicular to the ground: the torso centre sits the standing height along the
        # normal.
        height = self.terrain.height_at(x, y) + layout.standing_height / jnp.cos(ground_slope)
        nose_up = jnp.array([jnp.cos(ground_slope / 2), 0.0, -jnp.sin(ground_slope / 2), 0.0])
        qpos = jnp.asarray(self.mj_model.qpos0, jnp.float32)
        qpos = qpos.at[layout.position].set(jnp.stack([x, y, height + _SPAWN_CLEARANCE]))
        qpos = qpos.at[layout.quaternion].set(nose_up)
        qpos = qpos.at[layout.joint_qpos].set(joints)
        data = backends.make_data(self.mj_model, self.impl, self.config)
        data = data.replace(qpos=qpos)
        data = data.replace(ctrl=layout.controls(joints, data))
        info = {}
        if self.commanded:
            rng, command_key = jax.random.split(rng)
            info["velocity_command"] = self.commands.start(command_key)
        if self.randomized:
            rng, draw_key = jax.random.split(rng)
            physics = randomization.sample(
                draw_key, self.config.randomization, self.config.physics_dt
            )
            info |= {"physics": physics, "rng": rng, "action": jnp.zeros(self.action_size)}
            if self._late_drive:  # the drive that acts during the first step's latency
                info["driven"] = info["velocity_command"].driven()
            info["fresh_draw"] = jnp.ones((), bool)  # the draw it steps with: `_perturb`
            if self.conditioned:  # which robustness condition the robot takes
                drawn_from = self.config.randomization
                info["condition"] = randomization.condition_index(draw_key, drawn_from)
        data = backends.pose(self._model(info), data)
        phase = jnp.zeros(())
        command = jnp.zeros(self.action_size)
        observed = self._observe(data, phase, command)
        obs, info = self._seen(self._with_command(observed.obs, info), info)
        zero = jnp.zeros(())
        metrics = {f"reward/{name}": zero for name in reward.TERM_NAMES}
        metrics |= {name: zero for name in _STEP_METRICS}
        return base.State(
            pipeline_state=data,
            obs=obs,
            reward=zero,
            done=zero,
            metrics=metrics,
            info={"phase": phase, "command": command, "mean_speed": zero, **info},
        )

    def step(self, state: base.State, action: jax.Array) -> base.State:
        """One control period: `substeps` MJX steps under the controller, then reward and fall;
        with the gait in `state.info[GAIT_KEY]` where a trainer put one there (a searched gait as
        data: its compiled programs serve every gait), else this env's."""
        env = self if GAIT_KEY not in state.info else self.with_gait(state.info[GAIT_KEY])
        return env._step(state, action)

    def _step(self, state: base.State, action: jax.Array) -> base.State:
        before = state.pipeline_state
        # Brax's AutoResetWrapper restores the physics state but not `info`: a robot whose clock
        # reads 0 was just reset, so its oscillator restarts at ψ = 0 and its filter at the
        # action centre as well.
        just_reset = before.time == 0.0
        phase = jnp.where(just_reset, 0.0, state.info["phase"])
        command = jnp.where(just_reset, 0.0, state.info["command"])
        mean_speed = jnp.where(just_reset, 0.0, state.info["mean_speed"])
        info = self._perturb(state.info, just_reset)
        if self.commanded:
            info["velocity_command"] = self.commands.restart(info["velocity_command"], just_reset)
            if self._late_drive:  # a new episode has no earlier drive
                driven = info["velocity_command"].driven()
                info["driven"] = jnp.where(just_reset, driven, info["driven"])
        if self.randomized:
            push = randomization.push_force(info["physics"])
            torso_force = before.xfrc_applied.at[self._torso_body, :3].set(push)
            before = before.replace(xfrc_applied=torso_force)
        previous = command
        data, phase, command = self._actuate(before, phase, command, action, info)
        if self.randomized:
            info["action"] = jnp.clip(action, -1.0, 1.0)
        if self._late_drive:  # the drive this step asked for (`_track` then corrects it)
            info["driven"] = info["velocity_command"].driven()
        observed = self._observe(data, phase, command)
        position = data.qpos[self.layout.position]
        slope_truth = self.terrain.slope_at(position[0], position[1])
        # A step whose physics blew up is a fall with a NaN reward: training resets the env and
        # stores nothing of it, evaluations count it as diverged.
        blew_up = blown_up(data.qpos, data.qvel)
        torso = self._torso_body
        fell = blew_up | fallen(
            self.layout, self.terrain, self.config, data, torso, observed.attitude, slope_truth
        )
        last = before.qpos[self.layout.position]
        moved = position - last
        forward_speed = moved[0] / self.dt
        moving_speed = self._moved_forward(before, moved) / self.dt
        mean_speed = mean_speed + self._speed_blend * (moving_speed - mean_speed)
        tracking, info = self._track(info, observed.attitude.yaw, before, data.time, moved)
        terms = reward.reward_terms(
            x_now=position[0],
            x_last=last[0],
            y_now=position[1],
            y_last=last[1],
            pitch=observed.attitude.pitch,
            yaw=observed.attitude.yaw,
            roll=observed.attitude.roll,
            slope=observed.slope_estimate,
            fell=fell,
            moving=self._moving(mean_speed, tracking),
            weights=self.weights,
            variant=self.config.reward_variant,
            max_progress=max_progress(self.config, self.dt),
            action_change=command - previous if self.weights.action_rate else None,
            **tracking,
        )
        metrics = {f"reward/{name}": value for name, value in terms.items()}
        metrics |= {
            "forward_speed": forward_speed,
            "slope_estimate": observed.slope_estimate,
            "slope_truth": slope_truth,
            "slope_error": jnp.abs(observed.slope_estimate - slope_truth),
            "abs_roll": jnp.abs(observed.attitude.roll),
            "abs_pitch_error": jnp.abs(observed.attitude.pitch - slope_truth),
        }
        obs, info = self._seen(self._with_command(observed.obs, info), info)
        return state.replace(
            pipeline_state=data,
            obs=obs,
            reward=jnp.where(blew_up, jnp.nan, sum(terms.values())),
            done=fell.astype(jnp.float32),
            metrics=metrics,
            info={**info, "phase": phase, "command": command, "mean_speed": mean_speed},
        )

    def action_for(self, params: oscillator.RhythmParameters) -> jax.Array:
        """The (..., action_size) action that commands rhythm parameters `params` in this env (no
        posture offset)."""
        return controller.action_for(self.config, self.action_map, params)

    def rhythm_parameters(self, action: jax.Array) -> oscillator.RhythmParameters:
        """The rhythm parameters (§3.3) that the oscillator controller's `action` sets."""
        return controller.rhythm_parameters(self.config, self.action_map, action)

    def zero_action_targets(self, time: jax.Array) -> jax.Array:
        """(J,) joint targets of a robot that has held the zero action since its reset, at time t
        (s since the episode's start): `controller.zero_action_targets`."""
        return controller.zero_action_targets(self.config, self.layout, self.action_map, time)

    # --- pieces of a step ---------------------------------------------------------------------

    def joint_targets(
        self, action: jax.Array, phase: jax.Array, time: jax.Array, drive: jax.Array | None = None
    ) -> jax.Array:
        """(J,) joint targets (rad) that `action` commands at oscillator phase ψ / time t (s since
        the episode's start), `drive` the command's feed-forward: `controller.joint_targets`."""
        return controller.joint_targets(
            self.config, self.layout, self.action_map, action, phase, time, drive
        )

    def rhythm(
        self, action: jax.Array, phase: jax.Array, time: jax.Array, drive: jax.Array | None = None
    ) -> jax.Array:
        """(8,) Eq. 3's oscillator outputs (rad) that the oscillator controller's `action`
        commands at phase ψ / time t: `controller.rhythm`."""
        return controller.rhythm(self.config, self.action_map, action, phase, time, drive)

    def drive_for(self, velocity: jax.Array) -> jax.Array | None:
        """(..., 2) the left and right hip-swing scales that velocity commands (..., 2) set, or
        None without commands or the feed-forward: `controller.drive_for`."""
        return controller.drive_for(self.config, self.drive_map, velocity)

    def _model(self, info: dict[str, Any]) -> mjx.Model:
        """The MJX model this robot steps: the env's, or with its randomised physics."""
        if not self.randomized:
            return self.model
        return randomization.apply(self.model, info["physics"], self._torso_body)

    def _perturb(self, info: dict[str, Any], just_reset: jax.Array) -> dict[str, Any]:
        """A randomised robot's `info` for this step: `randomization.step_info`."""
        if not self.randomized:
            return dict(info)  # the step writes into it: not into the caller's state
        config = self.config
        return randomization.step_info(info, just_reset, config.randomization, config.physics_dt,
                                       self.dt)  # fmt: skip

    def _seen(self, obs: jax.Array, info: dict[str, Any]) -> tuple[jax.Array, dict[str, Any]]:
        """The observation as the policy sees it: with a randomised robot's observation noise."""
        if not self.randomized:
            return obs, info
        return randomization.seen(obs, info, self.config.randomization)

    def _actuate(
        self,
        data: mjx.Data,
        phase: jax.Array,
        command: jax.Array,
        action: jax.Array,
        info: dict[str, Any],
    ) -> tuple[mjx.Data, jax.Array, jax.Array]:
        """`substeps` physics steps; the command (the filtered action) moves towards `action`
        (towards the previous action for a randomised robot's first `latency_steps`, and with
        `randomization.delay_drive` the drive's scales are the previous step's meanwhile)."""
        dt = self.config.physics_dt
        tau = self.config.action_filter_tau
        blend = 1.0 - math.exp(-dt / tau) if tau > 0 else 1.0
        action = jnp.clip(action, -1.0, 1.0)
        model = self._model(info)
        if self.impl == "warp":
            # MJX-Warp hands every model field to its call, and XLA would sink the constant ones
            # into the substep loop, where each splat one is a broadcast kernel every substep;
            # behind a barrier they are built once a control step (docs/benchmarks.md).
            model = jax.lax.optimization_barrier(model)
        drive = self.drive_for(info["velocity_command"].driven()) if self.commanded else None
        late_drive = self.drive_for(info["driven"]) if self._late_drive else drive
        strength = randomization.strength(info["physics"]) if self.randomized else 1.0

        def substep(carry, index):
            data, phase, command = carry
            target, scales = action, drive
            if self.randomized:  # the previous action acts for the first latency_steps
                late = index < randomization.latency_steps(info["physics"])
                target = jnp.where(late, info["action"], action)
                if self._late_drive:
                    scales = jnp.where(late, late_drive, drive)
            command = command + blend * (target - command)
            targets = self.joint_targets(command, phase, data.time, scales)
            data = data.replace(ctrl=self.layout.controls(targets, data, strength))
            data = backends.step(model, data)
            period = controller.period(self.config, self.action_map, command)
            return (data, oscillator.advance_phase(phase, period, dt), command), period

        (data, phase, command), periods = jax.lax.scan(
            substep,
            (data, phase, command),
            jnp.arange(self.substeps),
            unroll=self.substep_unroll,
        )
        if self.config.oscillator_form == "literal":
            phase = jnp.mod(oscillator.TWO_PI * data.time / periods[-1], oscillator.TWO_PI)
        return data, phase, command

    @property
    def commanded(self) -> bool:
        """Whether the robots follow velocity commands (`commands.spec` set)."""
        return self.commands.spec.enabled

    def with_commands(self, spec: str) -> "QuadrupedEnv":
        """This env (a shallow copy sharing its models) following command spec `spec` ("random"
        or a schedule) instead of its own (`commands.followed`: a ValueError for a bad spec, "",
        or an env without commands)."""
        parsed = commands.followed(spec, self.config.commands)
        config = ml_collections.ConfigDict(self.config.to_dict())
        config.commands.spec = spec
        copy = object.__new__(type(self))
        copy.__dict__.update(self.__dict__)
        copy.config = config
        copy.commands = commands.Plan(parsed, config.commands)
        return copy

    # The config fields `gait` holds: a trainer's programs take them as data (caches.py)
    gait_fields = ("action_centre", "commands.reference_speed", "commands.half_track",
                   "commands.speed_map")

    @property
    def gait(self) -> dict[str, np.ndarray]:
        """What the searched gait sets in this env's programs: its action map (`action_map`,
        (3, 5)) and, with the feed-forward, its drive map (`drive_map`, (5,))."""
        maps = {"action_map": self.action_map, "drive_map": self.drive_map}
        return {name: value for name, value in maps.items() if value is not None}

    def with_gait(self, gait: dict[str, jax.Array]) -> "QuadrupedEnv":
        """This env (a shallow copy sharing its models) with another gait's maps (`gait`'s
        keys; traced where a trainer passes them)."""
        copy = object.__new__(type(self))
        copy.__dict__.update(self.__dict__, **gait)
        return copy

    def with_gait_of(self, env_config: ml_collections.ConfigDict) -> "QuadrupedEnv":
        """This env (a shallow copy sharing its models) as built from its config with the
        `gait_fields` of `env_config` (the gait a search found): that config, action centre and
        maps, and the command plan of its spec read with that config."""
        config = ml_collections.ConfigDict(self.config.to_dict())
        for field in self.gait_fields:
            section, _, name = field.rpartition(".")
            source = env_config[section] if section else env_config
            (config[section] if section else config)[name] = source[name]
        centre = oscillator.action_centre(config.action_centre, config.period_min)
        copy = self.with_gait({
            "action_centre": centre,
            "action_map": oscillator.action_map(config.period_min, centre),
            "drive_map": commands.drive_map(config.commands) if self.commanded else None,
        })  # fmt: skip
        copy.config = config
        copy.commands = commands.Plan(self.commands.spec, config.commands)
        return copy

    def _track(self, info: dict[str, Any], yaw: jax.Array, before: mjx.Data, now: jax.Array,
               moved: jax.Array):
        """The reward's command arguments for a step from state `before` to time `now` (s), at
        whose end the yaw is `yaw` (rad; none without commands: Eqs. 8–13) and the torso has moved
        by `moved` (x, y, z; m), and `info` with the command advanced (`commands.Plan`)."""
        if not self.commanded:
            return {}, info
        yaw_before = slope.attitude(self.layout.orientation(before)).yaw
        progress = moved[0] * jnp.cos(yaw_before) + moved[1] * jnp.sin(yaw_before)
        tracking, following = self.commands.step(
            info["velocity_command"], yaw, yaw_before, self.dt, before.time, now, progress
        )
        return tracking, {**info, "velocity_command": following}

    def _moved_forward(self, before: mjx.Data, moved: jax.Array) -> jax.Array:
        """m: a step's torso displacement `moved` (x, y, z) along x, or with
        `survival_speed_frame` "heading" along the torso's heading in `before`."""
        if self.config.survival_speed_frame == "x":
            return moved[0]
        yaw_before = slope.attitude(self.layout.orientation(before)).yaw
        return reward.along_heading(moved[0], moved[1], yaw_before)[0]

    def _moving(self, mean_speed: jax.Array, tracking: dict[str, jax.Array]) -> jax.Array | bool:
        """Whether a step earns Eq. 9's r_s: every step (survival_min_speed 0), or a step whose
        low-passed forward speed (m/s) reaches survival_min_speed — with commands, or half the
        commanded speed where that is less (a robot asked to stand earns r_s standing)."""
        if self.config.survival_min_speed == 0:
            return True
        threshold = self.config.survival_min_speed
        if tracking:
            threshold = jnp.minimum(threshold, 0.5 * tracking["commanded_progress"] / self.dt)
        return mean_speed >= threshold

    def _observe(
        self, data: mjx.Data, phase: jax.Array, command: jax.Array
    ) -> observation.Observed:
        return observation.observe(self.config, self.layout, data, phase, command)

    def _with_command(self, obs: jax.Array, info: dict[str, Any]) -> jax.Array:
        """The observation with the velocity command last, where there are commands."""
        return observation.with_command(self.config, obs, info) if self.commanded else obs


GAIT_KEY = "gait"  # state.info: the gait's maps (`QuadrupedEnv.gait`) a trainer passes as data
_SPAWN_CLEARANCE = 0.002  # m: feet start just above the ground
_SPAWN_MARGIN = 1.0  # m: the least ground ahead of a random spawn (a robot is 0.8 m long)
# besides the reward's terms; the last two: the body's attitude off the slope
_STEP_METRICS = ("forward_speed", "slope_estimate", "slope_truth", "slope_error", "abs_roll",
                 "abs_pitch_error")  # fmt: skip

