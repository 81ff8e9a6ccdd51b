"""The robot stepped in C MuJoCo (`mujoco.mj_step` on an `MjData`), no JAX in the loop: the env's
controller path for sim-to-sim (`evaluate_mujoco`) and `python -m quadcos.play`.

`HostRobot` steps one robot as `QuadrupedEnv.step` does (command filter, rhythm parameters, phase
and joint targets at every physics step; observation, slope estimate, reward, fall check) with the
NumPy twins of `quadcos.deploy.twins`. The policy is its exported NumPy forward pass
(`quadcos.deploy.export`; a pilot also takes an exported .npz, an exported .onnx run with ONNX
Runtime, or `fixed:...`) in the env config it was trained with. Reset: the env's spawn pose at
x = y = 0; episodes differ by their noise seed.

Two deployment faults, both off by default: observation noise (Gaussian, std `obs_noise`, on each
value the policy sees; the episode's own stream, seeded by its reset seed) and control latency
(`latency_s`, rounded to whole physics steps L: the command filter at physics step t of the
episode moves towards the action computed at the control step that began L physics steps
earlier, zero before the first. For L below a control step this is the MJX env's randomised
`latency_steps`: the previous action for the first L substeps of each control step, then the
new one; a latency of one control step acts each action one step late).

The constraint solver: `physics="reference"` (the default) runs the MJCF's own solver iterations
(MuJoCo's default: 100 Newton iterations, 50 line-search) at the training step, cone and
contacts: the converged physics a policy has to transfer to. `physics="training"` runs the
iterations the env trained with (the robot preset's shortcut, e.g. Go1's 4 / 8): C MuJoCo's solver
stopped that early is not MJX-Warp's and can blow up under a fast gait (experiments/robots). For
the paper's robot, whose preset keeps the MJCF's iterations, the two are the same. `physics="N/M"`
runs N solver and M line-search iterations (the same step, cone and contacts), to find where the
solver a policy trained with stops transferring.

Episodes end and succeed as in `quadcos.evaluation` (no fall within the time limit; on a course,
the torso past `course_end_x` first). `evaluate_mujoco` returns an evaluation JSON in
`quadcos.evaluation`'s format (aggregates, "setup" with `"engine": "mujoco"`, per-episode values),
so the two compare key by key.
"""

import argparse
import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import ml_collections
import mujoco
import numpy as np

from quadcos import env as env_lib
from quadcos import evaluation, robot
from quadcos import terrain as terrain_lib
from quadcos._util import cli
from quadcos._util import overrides as config_lib
from quadcos.deploy import export, solver, twins
from quadcos.deploy.numpy_policy import NumpyPolicy
from quadcos.deploy.onnx_policy import OnnxPolicy
from quadcos.env.layout import Layout
from quadcos.equations import oscillator, reward, slope
from quadcos.evaluation import report, rollout, sources

ENGINE = "mujoco"
# Per-episode maxima of evaluation.EpisodeStats: |y − y0|, |roll|, |yaw|, |pitch − true slope|.
_MAXIMA = ("max_lateral_deviation", "max_abs_roll", "max_abs_yaw", "max_abs_pitch_error")
_CORNER_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])


@dataclasses.dataclass(frozen=True)
class Pilot:
    """What chooses actions: a NumPy or ONNX Runtime policy or fixed rhythm parameters, and the
    env config (`quadcos.env.default_config()` with the policy's saved options) it runs in."""

    name: str
    kind: str  # "sac" or "fixed"
    config: ml_collections.ConfigDict
    training_terrain: str
    policy: NumpyPolicy | OnnxPolicy | None = None
    fixed_parameters: oscillator.RhythmParameters | None = None

    def actor(self) -> Callable[[np.ndarray], np.ndarray]:
        """obs -> (action_size,) action; fixed parameters: the constant action commanding them."""
        if self.policy is not None:
            return self.policy
        centre = oscillator.action_centre(self.config.action_centre, self.config.period_min)
        action = np.asarray(
            oscillator.parameters_to_action(
                self.fixed_parameters, self.config.period_min, centre, self.config.action_scale
            ),
            np.float64,
        )
        action = np.pad(action, (0, env_lib.action_size(self.config) - action.size))
        return lambda obs: action


