"""One way to evaluate a policy: `evaluate(policy, engine="mjx" | "mujoco", ...)`.

- "mjx" (default): `quadcos.evaluation.evaluate`, all episodes at once on the device, one traced.
- "mujoco": episode after episode in C MuJoCo (`host_robot.HostRobot`: the env's controller path,
  no JAX in the loop), with the deployment faults of `quadcos.deploy.host_robot` (observation
  noise, latency) and its choice of solver (`physics`). Episode i resets with joint noise from the
  seed (seed, i); episodes end and succeed as in `quadcos.evaluation`.

Both take a --policy string or a `PolicySpec` and run it in the env config it was trained in
(`PolicySpec.env_config`) with the same `env_overrides`; both return a
`quadcos.evaluation.Evaluation` whose `to_json()` is the evaluation JSON (aggregates, "setup",
"episodes"; a mujoco setup says `"engine": "mujoco"`), so the two compare key by key.

The command lines that name a policy (`evaluate`, `play`, `sim2sim`) share `policy_parser` and
`parse_command`: --policy, --terrain, --robot, --seed and env options `--env.KEY=VALUE`.
"""

import argparse
import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from quadcos import env as env_lib
from quadcos import evaluation
from quadcos import terrain as terrain_lib
from quadcos._util import cli
from quadcos._util.overrides import parse_overrides
from quadcos.deploy import host_robot, solver, twins
from quadcos.deploy.onnx_policy import OnnxPolicy
from quadcos.env import commands as env_commands
from quadcos.env import tracking
from quadcos.equations import reward
from quadcos.evaluation import report, rollout, sources

ENGINES = ("mjx", "mujoco")
# Per-episode maxima of evaluation.EpisodeStats: |y − y0|, |roll|, |yaw|, |pitch − true slope|.
_MAXIMA = ("max_lateral_deviation", "max_abs_roll", "max_abs_yaw", "max_abs_pitch_error")
# GaitEpisodeStats fields that the host episodes do not sum: the end-of-step samples (only the
# rollout's next step reads them) and the flags.
_NOT_SUMMED = (
    "reward_terms", "command", "yaw", "foot_xy", "foot_contact", "commanded", "mass", "tracking"
)
_MUJOCO_ONLY = {"obs_noise": 0.0, "latency_s": 0.0, "physics": "reference", "friction": 0.0}


def evaluate(
    policy: str | sources.PolicySpec,
    terrain: terrain_lib.Terrain | str | None = None,
    *,
    engine: str = "mjx",
    episodes: int = 64,
    seconds: float = 20.0,
    seed: int = 0,
    env_overrides: Mapping[str, Any] | None = None,
    trace_episode: int = 0,
    obs_noise: float = 0.0,
    latency_s: float = 0.0,
    physics: str = "reference",
    progress: Callable[[int, int], None] | None = None,
    commands: str | None = None,
    friction: float = 0.0,
) -> evaluation.Evaluation:
    """`episodes` deterministic episodes of `policy` on `terrain` (default: its training terrain)
    in `engine` ("mjx" or "mujoco", module docstring).

    Args:
      seconds: time limit of an episode, s (rounded up to whole control steps).
      seed: seed of the reset noise.
      env_overrides: env config options on top of the policy's (dotted keys).
      trace_episode: mjx: the episode whose time series the result's `trace` holds.
      obs_noise, latency_s, physics, friction: mujoco: observation noise (std), control latency
        (s), solver and every geom's sliding friction (0: the MJCF's) (`quadcos.deploy.host_robot`).
      progress: called as progress(done, total) (mjx: steps; mujoco: episodes).
      commands: velocity commands to follow ("random" or a schedule "v,ω@s;...",
        `quadcos.env.commands.parse_commands`); None: the policy's env's own.

    Raises:
      ValueError, FileNotFoundError: bad policy, engine, terrain, overrides, sizes, counts, or an
        option of the other engine.
    """
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}; known: {', '.join(ENGINES)}")
    spec = sources.PolicySpec.parse(policy) if isinstance(policy, str) else policy
    if engine == "mjx":
        given = dict(obs_noise=obs_noise, latency_s=latency_s, physics=physics, friction=friction)
        if given != _MUJOCO_ONLY:
            raise ValueError(
                "obs_noise, latency_s, physics and friction are options of the mujoco engine"
            )
        return evaluation.evaluate(
            spec,
            terrain,
            num_envs=episodes,
            seconds=seconds,
            seed=seed,
            trace_episode=trace_episode,
            env_overrides=env_overrides,
            progress=progress,
            commands=commands,
        )
    if trace_episode:
        raise ValueError("the mujoco engine traces no episode: trace_episode is an mjx option")
    if episodes < 1 or not (math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"episodes must be >= 1 and seconds > 0; got {episodes}, {seconds}")
    if not (math.isfinite(obs_noise) and obs_noise >= 0):
        raise ValueError(f"the observation noise must be >= 0 and finite; got {obs_noise}")
    pilot = host_robot.Pilot.load(spec, env_overrides)
    ground = terrain if terrain is not None else spec.training_terrain
    host = host_robot.HostRobot(ground, pilot.config, latency_s, physics, commands, friction)
    return _mujoco_episodes(pilot, host, episodes, seconds, seed, obs_noise, progress)


