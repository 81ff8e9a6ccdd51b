"""Physics for a robot without a preset: the cheapest solver options that simulate it as its MJCF's
own do, measured (`probe`).

A robot quadcos has no preset for (`quadcos.robot.presets`) keeps its MJCF's solver (its cone and
up to 100 iterations) at `RobotPreset`'s 2-ms step (not the MJCF's timestep), which trains several
times slower than a preset's 5-ms step at 4 / 8 iterations. The probe runs a few robots on flat
ground: a third hold the home pose, a third walk the fixed trot (the env's zero action,
`QuadrupedEnv.zero_action_targets`), a third a fast gait (`_FAST`). It runs them first at the
options the env would otherwise run, in C MuJoCo (the reference: the MJCF's solver, with nothing to
compile), then at each candidate from the cheapest on in MJX-JAX (vmapped; the CPU too), and takes
the first candidate whose robots stay finite, upright and close to the reference (`judge`). The
presets were chosen the same way (experiments/robots/physics); MJX-JAX, as there, whatever the
training physics.

One compiled rollout serves every candidate of the same cone and iteration counts: the physics
step and the number of steps are traced values. Both engines follow one schedule of joint targets
(`_Rollout.targets`) and reduce their robots' stats to an `Outcome` in one place (`_outcome`).
"""

import dataclasses
import functools
import json
import math
import time
from collections.abc import Callable, Sequence
from typing import NamedTuple

import jax
import jax.numpy as jnp
import ml_collections
import mujoco
import numpy as np

from quadcos import robot as robot_lib
from quadcos import terrain as terrain_lib
from quadcos._util.quiet import warp_absence_unprinted
from quadcos.env import backends
from quadcos.env import config as config_lib
from quadcos.env.layout import Layout
from quadcos.env.quadruped import QuadrupedEnv
from quadcos.equations import oscillator, slope

with warp_absence_unprinted():
    from mujoco import mjx

PHYSICS_KEYS = ("physics_dt", "solver_iterations", "ls_iterations", "cone")
# Cheapest first: the step (physics steps per second of robot time) dominates the cost, so every
# step comes before any iteration count; at one step, fewer iterations, then pyramidal cones
# (Go1's and Go2's presets; quad12's and ANYmal C's need elliptic ones).
# s; only those dividing control_dt and longer than the reference's. Not 10 ms: Go1's MJCF passed
# the probe there and trained a policy that stood, its randomised evaluations blowing up (speeds of
# 1e5 m/s) and C MuJoCo's calibration walk falling (docs/decisions.md); every preset is 5 or 2.5 ms.
STEPS = (0.005, 0.0025)
# (solver, line search). Not 1 / 4 or 2 / 4: every Menagerie robot went NaN with them within 10 s
# (experiments/robots/physics), in a robot or two of 32, which a probe of 2 s cannot see.
ITERATIONS = ((4, 8), (8, 16))
CONES = ("pyramidal", "elliptic")
PROBE_ROBOTS = 9  # 3 hold the home pose, 3 trot, 3 walk the fast gait: small enough for a CPU
PROBE_SECONDS = 2.0  # s: a few periods of the fixed trot


@dataclasses.dataclass(frozen=True)
class SolverOptions:
    """Physics options of the env config: `physics_dt` s, iteration counts, cone."""

    physics_dt: float
    solver_iterations: int
    ls_iterations: int
    cone: str

    @property
    def label(self) -> str:
        return (
            f"physics_dt {self.physics_dt * 1000:g} ms, {self.cone} cones,"
            f" {self.solver_iterations} / {self.ls_iterations} iterations"
        )


class Outcome(NamedTuple):
    """What a rollout did (m, rad): a third of the robots hold the home pose, a third walk the fixed
    trot, the rest a fast gait (`_FAST`: counted in `finite` only)."""

    finite: bool
    fell: int  # robots whose base went below the fall height or tilted beyond the fall limit
    hold_height: float  # mean base height of the holding robots over the second half
    trot_height: float  # the same for the trotting robots
    max_tilt: float  # largest |roll| or |pitch| of any robot
    trot_forward: float  # mean forward displacement of the trotting robots
    max_penetration: float  # deepest a foot went into the ground
    seconds: float  # wall time of the rollout, compile included