def load_pilot(spec: str, robot: str | None = None) -> Pilot:
    """The pilot for a --policy value: `fixed:trot`, `fixed:A_k,A_h,T,phi1,phi3`, a run or policy
    directory, an exported .npz, or an exported .onnx (run with ONNX Runtime); `robot`: the
    quadruped fixed parameters drive (a trained policy drives its own: another is refused).

    Raises:
      FileNotFoundError, ValueError: no policy there, a file that is not a quadcos policy, or an
        env config this quadcos cannot build.
    """
    if spec.startswith(sources.FIXED_PREFIX):
        source = evaluation.resolve_source(spec)
        overrides = {} if robot is None else {"robot": robot}
        config = evaluation.build_env(source, "flat", overrides).config  # checks the ranges
        return Pilot(spec, "fixed", config, "flat", fixed_parameters=source.fixed_parameters)
    policy = OnnxPolicy.load(spec) if spec.endswith(".onnx") else export.numpy_policy(spec)
    saved = dict(policy.env_config)
    terrain = str(saved.pop("terrain", "flat"))
    try:
        config = env_config(config_lib.flatten(saved))
    except ValueError as error:
        raise ValueError(f"{spec}: its env config does not build: {error}") from None
    if robot is not None and robot != config.robot:
        raise ValueError(f"the policy {spec} was trained on robot {config.robot!r}, not {robot!r}")
    return Pilot(spec, "sac", config, terrain, policy=policy)