def run_episode(
    host: host_robot.HostRobot,
    act: Callable[[np.ndarray], np.ndarray],
    seed: int | Sequence[int],
    num_steps: int,
    obs_noise: float = 0.0,
) -> dict[str, Any]:
    """One episode of at most `num_steps` control steps from `host.reset(seed)`, the policy
    seeing each observation value plus N(0, obs_noise²) noise (a stream spawned from `seed`);
    returns the fields of `evaluation.GaitEpisodeStats` for it (scalars), accumulated as
    `evaluate` does."""
    obs = host.reset(seed)
    key_noise = np.random.SeedSequence(seed).spawn(1)[0]
    noise = np.random.default_rng(key_noise)
    position = host.layout.position
    x, y, _ = (float(value) for value in host.data.qpos[position])
    record = dict(fell=False, finished=False, steps=0, start_x=x, start_y=y, x=x, y=y)
    maxima = np.zeros(len(_MAXIMA))
    slope_sq_error, reward_terms = 0.0, dict.fromkeys(reward.TERM_NAMES, 0.0)
    course_end_x = host.terrain.course_end_x
    gait = _GaitSums(host)
    for _ in range(num_steps):
        seen = obs + noise.normal(0.0, obs_noise, obs.shape) if obs_noise > 0 else obs
        command = host.commands.velocity if host.commands is not None else None
        result = host.step(act(seen))
        gait.add(host, command)
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
        **gait.sums,
    }


class _GaitSums:
    """An episode's running gait sums of `rollout.GaitEpisodeStats` (the mjx rollout's
    `_update_gait_stats`, one robot): tracking errors, foot slip, energy, path, peak torque;
    feet and torques sampled at the end of each control step."""

    def __init__(self, host: host_robot.HostRobot):
        self.sums = dict.fromkeys(
            ("speed_sq_error", "yaw_rate_sq_error", "slip_sum", "energy", "path"), 0.0
        )
        self.sums |= dict.fromkeys(("open_speed_error", "open_yaw_rate_error"), 0.0)
        self.sums |= {"slip_steps": 0, "peak_torque_ratio": 0.0, "windows": 0}
        self.steps, self.window = 0, tracking.window_steps(host.dt)
        self.sample = self._sample(host)

    @staticmethod
    def _sample(host: host_robot.HostRobot) -> dict[str, Any]:
        data, layout = host.data, host.layout
        feet = data.geom_xpos[layout.foot_geoms]
        ground = twins.height_at(host.terrain, feet[:, 0], feet[:, 1])
        return {
            "xy": data.qpos[layout.position][:2].copy(),
            "yaw": twins.attitude(data.qpos[layout.quaternion]).yaw,
            "feet": feet[:, :2].copy(),
            "touching": feet[:, 2] - layout.foot_radius - ground < rollout.CONTACT_CLEARANCE,
        }

    def add(self, host: host_robot.HostRobot, command: np.ndarray | None) -> None:
        """One control step just taken by `host`, which followed `command` (v*, ω*) in it."""
        last, now, dt, layout = self.sample, self._sample(host), host.dt, host.layout
        step_x, step_y = now["xy"] - last["xy"]
        yaw = now["yaw"]
        sums = self.sums
        if command is not None:
            speed = (step_x * math.cos(yaw) + step_y * math.sin(yaw)) / dt
            yaw_rate = twins.wrap_angle(yaw - last["yaw"]) / dt
            sums["open_speed_error"] += speed - command[0]
            sums["open_yaw_rate_error"] += yaw_rate - command[1]
        self.steps += 1
        if command is not None and self.steps % self.window == 0:
            for name in ("speed", "yaw_rate"):
                sums[f"{name}_sq_error"] += (sums[f"open_{name}_error"] / self.window) ** 2
                sums[f"open_{name}_error"] = 0.0
            sums["windows"] += 1
        slipping = now["touching"] & last["touching"]
        foot_speed = np.linalg.norm(now["feet"] - last["feet"], axis=-1) / dt
        sums["slip_sum"] += float((foot_speed * slipping).sum() / max(slipping.sum(), 1))
        sums["slip_steps"] += int(slipping.any())
        torque = host.data.qfrc_actuator[layout.joint_qvel]
        sums["energy"] += float(np.abs(torque * host.data.qvel[layout.joint_qvel]).sum()) * dt
        sums["path"] += math.hypot(step_x, step_y)
        limit = np.asarray(layout.torque_limit, np.float64)
        ratio = float((np.abs(torque) / limit).max()) if np.isfinite(limit).any() else math.nan
        sums["peak_torque_ratio"] = max(sums["peak_torque_ratio"], ratio)
        self.sample = now


