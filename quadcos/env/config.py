"""The env's config: its fields with their defaults and meanings, and what it may hold.

`quadcos.env` re-exports all of it; `QuadrupedEnv` validates its config here.
"""

import math

import ml_collections
import numpy as np

from quadcos import robot as robot_lib
from quadcos.env import backends, commands, randomization
from quadcos.equations import oscillator, reward

CONTROLLERS = ("oscillator", "joint")
OSCILLATOR_FORMS = ("phase", "literal")
# `survival_speed_frame`: "x", the world's x axis (the paper's course direction), or "heading", the
# torso's heading at each step's start (a turning robot's progress; with velocity commands the way
# the forward term measures too).
SURVIVAL_FRAMES = ("x", "heading")
_POSTURE_BOUND_MAX = 0.7  # rad: a hip offset plus §3.3's hip swing (≤ 0.5) stays in ±1.2 rad


def default_config() -> ml_collections.ConfigDict:
    """A fresh env config; every field is overridable by `make_env(**overrides)`."""
    config = ml_collections.ConfigDict()
    config.terrain = "flat"  # name or spec string, see quadcos.terrain.parse
    # The quadruped: "quadcos" (the paper's), "quad12" (our 12-joint test robot), an MJCF path,
    # "menagerie:NAME" (MuJoCo Menagerie) or a name registered with quadcos.robot.register.
    config.robot = "quadcos"
    # MJX implementation: "auto" = Warp on a CUDA GPU with warp-lang installed, else "jax".
    config.impl = "auto"
    config.warp = backends.default_warp_config()
    # s: one env step = one SAC action (20 Hz; CoppeliaSim's default 50 ms step, the paper's
    # simulator). The paper's r_s = 10, r_y = w1 Δy favour walking over standing only when Δy
    # matters in a step: at 50 Hz a trot scores less per step than standing (experiments/README.md).
    config.control_dt = 0.05
    # s: MJX step, control_dt a multiple; 0 = the robot's (quadcos.robot.presets; ours 0.005 s).
    config.physics_dt = 0.0
    # jax.lax.scan's unroll factor of the physics steps in a control step: 1 runs them as a loop
    # (XLA's while loop on a GPU), control_dt / physics_dt as straight-line code.
    config.substep_unroll = 1
    config.solver_iterations = 0  # 0 = the robot's preset's, else the MJCF's
    config.ls_iterations = 0  # 0 = the robot's preset's, else the MJCF's
    # Friction cones, "pyramidal" or "elliptic"; "" = the robot preset's, else the MJCF's.
    config.cone = ""
    # A robot without a preset (quadcos.robot.presets): a training run measures the cheapest
    # stable physics_dt, iterations and cone (quadcos.env.solver_probe) where all four above are
    # left to the robot; False keeps its MJCF's.
    config.solver_probe = True
    # N m/rad, N m s/rad: > 0 gives every position servo this gain and servo_kd this damping (the
    # rhythm is open loop: a soft servo sags and lags it); servo_kp 0 keeps the MJCF's servos.
    config.servo_kp = 0.0
    config.servo_kd = 0.0
    config.controller = "oscillator"  # "oscillator" (paper) or "joint" (DRL-only baseline)
    # "phase" integrates ψ += 2π dt/T every physics step (continuous when T changes); "literal"
    # evaluates Eq. 3 at 2πt/T. Equal while T is constant; see quadcos.oscillator.
    config.oscillator_form = "phase"
    config.period_min = oscillator.PERIOD_MIN  # s: lower end of T's range (0, 2]
    # What the zero action means: "trot" = oscillator.FIXED_TROT (a fresh policy starts from a
    # walking gait; all of §3.3's ranges stay reachable), "midpoint" = the middle of each range
    # (a plain linear map: the zero action stands still). See oscillator.action_to_parameters.
    config.action_centre = "trot"
    # The share of each rhythm range the policy reaches around the centre (1: every bound of
    # §3.3, the paper; 0.3: 30 % of the way to each bound, a residual on a searched gait).
    config.action_scale = 1.0
    # §3.3's parameters held at the centre, e.g. "period,phi1,phi3" ("": none): rhythm_scales.
    config.held_rhythm = ""
    # rad: > 0 adds two action values, front and hind hip offsets of up to ± this (a posture
    # beyond §3.3's rhythm, for leaning back on steep descents: oscillator.posture_offsets);
    # 0 = the paper's five-value action.
    config.posture_bound = 0.0
    # Turning (beyond §3.3): "none" (the paper), or one more action value u ∈ [−1, 1] that makes
    # the rhythm asymmetric: "hip_amplitude_difference" (right hips' swing × (1 + turn_bound·u),
    # left × (1 − turn_bound·u)) or "abduction_stride" (12-joint robots: each leg's abduction
    # follows its hip swing × ±turn_bound·u, rotating the strides). oscillator.TURN_MODES.
    config.turn_mode = "none"
    config.turn_bound = 0.5  # the largest share (amplitude difference, stride rotation) u reaches
    # Velocity commands (v*, ω*) the policy observes and the reward tracks; off ("") by default:
    # quadcos.env.commands.
    config.commands = commands.default_config()
    config.reward_variant = "full"  # "full" (Eq. 13) or "xy" (Fig. 9's r_xy)
    # m/s: Eq. 9 pays r_s "for every step of movement". 0 reads that as every control step
    # alive, standing still included; > 0 pays r_s only on steps whose forward speed reaches
    # this, so that standing earns nothing and walking is the only way to score (see
    # experiments/from_scratch: with 0, standing still is a strong optimum of Eq. 13).
    config.survival_min_speed = 0.0
    # s: "moving" is judged on the forward speed low-pass filtered with this time constant, so
    # that rocking back and forth (forward half the time, no progress) does not count.
    config.survival_speed_tau = 1.0
    config.survival_speed_frame = "x"  # along what "moving" is measured: SURVIVAL_FRAMES
    # m/s: > 0 caps the speed Eq. 10's r_y pays for (faster steps earn no more progress reward),
    # so that a policy does not trade falls for speed; 0 = the paper's uncapped r_y.
    config.forward_speed_cap = 0.0
    config.reward = ml_collections.ConfigDict(reward.RewardWeights()._asdict())
    config.observe_slope = False  # append the slope estimate to the paper's 14-d state
    config.observe_phase = False  # append (cos ψ, sin ψ) of the oscillator
    config.observe_angular_velocity = False  # append the torso's gyro (rad/s, its own frame)
    # s: time constant of a first-order low-pass filter between the action and the controller,
    # run at every physics substep; 0 = the paper's literal, instantaneous parameter change.
    # A trot topples under per-step action noise of std 0.06 (79 % of robots in 10 s) but not
    # behind a 0.25-s filter (2 %) — SAC explores with such noise (experiments/noise_tolerance). When
    # > 0 the filtered action is appended to the observation (it is part of the state).
    config.action_filter_tau = 0.25
    # s: > 0 lets the rhythm (hip offsets included) in linearly over an episode's first seconds
    # (oscillator.start_ramp), so that a robot steps off from standing gently; 0 = the paper's
    # full rhythm from the first step. The oscillator controller only.
    config.start_ramp_s = 0.0
    config.reset_joint_noise = 0.02  # rad: uniform noise on the initial joint angles
    # m: reset spawns each robot at x ~ U(0, spawn_x_max) (y = 0) instead of the spawn point, so
    # that training sees a whole course, not only what its robots reach within an episode.
    # Training's auto-reset returns each env to its own first spawn. Evaluation always starts at
    # the spawn point (quadcos.evaluate sets 0).
    config.spawn_x_max = 0.0
    # m: the torso centre above the ground below it; 0 = the robot's (the paper's robot 0.35 m of
    # its 0.67 m standing height; others the same fraction of theirs).
    config.fall_min_height = 0.0
    config.fall_max_roll = 0.8  # rad
    config.fall_max_pitch_error = 0.8  # rad: |pitch − true slope|
    # Domain randomisation (friction, torso mass and CoM, servo gain, damping, motor strength,
    # latency, pushes), off by default: quadcos.randomization.
    config.randomization = randomization.default_config()
    return config