def env_config(overrides: dict[str, Any] | None = None) -> ml_collections.ConfigDict:
    """`quadcos.env.default_config()` with dotted `overrides`, spawning at x = 0 as evaluations do.

    Raises:
      ValueError: an unknown key or a value the env cannot run with.
    """
    overrides = dict(overrides or {})
    config = config_lib.apply_overrides(env_lib.default_config(), overrides | {"spawn_x_max": 0.0})
    env_lib.validate_config(config)
    return config


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
    iterations (module docstring).

    Raises:
      ValueError: a latency that is negative or not finite, or an unknown `physics`.
    """

    def __init__(
        self,
        terrain: terrain_lib.Terrain | str,
        config: ml_collections.ConfigDict,
        latency_s: float = 0.0,
        physics: str = "reference",
    ):
        if not (math.isfinite(latency_s) and latency_s >= 0):
            raise ValueError(f"the latency must be >= 0 s and finite; got {latency_s}")
        self.terrain = terrain_lib.get(terrain) if isinstance(terrain, str) else terrain
        self.robot = robot.load(config.robot)
        config = env_lib.resolve(config)
        self.config = config
        iterations, ls_iterations = solver.iterations(physics, config)
        self.model = robot.build_model(
            self.terrain,
            self.robot,
            timestep=config.physics_dt,
            solver_iterations=iterations,
            ls_iterations=ls_iterations,
        )
        self.physics = {
            "solver": physics,
            "timestep": float(self.model.opt.timestep),
            "iterations": int(self.model.opt.iterations),
            "ls_iterations": int(self.model.opt.ls_iterations),
            "cone": "elliptic"
            if self.model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
            else "pyramidal",
        }
        self.layout = Layout.of(self.robot.description, self.model, xp=np)
        self.data = mujoco.MjData(self.model)
        self.substeps = round(config.control_dt / config.physics_dt)
        self.dt = self.substeps * config.physics_dt
        self.latency_steps = round(latency_s / config.physics_dt)  # physics steps
        self._queue_length = -(-self.latency_steps // self.substeps)  # earlier actions still due
        tau = config.action_filter_tau
        self._blend = 1.0 - math.exp(-config.physics_dt / tau) if tau > 0 else 1.0
        speed_tau = config.survival_speed_tau
        self._speed_blend = 1.0 - math.exp(-self.dt / speed_tau) if speed_tau > 0 else 1.0
        self.action_size = env_lib.action_size(config)
        self.action_centre = oscillator.action_centre(config.action_centre, config.period_min)
        self.weights = reward.RewardWeights(**config.reward.to_dict())
        self._torso = self.model.body(self.robot.description.root_body).id
        self.phase, self.command, self.mean_speed = 0.0, np.zeros(self.action_size), 0.0
        self._pending = [np.zeros(self.action_size)] * self._queue_length

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
        return self._observe()[0]

    def rhythm_parameters(self) -> oscillator.RhythmParameters | None:
        """The parameters the current command sets (None for the joint controller)."""
        if self.config.controller != "oscillator":
            return None
        return twins.action_to_parameters(
            self.command[: oscillator.RHYTHM_SIZE],
            self.config.period_min,
            self.action_centre,
            self.config.action_scale,
        )

    def step(self, action: np.ndarray) -> StepResult:
        """One control period: `substeps` mj_steps under the controller (the command filter
        moving towards the action due after the latency), then observe, reward and check for a
        fall."""
        x_last, y_last, _ = self.data.qpos[self.layout.position]
        actions = [*self._pending, np.clip(np.asarray(action, np.float64), -1.0, 1.0)]
        period = oscillator.FIXED_TROT.period
        for index in range(self.substeps):
            target = actions[self._queue_length + (index - self.latency_steps) // self.substeps]
            self.command = self.command + self._blend * (target - self.command)
            params = self.rhythm_parameters()
            self.data.ctrl[:] = self.layout.controls(self._joint_targets(params), self.data)
            mujoco.mj_step(self.model, self.data)
            period = period if params is None else params.period
            self.phase = twins.advance_phase(self.phase, period, self.config.physics_dt)
        self._pending = actions[len(actions) - self._queue_length :]
        if self.config.oscillator_form == "literal":
            self.phase = math.fmod(oscillator.TWO_PI * self.data.time / period, oscillator.TWO_PI)
        obs, body, slope_estimate = self._observe()
        x, y, _ = self.data.qpos[self.layout.position]
        slope_truth = float(twins.slope_at(self.terrain, x, y))
        finite = np.isfinite(self.data.qpos).all() and np.isfinite(self.data.qvel).all()
        fell = not finite or self._fell(body, slope_truth)
        forward_speed = (x - x_last) / self.dt
        self.mean_speed += self._speed_blend * (forward_speed - self.mean_speed)
        terms = twins.reward_terms(
            x_now=x,
            x_last=x_last,
            y_now=y,
            y_last=y_last,
            body=body,
            slope_estimate=slope_estimate,
            fell=fell,
            moving=self._moving(self.mean_speed),
            weights=self.weights,
            variant=self.config.reward_variant,
            max_progress=env_lib.max_progress(self.config, self.dt),
        )
        return StepResult(obs, body, slope_estimate, slope_truth, forward_speed, terms, fell)

    def _moving(self, mean_speed: float) -> bool:
        """`QuadrupedEnv._moving`: whether the step earns Eq. 9's r_s."""
        min_speed = self.config.survival_min_speed
        return min_speed == 0 or mean_speed >= min_speed

    def _joint_targets(self, params: oscillator.RhythmParameters | None) -> np.ndarray:
        """`QuadrupedEnv.joint_targets` of the current command and phase."""
        if params is None:
            return self.layout.home + env_lib.JOINT_TARGET_BOUND * np.clip(self.command, -1.0, 1.0)
        phase = self.phase
        if self.config.oscillator_form == "literal":
            phase = oscillator.TWO_PI * self.data.time / params.period
        phases = twins.trot_phases(params.phi1, params.phi3)
        targets = twins.rhythm_at_phase(phase, params.amplitude_hip, params.amplitude_knee, phases)
        if self.config.posture_bound > 0:
            targets += twins.posture_offsets(
                self.command[oscillator.RHYTHM_SIZE :], self.config.posture_bound
            )
        if self.config.start_ramp_s > 0:
            targets = targets * twins.start_ramp(self.data.time, self.config.start_ramp_s)
        return self.layout.rhythm_targets(targets)

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
        return np.concatenate(parts), body, slope_estimate

    def _fell(self, body: slope.Attitude, slope_truth: float) -> bool:
        """`QuadrupedEnv._fell`: torso too low, attitude beyond limits, or a torso corner below
        the ground."""
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