@dataclasses.dataclass(frozen=True)
class Tolerances:
    """How far from the reference a candidate may be (measured on Go1, experiments/robots/physics
    and this probe). Height: 5 % of the standing height, the presets' criterion (pyramidal cones
    hold Go1 3 % above the converged elliptic reference). Tilt: 0.1 rad beyond the reference's
    largest (Go1 trotting: 0.14 rad at the reference, 0.15 at its preset), an eighth of the fall
    check's 0.8. Forward: a quarter of the reference trot's distance, at least 5 cm (Go1's trot
    speed spans 0.20–0.26 m/s over the settings that pass). Penetration: 1 cm deeper than the
    reference's (Menagerie's soft feet sink 14–17 mm there, 9 mm at Go1's preset)."""

    height_fraction: float = 0.05
    tilt: float = 0.1
    forward_fraction: float = 0.25
    forward_floor: float = 0.05
    penetration: float = 0.01


@dataclasses.dataclass(frozen=True)
class ProbeResult:
    """The options chosen (the reference's where no candidate passed) and every rollout."""

    chosen: SolverOptions
    reference: SolverOptions
    passed: bool
    trials: tuple[tuple[SolverOptions, Outcome, str], ...]  # (options, outcome, "" or why not)
    reference_outcome: Outcome

    @property
    def message(self) -> str:
        """One line: what the probe chose."""
        if self.passed:
            return f"solver probe: {self.chosen.label} (without it: {self.reference.label})"
        if not self.trials:
            return f"solver probe: no cheaper candidate than {self.reference.label}; keeping it"
        return f"solver probe: no candidate passed; keeping {self.reference.label}"

    def record(self) -> dict:
        """For a run's config.json (strict JSON: NaN as None)."""
        return {
            "chosen": dataclasses.asdict(self.chosen),
            "reference": dataclasses.asdict(self.reference),
            "passed": self.passed,
            "reference_outcome": _record(self.reference_outcome),
            "trials": [
                {**dataclasses.asdict(options), **_record(outcome), "rejected": why}
                for options, outcome, why in self.trials
            ],
        }


def _record(outcome: Outcome) -> dict:
    return {
        key: None if isinstance(value, float) and not math.isfinite(value) else value
        for key, value in outcome._asdict().items()
    }


def _flat() -> terrain_lib.Terrain:
    return terrain_lib.get("flat")


def needs_probe(config: ml_collections.ConfigDict) -> bool:
    """Whether an env config leaves its physics to a robot without a preset, with the probe on."""
    if not config.solver_probe or any(config[key] for key in PHYSICS_KEYS):
        return False
    return robot_lib.load(config.robot).name not in robot_lib.presets.PRESETS


def candidates(control_dt: float, reference: SolverOptions) -> tuple[SolverOptions, ...]:
    """The default candidates, cheapest first: `STEPS` that divide `control_dt` and are longer
    than the reference's step, each with `ITERATIONS` and `CONES`."""
    steps = [
        dt
        for dt in STEPS
        if dt > reference.physics_dt and abs(control_dt / dt - round(control_dt / dt)) < 1e-6
    ]
    return tuple(
        SolverOptions(dt, solver, line_search, cone)
        for dt in steps
        for solver, line_search in ITERATIONS
        for cone in CONES
    )


def judge(
    reference: Outcome, trial: Outcome, standing_height: float, tolerances: Tolerances
) -> str:
    """Why `trial` does not simulate the robot as `reference` does; "" when it does. Both are
    `Outcome`s of the same robots; `standing_height` m."""
    if not reference.finite:
        return "the reference itself is not finite"
    if not trial.finite:
        return "not finite"
    if trial.fell > reference.fell:
        return f"{trial.fell} fell ({reference.fell} at the reference)"
    height_tolerance = tolerances.height_fraction * standing_height
    for name in ("hold_height", "trot_height"):
        error = abs(getattr(trial, name) - getattr(reference, name))
        if error > height_tolerance:
            return f"{name} off by {error:.3f} m"
    if trial.max_tilt > reference.max_tilt + tolerances.tilt:
        return f"tilted {trial.max_tilt:.2f} rad"
    forward_tolerance = max(
        tolerances.forward_fraction * abs(reference.trot_forward), tolerances.forward_floor
    )
    if abs(trial.trot_forward - reference.trot_forward) > forward_tolerance:
        return f"trotted {trial.trot_forward:.2f} m, not {reference.trot_forward:.2f}"
    if trial.max_penetration > reference.max_penetration + tolerances.penetration:
        return f"feet {trial.max_penetration * 1000:.0f} mm deep"
    return ""