def max_progress(config: ml_collections.ConfigDict, dt: float) -> float:
    """m of forward progress per control step that r_y pays for (`forward_speed_cap`)."""
    return config.forward_speed_cap * dt if config.forward_speed_cap > 0 else math.inf


def resolve(config: ml_collections.ConfigDict) -> ml_collections.ConfigDict:
    """A copy of `config` with the values that 0 leaves to the robot filled in from it.

    Raises:
      FileNotFoundError, ValueError: the robot cannot be loaded (see quadcos.robot.load).
    """
    robot = robot_lib.load(config.robot)
    resolved = ml_collections.ConfigDict(config.to_dict())
    if not resolved.physics_dt:
        resolved.physics_dt = robot.preset.physics_dt
    if not resolved.fall_min_height:
        resolved.fall_min_height = robot.fall_min_height
    if not resolved.solver_iterations:
        resolved.solver_iterations = robot.preset.solver_iterations
    if not resolved.ls_iterations:
        resolved.ls_iterations = robot.preset.ls_iterations
    if not resolved.cone:
        resolved.cone = robot.preset.cone
    if not resolved.warp.hfield_contacts:
        resolved.warp.hfield_contacts = robot.preset.hfield_contacts
    if not resolved.commands.speed_max:
        resolved.commands.speed_max = commands.speed_range(
            robot.preset.command_speed_max, robot.description.standing_height
        )
    if not resolved.commands.yaw_rate_max:
        resolved.commands.yaw_rate_max = commands.yaw_rate_range(
            robot.preset.command_yaw_rate_max, resolved.commands.speed_max
        )
    if not resolved.commands.reference_speed:
        resolved.commands.reference_speed = resolved.commands.speed_max
    if not resolved.commands.half_track:
        hips = [abs(leg.hip_position[1]) for leg in robot.description.legs]
        resolved.commands.half_track = round(sum(hips) / len(hips), 4)
    return resolved