# --- episodes and the evaluation file -----------------------------------------------------------


def run_episode(
    host: HostRobot,
    act: Callable[[np.ndarray], np.ndarray],
    seed: int | Sequence[int],
    num_steps: int,
    obs_noise: float = 0.0,
) -> dict[str, Any]:
    """One episode of at most `num_steps` control steps from `host.reset(seed)`, the policy
    seeing each observation value plus N(0, obs_noise²) noise (a stream spawned from `seed`);
    returns the fields of `evaluation.EpisodeStats` for it (scalars), accumulated as `evaluate`
    does."""
    obs = host.reset(seed)
    key_noise = np.random.SeedSequence(seed).spawn(1)[0]
    noise = np.random.default_rng(key_noise)
    position = host.layout.position
    x, y, _ = (float(value) for value in host.data.qpos[position])
    record = dict(fell=False, finished=False, steps=0, start_x=x, start_y=y, x=x, y=y)
    maxima = np.zeros(len(_MAXIMA))
    slope_sq_error, reward_terms = 0.0, dict.fromkeys(reward.TERM_NAMES, 0.0)
    course_end_x = host.terrain.course_end_x
    for _ in range(num_steps):
        seen = obs + noise.normal(0.0, obs_noise, obs.shape) if obs_noise > 0 else obs
        result = host.step(act(seen))
        obs, qpos = result.obs, host.data.qpos
        body = twins.attitude(qpos[host.layout.quaternion])  # as evaluate: from qpos
        x, y, _ = (float(value) for value in qpos[position])
        record.update(steps=record["steps"] + 1, x=x, y=y)
        now = [y - record["start_y"], body.roll, body.yaw, body.pitch - result.slope_truth]
        maxima = np.maximum(maxima, np.abs(now))
        slope_sq_error += (result.slope_estimate - result.slope_truth) ** 2
        for term, value in result.reward_terms.items():
            reward_terms[term] += value
        at_end = course_end_x is not None and x >= course_end_x
        record.update(fell=result.fell, finished=not result.fell and at_end)
        if record["fell"] or record["finished"]:
            break
    return {
        **record,
        **dict(zip(_MAXIMA, maxima.tolist())),
        "running": not (record["fell"] or record["finished"]),
        "lane": 0,
        "slope_sq_error": slope_sq_error,
        "episode_reward": sum(reward_terms.values()),
        "reward_terms": reward_terms,
    }


