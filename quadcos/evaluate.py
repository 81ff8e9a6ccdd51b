"""Batched deterministic rollouts of a trained policy or fixed oscillator parameters.

    python -m quadcos.evaluate --policy=runs/slope5 --terrain=s4 --num_envs=1024 --seconds=30 \\
        --out=s4.json --trace=s4_trace.json --video=s4.mp4
    python -m quadcos.evaluate --policy=fixed:trot --terrain=slope5 --out=fixed.json   # Fig. 15
    python -m quadcos.evaluate --policy=fixed:0.4,0.15,0.6,pi/2,-pi/2 --out=fixed.json
    python -m quadcos.evaluate --search_fixed --terrain=flat --num_candidates=512 --out=search.json
    python -m quadcos.evaluate --render=s4_trace.json --video=s4.mp4     # a saved trace, here

`--policy` is a run directory, a policy directory (`quadcos.load_policy`), `gait:DIRECTORY` (the
zero action in that policy's env: the gait it started from), `fixed:trot`
(`oscillator.FIXED_TROT`) or `fixed:A_k,A_h,T,phi1,phi3` (rad, rad, s, rad, rad; `pi` allowed);
with `--engine=mujoco` also an exported .npz or .onnx (`quadcos.evaluation.PolicySpec`).
A trained policy runs in the env it was trained in (its saved env config), on its training
terrain unless `--terrain` names another; fixed parameters run in the default env. Env options
`--env.KEY=VALUE` go on top (values read as in `quadcos.train`: `true` is a bool); an unknown key
is an error. `--engine=mujoco` runs the episodes one after another in C MuJoCo
(`quadcos.sim2sim`'s engine, `quadcos.deploy.engines.evaluate`) and writes the same JSON.

An episode ends when the robot falls (the env's fall check), when `--seconds` have passed, or, on a
course (a terrain with `course_end_x`), when the torso passes the course end. Success: no fall and,
on a course, the course end reached within `--seconds`. Bad flags, policy paths or terrain specs
exit with one line on stderr and status 2, before anything is written; output files are written
atomically.

--out JSON (without it nothing is written; the summary line is printed either way): aggregates at
the top level — num_episodes, success_rate, fall_rate, course_completion_rate, mean_forward_speed
(m/s), std_forward_speed, mean_distance (m), mean_seconds, mean_max_abs_roll, mean_max_abs_yaw,
mean_max_abs_pitch_error (|pitch − slope|, rad), mean_lateral_drift (|Δy| at the episode's end,
m), mean_max_lateral_deviation (m), slope_error_rms (estimate − ground truth over all steps, rad),
mean_episode_reward (Eq. 13 summed), mean_reward_terms — then "setup" (policy, terrain, sizes, env
config, versions) and "episodes" (one dict per episode: success, fell, fall_time_s,
finished_course, finish_time_s, seconds, distance, forward_speed, lateral_drift, max_abs_roll,
..., episode_reward, reward_terms).
--trace JSON: one episode's series (see `quadcos.evaluation.trace_dict`), its positions and env
config.

The work is done by `quadcos.evaluation`; this module is its command line.
"""

import argparse
import logging
import math
import pathlib
import sys
import tempfile
import time
from collections.abc import Sequence
from typing import Any

from quadcos import evaluation
from quadcos._util import caches, cli, quiet
from quadcos.deploy import engines
from quadcos.evaluation.fixed_search import SPEED_FLOOR_OF
from quadcos.viz import video

_PROG = "quadcos.evaluate"