def _mujoco_episodes(
    pilot: host_robot.Pilot,
    host: host_robot.HostRobot,
    episodes: int,
    seconds: float,
    seed: int,
    obs_noise: float,
    progress: Callable[[int, int], None] | None,
) -> evaluation.Evaluation:
    """The mujoco engine of `evaluate`, once its arguments are checked."""
    act = pilot.actor()
    observation_size = host.reset(0).shape[0]
    expected = pilot.spec.observation_size, pilot.spec.action_size
    sources.check_sizes(pilot.name, expected, (observation_size, host.action_size))
    num_steps = math.ceil(seconds / host.dt - 1e-9)
    started = time.monotonic()
    records = []
    for index in range(episodes):
        records.append(run_episode(host, act, (seed, index), num_steps, obs_noise))
        if progress is not None:
            progress(index + 1, episodes)
    fields = {
        name: np.array([record[name] for record in records])
        for name in rollout.GaitEpisodeStats.__dataclass_fields__
        if name not in _NOT_SUMMED
    }
    terms = {t: np.array([r["reward_terms"][t] for r in records]) for t in reward.TERM_NAMES}
    windows = {
        name: np.array([record[name] for record in records])
        for name in tracking.Windows.__dataclass_fields__
    }
    stats = rollout.GaitEpisodeStats(
        **fields,
        tracking=tracking.Windows(**windows),
        command=np.zeros((episodes, 2)),
        yaw=np.zeros(episodes),
        foot_xy=np.zeros((episodes, 4, 2)),
        foot_contact=np.zeros((episodes, 4), bool),
        reward_terms=terms,
        commanded=host.commands is not None,
        mass=float(host.layout.mass),
    )
    values = evaluation.episode_values(stats, host.dt, num_steps)
    course = host.terrain.course_end_x is not None
    for episode in values:
        episode["success"] = episode["finished_course"] if course else not episode["fell"]
        episode["reset_seed"] = [seed, episode["index"]]
    setup = {
        "engine": "mujoco",
        "policy": pilot.name,
        "policy_kind": pilot.spec.source_kind,
        "policy_env_steps": pilot.spec.env_steps,
        "robot": host.robot.provenance(),
        "terrain": host.terrain.spec,
        "course_end_x": host.terrain.course_end_x,
        "num_envs": episodes,
        "seconds": num_steps * host.dt,
        "num_steps": num_steps,
        "control_dt": host.dt,
        "seed": seed,
        "commands": host.config.commands.spec,
        "obs_noise": obs_noise,
        "latency_s": host.latency_s,
        "latency_physics_steps": host.latency_steps,
        "physics": host.physics,
        "env": pilot.config.to_dict() | {"terrain": host.terrain.spec},
        "wall_time_s": time.monotonic() - started,
        "versions": {"mujoco": mujoco.__version__, "numpy": np.__version__}
        | _onnxruntime_version(pilot),
    }
    head = {"format": report.FORMAT, "format_version": rollout.FORMAT_VERSION}
    summary = head | evaluation.aggregate(values, stats) | {"setup": setup}
    return evaluation.Evaluation(summary=summary, episodes=values)