def evaluate_mujoco(
    pilot: Pilot | str,
    terrain: terrain_lib.Terrain | str | None = None,
    *,
    episodes: int = 64,
    seconds: float = 20.0,
    seed: int = 0,
    obs_noise: float = 0.0,
    latency_s: float = 0.0,
    physics: str = "reference",
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """`episodes` deterministic episodes in C MuJoCo, one after another; episode i resets with
    joint noise from the seed (seed, i). `obs_noise` (std) and `latency_s` (s): the deployment
    faults of the module docstring; `physics`: its solver choice. Returns the content of an
    evaluation JSON (aggregates, "setup", "episodes"), as `quadcos.evaluate` writes it.

    Raises:
      ValueError, FileNotFoundError: bad policy, terrain, sizes, counts, noise or latency.
    """
    pilot = load_pilot(pilot) if isinstance(pilot, str) else pilot
    if episodes < 1 or not (math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"episodes must be >= 1 and seconds > 0; got {episodes}, {seconds}")
    if not (math.isfinite(obs_noise) and obs_noise >= 0):
        raise ValueError(f"the observation noise must be >= 0 and finite; got {obs_noise}")
    ground = terrain if terrain is not None else pilot.training_terrain
    host = HostRobot(ground, pilot.config, latency_s, physics)
    act = pilot.actor()
    size = host.reset(0).shape[0]
    if pilot.policy is not None and size != pilot.policy.observation_size:
        raise ValueError(
            f"the policy {pilot.name} expects observations of size"
            f" {pilot.policy.observation_size}, the env gives {size}: its env config does not"
            " match the one it was trained with"
        )
    num_steps = math.ceil(seconds / host.dt - 1e-9)
    started = time.monotonic()
    records = []
    for index in range(episodes):
        records.append(run_episode(host, act, (seed, index), num_steps, obs_noise))
        if progress is not None:
            progress(index + 1, episodes)
    fields = {
        name: np.array([record[name] for record in records])
        for name in evaluation.EpisodeStats.__dataclass_fields__
        if name != "reward_terms"
    }
    terms = {t: np.array([r["reward_terms"][t] for r in records]) for t in reward.TERM_NAMES}
    stats = evaluation.EpisodeStats(**fields, reward_terms=terms)
    values = evaluation.episode_values(stats, host.dt, num_steps)
    course = host.terrain.course_end_x is not None
    for episode in values:
        episode["success"] = episode["finished_course"] if course else not episode["fell"]
        episode["reset_seed"] = [seed, episode["index"]]
    setup = {
        "engine": ENGINE,
        "policy": pilot.name,
        "policy_kind": pilot.kind,
        "robot": host.robot.provenance(),
        "terrain": host.terrain.spec,
        "course_end_x": host.terrain.course_end_x,
        "num_envs": episodes,
        "seconds": num_steps * host.dt,
        "num_steps": num_steps,
        "control_dt": host.dt,
        "seed": seed,
        "obs_noise": obs_noise,
        "latency_s": latency_s,
        "latency_physics_steps": host.latency_steps,
        "physics": host.physics,
        "env": pilot.config.to_dict() | {"terrain": host.terrain.spec},
        "wall_time_s": time.monotonic() - started,
        "versions": {"mujoco": mujoco.__version__, "numpy": np.__version__}
        | _onnxruntime_version(pilot),
    }
    head = {"format": report.FORMAT, "format_version": rollout.FORMAT_VERSION}
    return head | evaluation.aggregate(values, stats) | {"setup": setup, "episodes": values}


def _onnxruntime_version(pilot: Pilot) -> dict[str, str]:
    """{"onnxruntime": version} for a pilot that runs ONNX Runtime, else {}."""
    if not isinstance(pilot.policy, OnnxPolicy):
        return {}
    import onnxruntime

    return {"onnxruntime": onnxruntime.__version__}


def pilot_parser(prog: str, description: str) -> argparse.ArgumentParser:
    """A CLI parser with --policy, --terrain and --seed (sim2sim's and play's) whose errors are
    `cli.UsageError`s, reported as one line."""
    parser = argparse.ArgumentParser(
        prog=prog, description=description, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--policy",
        required=True,
        help="run or policy directory, exported .npz or .onnx, or fixed:trot",
    )
    parser.add_argument("--terrain", help="terrain name or spec (default: the training terrain)")
    parser.add_argument(
        "--robot",
        help="the quadruped of fixed:... parameters (quadcos, quad12, an MJCF path,"
        " menagerie:NAME); a trained policy drives its own",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the reset joint noise")
    parser.add_argument(
        "--physics",
        type=solver.physics_choice,
        default="reference",
        help="C MuJoCo's solver: the MJCF's iterations (reference, converged), the training"
        " shortcut's (training), or N/M solver / line-search iterations",
    )
    return cli.raising(parser)