def servo_gains(config: ml_collections.ConfigDict) -> tuple[float, float] | None:
    """(kp, kd) for the robot's position servos (`robot.build_model`), None for the MJCF's."""
    return (float(config.servo_kp), float(config.servo_kd)) if config.servo_kp > 0 else None


def action_size(config: ml_collections.ConfigDict) -> int:
    """Values in an action of an env with this config."""
    if config.controller == "joint":
        return len(robot_lib.load(config.robot).description.joint_names)
    posture = oscillator.POSTURE_SIZE if config.posture_bound > 0 else 0
    turn = oscillator.TURN_SIZE if config.turn_mode != "none" else 0
    return oscillator.RHYTHM_SIZE + posture + turn


def rhythm_scales(config: ml_collections.ConfigDict) -> np.ndarray:
    """(5,) the share of each rhythm parameter's range the policy reaches around the centre:
    `action_scale`, 0 for the parameters `held_rhythm` names.

    Raises:
      ValueError: naming a held parameter that §3.3's action does not set.
    """
    held = [name.strip() for name in str(config.held_rhythm).split(",") if name.strip()]
    names = oscillator.RhythmParameters._fields
    for name in held:
        if name not in names:
            raise ValueError(f"held_rhythm names {name!r}; known: {', '.join(names)}")
    return np.array([0.0 if name in held else config.action_scale for name in names])