def _onnxruntime_version(pilot: host_robot.Pilot) -> dict[str, str]:
    """{"onnxruntime": version} for a pilot that runs ONNX Runtime, else {}."""
    if not isinstance(pilot.policy, OnnxPolicy):
        return {}
    import onnxruntime

    return {"onnxruntime": onnxruntime.__version__}


# --- the command lines' policy flags ------------------------------------------------------------


def policy_parser(prog: str, description: str, policy_help: str) -> argparse.ArgumentParser:
    """A CLI parser with --policy, --terrain, --robot and --seed whose errors are
    `cli.UsageError`s, reported as one line; env options `--env.KEY=VALUE` are read by
    `parse_command`."""
    parser = argparse.ArgumentParser(
        prog=prog,
        description=description,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Env options: --env.KEY=VALUE (e.g. --env.fall_max_roll=1.0); see"
        " quadcos.env.default_config(). An unknown key is an error.",
    )
    parser.add_argument("--policy", help=policy_help)
    parser.add_argument(
        "--terrain", help="terrain name or spec (default: the policy's training terrain; flat)"
    )
    parser.add_argument(
        "--robot",
        help="the quadruped of fixed:... parameters (quadcos, quad12, an MJCF path,"
        " menagerie:NAME); a trained policy drives its own",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the reset noise")
    parser.add_argument(
        "--commands",
        help="velocity commands of a policy trained with them: 'random' (the training"
        " distribution) or a schedule 'v,w@s;...' (forward speed m/s, yaw rate rad/s, seconds),"
        " e.g. --commands='0.5,0@5;1.0,0@5;0.6,0.4@5;0,0@5' (quoted: ';' ends a shell command;"
        " default: the policy's own)",
    )
    return cli.raising(parser)



def host_parser(prog: str, description: str) -> argparse.ArgumentParser:
    """`policy_parser` for the commands that run a policy in C MuJoCo (`play`, `sim2sim`): every
    kind of policy, and --physics, C MuJoCo's solver."""
    parser = policy_parser(
        prog,
        description,
        policy_help="run or policy directory, gait:DIRECTORY (its zero action), exported .npz or"
        " .onnx, or fixed:trot",
    )
    parser.add_argument(
        "--physics",
        type=solver.physics_choice,
        default="reference",
        help="C MuJoCo's solver: the MJCF's iterations (reference, converged), the training"
        " shortcut's (training), or N/M solver / line-search iterations",
    )
    return parser

def parse_command(
    parser: argparse.ArgumentParser, argv: Sequence[str] | None
) -> tuple[argparse.Namespace, dict[str, Any]]:
    """(flags, env overrides) of a command line: `--env.KEY=VALUE` items read by
    `quadcos._util.overrides.parse_overrides` (as `train` reads `--config.KEY=VALUE`), keys
    checked against the env config; --robot is the override "robot"; --commands parsed.

    Raises:
      ValueError: a flag, item or key that is not known, or a bad --commands spec.
    """
    args, rest = parser.parse_known_args(argv)
    overrides = parse_overrides(rest, "env", env_lib.default_config())
    if getattr(args, "commands", None) is not None:
        env_commands.parse_commands(args.commands)  # a bad spec fails before any work
    if getattr(args, "robot", None) is not None:
        overrides["robot"] = args.robot
    return args, overrides


def summary_line(summary: Mapping[str, Any], engine: str, out: Any = None) -> str:
    """The evaluation in one line: episodes, survival, speed (on a course, how many episodes the
    time limit ended before its end), the command tracking where the robots followed commands,
    and where the JSON went."""
    where = " in C MuJoCo" if engine == "mujoco" else ""
    episodes = summary["num_episodes"]
    line = (
        f"{episodes} episode{'' if episodes == 1 else 's'} on {summary['setup']['terrain']}{where}:"
        f" success {summary['success_rate']:.3f}, falls {summary['fall_rate']:.3f}, speed"
        f" {summary['mean_forward_speed']:.3f} m/s"
    )
    if summary["setup"].get("course_end_x") is not None:
        short = round(episodes * (1.0 - summary["success_rate"] - summary["fall_rate"]))
        if short > 0:
            line += f", {short} out of time before the course's end"
    if summary.get("speed_tracking_rms") is not None:
        line += (
            f", tracking {summary['speed_tracking_rms']:.3f} m/s,"
            f" {summary['yaw_rate_tracking_rms']:.3f} rad/s RMS"
        )
    return line + (f" -> {out}" if out else "")