def _parser() -> argparse.ArgumentParser:
    parser = engines.policy_parser(
        "python -m quadcos.evaluate",
        __doc__,
        policy_help="run or policy directory, gait:DIRECTORY (its zero action), fixed:trot or"
        " fixed:A_k,A_h,T,phi1,phi3 (and with --engine=mujoco an exported .npz or .onnx)",
    )
    parser.add_argument("--num_envs", type=int, default=64, help="episodes, all run at once")
    parser.add_argument("--seconds", type=float, default=20.0, help="time limit of an episode, s")
    parser.add_argument("--out", help="evaluation (or search) JSON to write")
    parser.add_argument("--trace", help="JSON of one episode's time series to write")
    parser.add_argument("--trace_episode", type=int, default=0, help="which episode to trace")
    parser.add_argument("--video", help="mp4 of the traced episode (headless: EGL or OSMesa)")
    parser.add_argument("--video_size", default="640x360", help="WIDTHxHEIGHT in pixels")
    parser.add_argument(
        "--render",
        metavar="TRACE",
        help="render a saved --trace JSON to --video (e.g. a trace written on a GPU machine)",
    )
    parser.add_argument(
        "--search_fixed",
        action="store_true",
        help="search the best fixed rhythm parameters instead of evaluating --policy",
    )
    parser.add_argument("--num_candidates", type=int, default=256, help="search: per round")
    parser.add_argument("--robots_per_candidate", type=int, default=4, help="search")
    parser.add_argument(
        "--min_speed", type=float, default=0.0, help="search: m/s a ranked gait reaches (0: any)"
    )
    parser.add_argument(
        "--min_speed_of",
        choices=tuple(SPEED_FLOOR_OF),
        default="mean",
        help="search: --min_speed holds for the candidate's robots' mean speed or its slowest's",
    )
    parser.add_argument(
        "--max_attitude",
        type=float,
        default=0.0,
        help="search: rad a ranked gait's mean peak roll and pitch error stay within (0: any)",
    )
    parser.add_argument("--rounds", type=int, default=3, help="search: rounds of refinement")
    parser.add_argument(
        "--confirm_robots",
        type=int,
        default=0,
        help="search: rerun the best candidates on this many robots each and rank by that (0: no)",
    )
    parser.add_argument(
        "--engine",
        choices=engines.ENGINES,
        default="mjx",
        help="mjx: batched on the device (default); mujoco: the same controller path in C MuJoCo,"
        " episode after episode (quadcos.sim2sim)",
    )
    parser.add_argument("--no_progress", action="store_true", help="no progress on stderr")
    return parser


_SEARCH_FLAGS = ("num_candidates", "robots_per_candidate", "min_speed", "min_speed_of",
                 "max_attitude", "rounds", "confirm_robots")


def _parse_args(argv: Sequence[str]) -> tuple[argparse.Namespace, dict[str, Any]]:
    args, overrides = engines.parse_command(_parser(), argv)
    modes = [args.policy is not None, args.search_fixed, args.render is not None]
    if sum(modes) != 1:
        raise cli.UsageError("give exactly one of --policy, --search_fixed and --render")
    if args.render is not None:
        if args.video is None or args.out or args.trace:
            raise cli.UsageError("--render TRACE.json takes --video OUT.mp4 (and no --out, --trace)")
        if not pathlib.Path(args.render).is_file():
            raise cli.UsageError(f"--render {args.render}: no such file")
    if args.engine == "mujoco" and (args.search_fixed or args.render or args.trace or args.video):
        raise cli.UsageError("--engine=mujoco evaluates a --policy (--out, no --trace or --video)")
    if args.search_fixed and (args.trace or args.video):
        raise cli.UsageError("--trace and --video go with --policy, not --search_fixed")
    defaults = _parser().parse_args([])
    if not args.search_fixed and (given := [
        f"--{name}" for name in _SEARCH_FLAGS if getattr(args, name) != getattr(defaults, name)
    ]):
        raise cli.UsageError(f"{', '.join(given)}: search flags, for --search_fixed only")
    if args.num_envs < 1:
        raise cli.UsageError(f"--num_envs must be >= 1; got {args.num_envs}")
    if not (math.isfinite(args.seconds) and args.seconds > 0):
        raise cli.UsageError(f"--seconds must be finite and > 0; got {args.seconds}")
    if not 0 <= args.trace_episode < args.num_envs:
        raise cli.UsageError(
            f"--trace_episode must be in 0..{args.num_envs - 1}; got {args.trace_episode}"
        )
    width, x, height = args.video_size.partition("x")
    if not (x and width.isdigit() and height.isdigit()) or any(
        int(side) < 16 or int(side) % 2 for side in (width, height)
    ):
        raise cli.UsageError(
            f"--video_size must be WIDTHxHEIGHT, each even and >= 16; got {args.video_size!r}"
        )
    args.video_size = (int(width), int(height))
    for flag, suffix in (("out", ".json"), ("trace", ".json"), ("video", ".mp4")):
        value = getattr(args, flag)
        if value is None:
            continue
        path = pathlib.Path(value)
        if path.suffix.lower() != suffix:
            raise cli.UsageError(f"--{flag} must end in {suffix}; got {value}")
        if path.is_dir():
            raise cli.UsageError(f"--{flag} {value} is a directory")
        parent = path.absolute().parent
        if not parent.is_dir() or not _can_create_files_in(parent):
            raise cli.UsageError(f"--{flag} {value}: {parent} is not a writable directory")
    return args, overrides