def validate_config(config: ml_collections.ConfigDict) -> None:
    """Raises ValueError naming the first env config value the env cannot run with (and
    FileNotFoundError for a robot MJCF that does not exist)."""
    if not isinstance(config.robot, str) or not config.robot:
        raise ValueError(f"robot must be a robot spec string; got {config.robot!r}")
    config = resolve(config)
    if config.impl not in backends.IMPLS:
        raise ValueError(f"unknown impl {config.impl!r}; known: {', '.join(backends.IMPLS)}")
    _validate_warp(config.warp)
    if config.cone not in ("", *robot_lib.prepare.CONES):
        raise ValueError(
            f"unknown cone {config.cone!r}; known: {', '.join(robot_lib.prepare.CONES)}"
        )
    if not (isinstance(config.substep_unroll, int) and config.substep_unroll >= 1):
        raise ValueError(
            f"substep_unroll must be a whole number >= 1; got {config.substep_unroll!r}"
        )
    if config.controller not in CONTROLLERS:
        raise ValueError(
            f"unknown controller {config.controller!r}; known: {', '.join(CONTROLLERS)}"
        )
    if config.oscillator_form not in OSCILLATOR_FORMS:
        raise ValueError(
            f"unknown oscillator_form {config.oscillator_form!r}; known: {', '.join(OSCILLATOR_FORMS)}"
        )
    if config.action_centre != oscillator.SEARCH_CENTRE:
        oscillator.action_centre(config.action_centre, config.period_min)
    randomization.validate(config.randomization)
    if config.reward_variant not in reward.VARIANTS:
        raise ValueError(
            f"unknown reward_variant {config.reward_variant!r}; known: {', '.join(reward.VARIANTS)}"
        )
    if not (0 < config.physics_dt < math.inf and 0 < config.control_dt < math.inf):  # resolved
        raise ValueError(
            f"control_dt and physics_dt must be finite and > 0; got {config.control_dt}, {config.physics_dt}"
        )
    ratio = config.control_dt / config.physics_dt
    if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
        raise ValueError(
            f"control_dt {config.control_dt} must be a whole multiple of physics_dt {config.physics_dt}"
        )
    latency_max = float(config.randomization.latency_s[1])
    # An action acts for one control step at most (quadcos.env.randomization).
    if config.randomization.enabled and latency_max > config.control_dt + 1e-9:
        raise ValueError(
            f"randomization.latency_s reaches {latency_max} s, beyond control_dt "
            f"{config.control_dt} s: an action is late by at most one control step"
        )
    if not 0.0 < config.action_scale <= 1.0:
        raise ValueError(f"action_scale must be in (0, 1]; got {config.action_scale}")
    rhythm_scales(config)
    _validate_servo(config)
    if not config.action_filter_tau >= 0:
        raise ValueError(f"action_filter_tau must be >= 0 s; got {config.action_filter_tau}")
    if not 0.0 <= config.start_ramp_s < math.inf:
        raise ValueError(f"start_ramp_s must be finite and >= 0 s; got {config.start_ramp_s}")
    if not 0.0 <= config.survival_min_speed < math.inf:
        raise ValueError(
            f"survival_min_speed must be finite and >= 0 m/s; got {config.survival_min_speed}"
        )
    if not 0.0 <= config.forward_speed_cap < math.inf:
        raise ValueError(
            f"forward_speed_cap must be finite and >= 0 m/s; got {config.forward_speed_cap}"
        )
    if config.survival_speed_frame not in SURVIVAL_FRAMES:
        raise ValueError(
            f"survival_speed_frame must be one of {', '.join(SURVIVAL_FRAMES)}; got"
            f" {config.survival_speed_frame!r}"
        )
    if not 0.0 <= config.survival_speed_tau < math.inf:
        raise ValueError(
            f"survival_speed_tau must be finite and >= 0 s; got {config.survival_speed_tau}"
        )
    if not 0.0 <= config.spawn_x_max < math.inf:
        raise ValueError(f"spawn_x_max must be finite and >= 0 m; got {config.spawn_x_max}")
    if not 0.0 <= config.posture_bound <= _POSTURE_BOUND_MAX:
        raise ValueError(
            f"posture_bound must be in [0, {_POSTURE_BOUND_MAX}] rad; got {config.posture_bound}"
        )
    if config.start_ramp_s > 0 and config.controller != "oscillator":
        raise ValueError("start_ramp_s > 0 needs controller='oscillator' (it ramps the rhythm in)")
    if config.posture_bound > 0 and config.controller != "oscillator":
        raise ValueError("posture_bound > 0 needs controller='oscillator' (it offsets the rhythm)")
    commands.validate(config.commands)
    _validate_turn(config)
    if not 0.0 < config.period_min <= oscillator.PERIOD_MAX:
        raise ValueError(
            f"period_min must be in (0, {oscillator.PERIOD_MAX}]; got {config.period_min}"
        )