def probe(
    config: ml_collections.ConfigDict,
    options: Sequence[SolverOptions] | None = None,
    *,
    num_robots: int | None = None,
    seconds: float | None = None,
    seed: int = 0,
    tolerances: Tolerances = Tolerances(),
    log: Callable[[str], None] | None = None,
) -> ProbeResult:
    """Measures the cheapest of `options` (default `candidates`) that simulates the robot of env
    config `config` as the options it would otherwise run with do: `num_robots` robots (holding,
    trotting and walking fast; default `PROBE_ROBOTS`) for `seconds` s (`PROBE_SECONDS`) on flat
    ground, each candidate until one passes; `log` hears a line per candidate.

    Raises:
      ValueError: a config the env cannot run (`validate_config`).
    """
    config_lib.validate_config(config)
    reference_config = config_lib.resolve(_probed_config(config))
    reference = SolverOptions(*(reference_config[key] for key in PHYSICS_KEYS))
    mj_model = robot_lib.build_model(
        _flat(),
        robot_lib.load(config.robot),
        timestep=reference.physics_dt,
        servo=config_lib.servo_gains(config),
    )
    reference = dataclasses.replace(  # the MJCF's own values where the config leaves them
        reference,
        solver_iterations=reference.solver_iterations or int(mj_model.opt.iterations),
        ls_iterations=reference.ls_iterations or int(mj_model.opt.ls_iterations),
        cone=reference.cone or ("pyramidal", "elliptic")[int(mj_model.opt.cone)],
    )
    rollout = _rollout(
        reference_config.to_json(sort_keys=True),
        num_robots or PROBE_ROBOTS,
        seconds or PROBE_SECONDS,
        seed,
    )
    reference_outcome = rollout.reference(reference)
    standing = rollout.layout.standing_height
    trials = []
    options = candidates(config.control_dt, reference) if options is None else options
    for option in options:
        outcome = rollout(option)
        why = judge(reference_outcome, outcome, standing, tolerances)
        trials.append((option, outcome, why))
        if log is not None:
            log(f"solver probe: {option.label}: {why or 'passes'} ({outcome.seconds:.1f} s)")
        if not why:
            return ProbeResult(option, reference, True, tuple(trials), reference_outcome)
    return ProbeResult(reference, reference, False, tuple(trials), reference_outcome)


def _probed_config(config: ml_collections.ConfigDict) -> ml_collections.ConfigDict:
    """`config` as the probe runs it: a gait still to be searched for (a run probes its physics
    before its gait search) replaced by the default trot, which the probe's trotting robots walk."""
    if config.action_centre != oscillator.SEARCH_CENTRE:
        return config
    probed = ml_collections.ConfigDict(config.to_dict())
    probed.action_centre = config_lib.default_config().action_centre
    return probed


def apply(config: ml_collections.ConfigDict, result: ProbeResult) -> None:
    """Writes the chosen options into env config `config` (in place), so that an env built from
    it, and a run resumed or evaluated from its config.json, needs no probe."""
    for key in PHYSICS_KEYS:
        config[key] = getattr(result.chosen, key)


class _Stats(NamedTuple):
    """One robot's rollout so far (m, rad)."""

    finite: jax.Array
    fell: jax.Array
    height_sum: jax.Array  # of the base height over the second half of the steps
    tilt: jax.Array  # the largest |roll| or |pitch|
    penetration: jax.Array  # the deepest contact