def _can_create_files_in(directory: pathlib.Path) -> bool:
    """Whether a file can be created there: tried, not inferred (root passes `os.access` on
    /proc, where nothing can be created), so that no rollout runs for output that is lost."""
    try:
        with tempfile.NamedTemporaryFile(dir=directory, prefix=".quadcos-probe-"):
            return True
    except OSError:
        return False


class _Progress:
    """Steps done on stderr: one updating line on a terminal, else a line every 10 %; at 0 done
    (the inputs checked, nothing compiled yet) `starting`, if given."""

    def __init__(self, label: str, enabled: bool, unit: str = "steps", starting: str = ""):
        self.label, self.enabled, self.unit, self.starting = label, enabled, unit, starting
        self.terminal = sys.stderr.isatty()
        self.started = time.monotonic()
        self.last_tenth = -1

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        if done == 0:
            if self.starting:
                print(self.starting, file=sys.stderr, flush=True)
                self.starting = ""
            return
        line = f"{self.label}: {done}/{total} {self.unit} ({100 * done / total:.0f} %), {time.monotonic() - self.started:.0f} s"
        if self.terminal:
            print("\r" + line, end="\n" if done >= total else "", file=sys.stderr, flush=True)
        elif (tenth := 10 * done // total) > self.last_tenth:
            self.last_tenth = tenth
            print(line, file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status."""
    with cli.logging_to_stderr(_PROG, logging.WARNING):
        return _main(sys.argv[1:] if argv is None else list(argv))


def _main(argv: list[str]) -> int:
    try:
        args, overrides = _parse_args(argv)
        quiet.quiet_warp()  # before anything loads a Warp module
        caches.enable()  # JAX's and Warp's caches: a second run compiles nothing
        if args.render:
            width, height = args.video_size
            evaluation.render_trace(args.render, args.video, width=width, height=height)
            print(f"{args.render} -> {args.video}")
            return 0
        if args.search_fixed:
            search = evaluation.search_fixed(
                args.terrain or "flat",
                num_candidates=args.num_candidates,
                robots_per_candidate=args.robots_per_candidate,
                rounds=args.rounds,
                seconds=args.seconds,
                seed=args.seed,
                min_speed=args.min_speed,
                min_speed_of=args.min_speed_of,
                max_attitude=args.max_attitude,
                confirm_robots=args.confirm_robots,
                env_overrides=overrides,
                progress=_Progress("search", not args.no_progress),
            )
            if args.out:
                evaluation.write_json(args.out, search)
            best = search["ranking"][0]
            print(
                f"best: --policy={best['policy']} (score {best['score']}, fall rate {best['fall_rate']})"
            )
            return 0
        if args.video:
            video.check_video_support()
        compiling = f"{_PROG}: compiling the rollout..."
        progress = (
            _Progress("evaluate", not args.no_progress, starting=compiling)
            if args.engine == "mjx"
            else _Progress("C MuJoCo", not args.no_progress, "episodes")
        )
        result = engines.evaluate(
            args.policy,
            args.terrain,
            engine=args.engine,
            episodes=args.num_envs,
            seconds=args.seconds,
            seed=args.seed,
            env_overrides=overrides,
            trace_episode=args.trace_episode,
            progress=progress,
            commands=args.commands,
        )
    except (ValueError, FileNotFoundError, video.VideoError) as error:
        cli.print_error(_PROG, error)
        return cli.EXIT_USAGE
    if args.out:
        evaluation.write_json(args.out, result.to_json())
    if args.trace:
        evaluation.write_json(args.trace, result.trace)
    try:
        if args.video:
            width, height = args.video_size
            result.save_video(args.video, width=width, height=height)
    except video.VideoError as error:  # checked up front; seen only if rendering breaks midway
        cli.print_error(_PROG, error)
        return cli.EXIT_FAILURE
    summary = result.summary
    if "courses" in summary:
        print(evaluation.course_table(summary))
    print(engines.summary_line(summary, args.engine, args.out))
    return 0


if __name__ == "__main__":
    cli.exit_process(main())