def _validate_servo(config: ml_collections.ConfigDict) -> None:
    """Raises ValueError for servo gains out of range or for a robot without position servos."""
    for key in ("servo_kp", "servo_kd"):
        if not 0.0 <= config[key] < math.inf:
            raise ValueError(f"{key} must be finite and >= 0; got {config[key]}")
    if config.servo_kd > 0 and not config.servo_kp > 0:
        raise ValueError(
            f"servo_kd {config.servo_kd} needs servo_kp > 0 (0 keeps the MJCF's servos as they are)"
        )
    if config.servo_kp > 0:
        robot = robot_lib.load(config.robot)
        if robot.description.actuator_kind != "position":
            raise ValueError(
                f"servo_kp {config.servo_kp} applies to position servos; robot {config.robot} drives"
                " torque motors (its PD gains: the robot preset's kp, kd)"
            )


def _validate_warp(warp: ml_collections.ConfigDict) -> None:
    """Raises ValueError naming the first `warp.*` value MJX-Warp cannot run with."""
    for key, least in (
        ("max_envs", 1),
        ("contacts_per_env", 1),
        ("constraints_per_env", 0),
        ("hfield_contacts", 1),
    ):
        value = warp[key]
        if not (isinstance(value, int) and value >= least):
            raise ValueError(f"warp.{key} must be a whole number >= {least}; got {value!r}")
    if warp.max_envs * warp.contacts_per_env >= 2**31:  # Warp indexes with int32
        raise ValueError(
            "warp.max_envs × warp.contacts_per_env must be < 2**31; got"
            f" {warp.max_envs} × {warp.contacts_per_env}"
        )
    if warp.graph_mode not in backends.GRAPH_MODES:
        raise ValueError(
            f"unknown warp.graph_mode {warp.graph_mode!r};"
            f" known: {', '.join(backends.GRAPH_MODES)}"
        )
    if warp.graph_mode == "jax" and warp.graph_conditional:
        raise ValueError(
            "warp.graph_mode 'jax' needs warp.graph_conditional=false: XLA records a Warp call"
            " as a child graph, which cannot hold the solver's conditional node"
        )


def _validate_turn(config: ml_collections.ConfigDict) -> None:
    """Raises ValueError for a `turn_mode` / `turn_bound` the controller and robot cannot run."""
    if config.turn_mode not in oscillator.TURN_MODES:
        raise ValueError(
            f"unknown turn_mode {config.turn_mode!r}; known: {', '.join(oscillator.TURN_MODES)}"
        )
    if config.turn_mode != "none" and config.controller != "oscillator":
        raise ValueError(f"turn_mode {config.turn_mode!r} needs controller='oscillator'")
    if config.commands.feed_forward and config.controller != "oscillator":
        raise ValueError("commands.feed_forward scales the rhythm: it needs controller='oscillator'")
    if not 0.0 < config.turn_bound <= 1.0:
        raise ValueError(f"turn_bound must be in (0, 1]; got {config.turn_bound}")
    if config.turn_mode == "abduction_stride":
        legs = robot_lib.load(config.robot).description.legs
        if any(leg.abduction is None for leg in legs):
            raise ValueError(
                f"turn_mode 'abduction_stride' needs a robot with abduction joints (12 joints);"
                f" robot {config.robot!r} has none: use 'hip_amplitude_difference'"
            )