class _Rollout:
    """Options → `Outcome` for one robot and env config: a jitted, vmapped rollout shared by every
    option (the model is an argument, its step traced: a new cone or iteration count
    recompiles), and the outcomes measured so far."""

    def __init__(
        self, config: ml_collections.ConfigDict, num_robots: int, seconds: float, seed: int
    ):
        self.seconds, self.outcomes = seconds, {}
        self.robot = robot = robot_lib.load(config.robot)
        self.servo = config_lib.servo_gains(config)
        plain = ml_collections.ConfigDict(config.to_dict())
        plain.impl, plain.randomization.enabled = "jax", False
        env = QuadrupedEnv("flat", plain)  # for its actions' joint targets
        self.layout = layout = env.layout
        self.roles = np.arange(num_robots) % 3  # HOLD, TROT, FAST
        fast = jnp.zeros(env.action_size).at[: len(_FAST)].set(jnp.array(_FAST))
        fast_period = env.rhythm_parameters(fast).period if config.controller != "joint" else 1.0
        noise = config.reset_joint_noise
        shape = (num_robots, layout.home.shape[0])
        key = jax.random.PRNGKey(seed)
        self.joints = layout.home + jax.random.uniform(key, shape, minval=-noise, maxval=noise)
        spawn = jnp.array([0.0, 0.0, layout.standing_height + _SPAWN_CLEARANCE])
        fall_height = robot.fall_min_height
        fall_tilt = min(config.fall_max_roll, config.fall_max_pitch_error)

        def targets(role, time):
            fast_phase = oscillator.TWO_PI * time / fast_period
            return jnp.select(
                [role == _HOLD, role == _TROT],
                [layout.home, env.zero_action_targets(time)],
                env.joint_targets(fast, fast_phase, time),
            )

        self.spawn, self.fall_height, self.fall_tilt = spawn, fall_height, fall_tilt
        # (robots, steps, J) joint targets at the given times: the C MuJoCo reference's schedule.
        self.targets = jax.jit(jax.vmap(jax.vmap(targets, (None, 0)), (0, None)))

        def step(model, role, data, stats, late):
            control = layout.controls(targets(role, data.time), data)
            data = mjx.step(model, data.replace(ctrl=control))
            attitude = slope.attitude(layout.orientation(data))
            tilt = jnp.maximum(jnp.abs(attitude.roll), jnp.abs(attitude.pitch))
            height = data.qpos[layout.position[2]]
            finite = jnp.isfinite(data.qpos).all() & jnp.isfinite(data.qvel).all()
            return data, _Stats(
                finite=stats.finite & finite,
                fell=stats.fell | (height < fall_height) | (tilt > fall_tilt),
                height_sum=stats.height_sum + jnp.where(late, height, 0.0),
                tilt=jnp.maximum(stats.tilt, tilt),
                penetration=jnp.maximum(stats.penetration, -_contact_dist(data).min(initial=0.0)),
            )

        def one(model, data, joints, role, steps):
            # No forward first: a step computes everything it uses from qpos (the warm start it
            # reads back is one a forward never writes), as the env's reset leaves it to the step.
            qpos = data.qpos.at[layout.position].set(spawn)
            qpos = qpos.at[layout.quaternion].set(jnp.array([1.0, 0.0, 0.0, 0.0]))
            data = data.replace(qpos=qpos.at[layout.joint_qpos].set(joints))
            zero = jnp.zeros(())
            stats = _Stats(jnp.array(True), jnp.array(False), zero, zero, zero)

            def body(index, carry):
                return step(model, role, *carry, late=index >= steps // 2)

            data, stats = jax.lax.fori_loop(0, steps, body, (data, stats))
            mean_height = stats.height_sum / (steps - steps // 2)
            return stats._replace(height_sum=mean_height), data.qpos[layout.position[0]]

        self._run = jax.jit(jax.vmap(one, in_axes=(None, None, 0, 0, None)))

    def _model(self, options: SolverOptions) -> mujoco.MjModel:
        return robot_lib.build_model(
            _flat(),
            self.robot,
            timestep=options.physics_dt,
            solver_iterations=options.solver_iterations,
            ls_iterations=options.ls_iterations,
            cone=options.cone,
            servo=self.servo,
        )

    def __call__(self, options: SolverOptions) -> Outcome:
        """The robots under `options` in MJX-JAX (a candidate)."""
        if options in self.outcomes:
            return self.outcomes[options]
        started = time.perf_counter()
        mj_model = self._model(options)
        model = mjx.put_model(mj_model, device=backends.local_device(), impl="jax")
        data = mjx.make_data(mj_model, device=backends.local_device(), impl="jax")
        steps = jnp.asarray(round(self.seconds / options.physics_dt), jnp.int32)
        stats, forward = jax.device_get(self._run(model, data, self.joints, self.roles, steps))
        self.outcomes[options] = outcome = _outcome(stats, forward, self.roles, started)
        return outcome

    def reference(self, options: SolverOptions) -> Outcome:
        """The robots under `options` in C MuJoCo, one after another (the reference)."""
        started = time.perf_counter()
        mj_model = self._model(options)
        layout = Layout.of(self.robot.description, mj_model, xp=np)
        steps = round(self.seconds / options.physics_dt)
        times = jnp.arange(steps, dtype=jnp.float32) * options.physics_dt
        targets = np.asarray(self.targets(jnp.asarray(self.roles), times), np.float64)
        late = np.arange(steps) >= steps // 2
        rows = [
            self._reference_robot(mj_model, layout, joints, schedule, late)
            for joints, schedule in zip(np.asarray(self.joints), targets)
        ]
        stats = _Stats(*(np.array(column) for column in zip(*(row[0] for row in rows))))
        return _outcome(stats, np.array([row[1] for row in rows]), self.roles, started)

    def _reference_robot(self, mj_model, layout, joints, schedule, late) -> tuple[tuple, float]:
        """One robot's (_Stats fields, forward displacement) in C MuJoCo."""
        data = mujoco.MjData(mj_model)
        data.qpos[layout.position] = np.asarray(self.spawn)
        data.qpos[layout.quaternion] = (1.0, 0.0, 0.0, 0.0)
        data.qpos[layout.joint_qpos] = joints
        mujoco.mj_forward(mj_model, data)
        heights, quaternions, depth = np.empty(len(schedule)), np.empty((len(schedule), 4)), 0.0
        for index, targets in enumerate(schedule):
            data.ctrl[:] = layout.controls(targets, data)
            mujoco.mj_step(mj_model, data)
            heights[index] = data.qpos[layout.position[2]]
            quaternions[index] = layout.orientation(data)
            depth = max(depth, -data.contact.dist.min(initial=0.0))
        attitude = slope.attitude(quaternions)
        tilt = np.maximum(np.abs(np.asarray(attitude.roll)), np.abs(np.asarray(attitude.pitch)))
        # C MuJoCo resets a simulation that went non-finite, with a warning: count it as not finite.
        blown = sum(data.warning[warning].number for warning in _BAD_STATE)
        finite = blown == 0 and bool(np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all())
        fell = bool(((heights < self.fall_height) | (tilt > self.fall_tilt)).any())
        fields = (finite, fell, heights[late].mean(), tilt.max(), depth)
        return fields, float(data.qpos[layout.position[0]])


def _outcome(stats: _Stats, forward: np.ndarray, roles: np.ndarray, started: float) -> Outcome:
    """Robots' stats (their mean late height in `height_sum`) and forward displacements → the
    rollout's `Outcome`; the fast gait's robots count in `finite` only (they may fall)."""
    finite = bool(np.all(stats.finite))
    hold, trot = roles == _HOLD, roles == _TROT
    judged = hold | trot
    return Outcome(
        finite=finite,
        fell=int(np.sum(stats.fell[judged])) if finite else int(judged.sum()),
        hold_height=float(np.mean(stats.height_sum[hold])),
        trot_height=float(np.mean(stats.height_sum[trot])),
        max_tilt=float(np.max(stats.tilt[judged])),
        trot_forward=float(np.mean(forward[trot])),
        max_penetration=float(np.max(stats.penetration[judged])),
        seconds=time.perf_counter() - started,
    )


def _contact_dist(data: mjx.Data) -> jax.Array:
    """m, every contact's distance (negative: penetration); MJX-JAX keeps them in its `_impl`."""
    return data._impl.contact.dist  # noqa: SLF001


_HOLD, _TROT = 0, 1  # the robots' roles; the others walk the fast gait
_BAD_STATE = tuple(  # C MuJoCo's warnings of a state it reset
    int(getattr(mujoco.mjtWarning, f"mjWARN_{name}")) for name in ("BADQPOS", "BADQVEL", "BADQACC")
)
# The fast gait: both amplitudes at their largest, the shortest period (the action's first three
# values; the phases the trot's): a gait SAC's exploration reaches, to expose a solver that blows
# up once the robot moves hard. Its robots only have to stay finite.
_FAST = (1.0, 1.0, -1.0)
_SPAWN_CLEARANCE = 0.002  # m: feet start just above the ground, as the env's reset


@functools.lru_cache(maxsize=4)
def _rollout(config_json: str, num_robots: int, seconds: float, seed: int) -> _Rollout:
    """The rollout of a resolved env config (as JSON): one per robot and config in a process."""
    return _Rollout(ml_collections.ConfigDict(json.loads(config_json)), num_robots, seconds, seed)
