"""`python -m quadcos.train`: train the paper's rhythm controller with SAC on a terrain.

    python -m quadcos.train --terrain=slope5 --preset=gpu --output_dir=runs/slope5
    python -m quadcos.train --output_dir=runs/slope5 --resume --num_timesteps=20000000
    python -m quadcos.train --preset=smoke --config.sac.batch_size=128 --config.env.reward.yaw=0

Every value of the resolved config (`--print_config` shows it) can be overridden with
`--config.<dotted.key>=<value>` (a group key such as `--config.sac.learning_rate=1e-3` sets all
of its values). Bad flags, values or terrain specs exit with one line on stderr and status 2,
before anything is written. stdout carries only the config JSON (`--print_config`) or the run
directory at the end; logs and progress go to stderr.
"""

import argparse
import json
import logging
import os
import pathlib
import sys
from collections.abc import Sequence
from typing import Any

import ml_collections

from quadcos import env as env_lib
from quadcos import evaluation
from quadcos import terrain as terrain_lib
from quadcos import training
from quadcos._util import caches, cli, provenance, quiet
from quadcos._util.cli import UsageError
from quadcos._util.overrides import parse_value
from quadcos.deploy import calibration
from quadcos.evaluation import gait_search
from quadcos.training import host, parallel, population, reuse, run_dirs
from quadcos.training.presets import PRESETS, build_config, default_config  # noqa: F401 (re-exported)

# Short flags -> the config key each one sets.
FLAGS = {
    "terrain": "env.terrain",
    "num_envs": "sac.num_envs",
    "num_timesteps": "sac.num_timesteps",
    "seed": "sac.seed",
    "reward": "env.reward_variant",
    "controller": "env.controller",
    "save_replay": "sac.save_replay",
    "num_devices": "sac.num_devices",
    "robot": "env.robot",
    "max_seconds": "sac.max_seconds",
}


logger = logging.getLogger("quadcos.train")  # also when run as __main__


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m quadcos.train",
        allow_abbrev=False,  # a flag is its whole name: --population's members drop theirs by it
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=(
            "Any config value: --config.KEY=VALUE, e.g. --config.sac.batch_size=1024, "
            "--config.env.control_dt=0.01, --config.sac.hidden_sizes.policy='(64, 64)'. "
            "Known keys: --print_config."
        ),
    )
    parser.add_argument(
        "--terrain",
        help=(
            f"terrain: {', '.join(terrain_lib.names())}, sections:ANGLE@LENGTH,...,"
            " random:max_deg=DEG,... (random courses), testset:SEED (held-out courses),"
            " heightfield:FILE.npy;x_range=MIN,MAX;y_range=MIN,MAX, or MODULE:NAME (a Terrain,"
            " factory or registered name from your module) (default: flat)"
        ),
    )
    parser.add_argument(
        "--robot",
        help=(
            "the quadruped: quadcos (the paper's, default), quad12, an MJCF path, menagerie:NAME"
            " (MuJoCo Menagerie; MENAGERIE_ROOT=DIR reads DIR/NAME) or a registered name"
        ),
    )
    parser.add_argument("--num_envs", type=int, help="parallel training envs")
    parser.add_argument(
        "--num_timesteps", type=int, help="total env steps (raise it with --resume to extend a run)"
    )
    parser.add_argument("--seed", type=int, help="seed of everything random")
    parser.add_argument(
        "--max_seconds",
        type=float,
        help="time budget from the process's start, s: the run then ends as at --num_timesteps"
        " (evaluation, checkpoint, policy/, policy_best/)",
    )
    parser.add_argument("--gait_from", metavar="DIR", help="start from the gait of DIR, a run or"
                        " policy directory (its action centre and feed-forward): no gait search")
    parser.add_argument("--output_dir", help="run directory (config, metrics, checkpoints, policy)")
    parser.add_argument(
        "--numbered",
        action="store_true",
        help=(
            "when --output_dir already holds files, start the new run in the first free DIR-2,"
            " DIR-3, ... (ignored with --resume)"
        ),
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue from the latest good checkpoint in --output_dir",
    )
    parser.add_argument(
        "--save_replay",
        action="store_true",
        help="store the replay buffer in checkpoints (exact resume)",
    )
    parser.add_argument(
        "--reward", choices=("full", "xy"), help="full: Eq. 13; xy: Fig. 9's r_xy ablation"
    )
    parser.add_argument(
        "--controller",
        choices=env_lib.CONTROLLERS,
        help="oscillator (paper) or joint (DRL-only baseline)",
    )
    parser.add_argument(
        "--preset",
        choices=tuple(PRESETS),
        default="cpu",
        help="smoke (tiny), cpu (default), gpu (from the trot), scratch (from no gait), any_slope,"
        " robust (randomised), command (follows velocity commands): docs/training.md's table",
    )
    parser.add_argument(
        "--num_devices",
        type=int,
        help="devices to spread the run over, data-parallel (default: all, of every process)",
    )
    parser.add_argument(
        "--coordinator",
        metavar="HOST:PORT",
        help="several processes (hosts): process 0's address, for jax.distributed.initialize",
    )
    parser.add_argument("--num_processes", type=int, help="with --coordinator: processes in all")
    parser.add_argument("--process_id", type=int, help="with --coordinator: this one, 0 to N-1")
    _population_flags(parser)
    parser.add_argument(
        "--print_config", action="store_true", help="print the resolved config as JSON and exit"
    )
    parser.add_argument(
        "--no_progress", action="store_true", help="plain log lines even on a terminal"
    )
    parser.add_argument(
        "--verbose",
        action="store_true",
        help="let Warp print its line per kernel module loaded (silenced by default)",
    )
    return parser


def _population_flags(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--population",
        type=int,
        metavar="N",
        help="N runs of this command, a GPU and a seed each (seed, seed + 1, ...), in"
        " DIR/member_I; the best on --population_terrain is copied to DIR/policy_best",
    )
    parser.add_argument(
        "--population_terrain",
        help="where --population compares its members (default: the run's terrain; testset:4242"
        " for random courses)",
    )
    parser.add_argument(
        "--population_envs", type=int, default=1024, help="--population: episodes a member"
    )
    parser.add_argument(
        "--population_seconds",
        type=float,
        help="--population: episode length, s (default: 40 on a test set's courses, else 20)",
    )


def resolve(argv: Sequence[str]) -> tuple[argparse.Namespace, dict[str, Any]]:
    """Parse the command line into (flags, the config overrides it names). Raises UsageError."""
    parser = cli.raising(_parser())  # one line, no SystemExit from inside the library
    args, rest = parser.parse_known_args(argv)
    overrides, flags = {}, {}
    for flag, key in FLAGS.items():
        value = getattr(args, flag)
        if value is not None and value is not False:
            overrides[key], flags[key] = value, flag
    for item in rest:
        if not item.startswith("--config.") or "=" not in item:
            raise UsageError(
                f"unrecognised argument {item!r} (config overrides look like --config.sac.batch_size=1024)"
            )
        key, text = item[len("--config.") :].split("=", 1)
        if key in flags:
            raise UsageError(f"--{flags[key]} and --config.{key} set the same value: give one")
        overrides[key] = parse_value(text)
    if args.gait_from:
        gait = _gait_from(args.gait_from)
        if given := sorted(set(gait) & set(overrides)):
            raise UsageError(f"--gait_from and --config.{given[0]} set the same value: give one")
        overrides |= gait
    return args, overrides


def _gait_from(path: str) -> dict[str, Any]:
    """`--gait_from`'s env overrides: the gait (action centre, feed-forward) of the run or policy
    directory at `path`. Raises UsageError naming it where it holds none."""
    from quadcos.training import run_config as runs

    try:
        return runs.gait_of(path)
    except (FileNotFoundError, ValueError) as error:
        raise UsageError(f"--gait_from: {error}") from None


def main(argv: Sequence[str] | None = None, trainers: reuse.Trainers | None = None) -> int:
    """CLI entry point; returns the exit status. `trainers`: the envs and trainers of the
    caller's earlier runs (`training.Trainers`), reused by a run of the same programs and given
    this run's."""
    argv = sys.argv[1:] if argv is None else list(argv)
    # Read when JAX starts its backend (building the env), so it is set before anything else.
    os.environ.setdefault("XLA_FLAGS", "--xla_gpu_triton_gemm_any=true")
    with cli.logging_to_stderr("quadcos.train"):
        return _main(argv, trainers)


def _main(argv: list[str], trainers: reuse.Trainers | None) -> int:
    startup = host.StartUp(provenance.process_start())
    startup.mark("imports")
    cache_dirs = caches.enable()
    try:
        args, overrides = resolve(argv)
        quiet.quiet_warp(args.verbose)  # before anything loads a Warp module
        run_dir = pathlib.Path(args.output_dir) if args.output_dir else None
        run_info = {"argv": argv}
        if args.resume:
            saved = _saved_config(run_dir)
            config = build_config(saved, overrides)
            run_info = _resumed(run_dir, saved, overrides, argv)
        else:
            config = build_config(PRESETS[args.preset], overrides)
        selection = _population_selection(args, config)  # before --print_config: checked either way
        if args.print_config:
            print(json.dumps(config.to_dict(), indent=2))
            return 0
        if args.resume and (
            message := run_dirs.finished_run_message(run_dir, config.sac.num_timesteps)
        ):
            logger.info("%s", message)
            return 0
        if selection is not None:
            return _population(argv, args, config, run_dir, selection)
        if args.numbered and args.coordinator:
            raise UsageError(
                "--numbered with --coordinator: give every process the same --output_dir"
            )
        parallel.initialize_distributed(args.coordinator, args.num_processes, args.process_id)
        writer = parallel.is_writer()  # the other processes neither check nor number run_dir
        if args.numbered and not args.resume and run_dir is not None and writer:
            run_dir = run_dirs.numbered_dir(run_dir)
        if writer or run_dir is None:
            run_dirs.check_output_dir(run_dir, args.resume)
        result = training.run(
            config,
            run_dir,
            resume=args.resume,
            trainers=trainers,
            find_gait=calibration.find_gait,
            progress_bar=not args.no_progress,
            extra_run_info={**run_info, "caches": cache_dirs},
            started_at=provenance.process_start(),
            startup=startup,
        )
    except (UsageError, ValueError, FileNotFoundError) as error:  # training.ConfigError too
        cli.print_error("quadcos.train", error)
        return 2
    except (gait_search.NoGaitFound, training.NonFiniteLossError) as error:
        cli.print_error("quadcos.train", error)
        return 1
    if writer:
        logger.info("env step %s: policy in %s", f"{result.env_steps:,}", run_dir / "policy")
        print(run_dir)
    return 0


def _population_selection(
    args: argparse.Namespace, config: ml_collections.ConfigDict
) -> tuple[str, float] | None:
    """Where and on how long episodes `--population` compares its members (terrain spec, s),
    its flags checked; None without `--population` (whose own flags then may not be given)."""
    if args.population is None:
        given = [
            f"--{name}" for name in ("population_terrain", "population_envs", "population_seconds")
            if getattr(args, name) != _parser().get_default(name)
        ]
        if given:
            raise UsageError(f"{', '.join(given)}: for --population only")
        return None
    if args.population < 2:
        raise UsageError(f"--population runs at least 2 members, not {args.population}")
    if args.resume or args.coordinator:
        raise UsageError("--population starts new runs: not with --resume or --coordinator")
    if os.environ.get(population.MEMBER_ENV):
        raise UsageError("--population inside a population's member: a member is one run")
    select = args.population_terrain or population.selection_terrain(config.env.terrain)
    seconds = args.population_seconds
    if seconds is None:
        seconds = population.selection_seconds(select)
    if args.population_envs < 1 or seconds <= 0:
        raise UsageError("--population_envs and --population_seconds must be positive")
    terrain_lib.parse(select)  # a bad spec is refused now, not after the training
    return select, seconds


def _population(
    argv: list[str], args: argparse.Namespace, config, run_dir, selection: tuple[str, float]
) -> int:
    """`--population=N` (training.population): its members run, then the best is kept."""
    select, seconds = selection
    if args.numbered and run_dir is not None:
        run_dir = run_dirs.numbered_dir(run_dir)
    run_dirs.check_output_dir(run_dir, resume=False)

    def compare(policy: pathlib.Path) -> dict[str, Any]:  # after the members: the GPUs are free
        return evaluation.evaluate(
            str(policy), select, num_envs=args.population_envs, seconds=seconds
        ).summary

    status = population.run(argv, args.population, run_dir, int(config.sac.seed), select, compare)
    if status == 0:
        print(run_dir)
    return status


def _saved_config(run_dir: pathlib.Path | None) -> dict[str, Any]:
    """The flattened config a run was trained with (its config.json, migrated), to resume it."""
    from quadcos.training import run_config as runs

    path = run_dir / "config.json" if run_dir else None
    if path is None or not path.is_file():
        raise UsageError(f"--resume: {run_dir} holds no run to resume (no config.json)")
    try:
        return runs.load_run_config(path)
    except ValueError as error:
        raise UsageError(
            f"--resume: {path} cannot be read, likely truncated or not a quadcos run config"
            f" ({error})"
        ) from None


def _resumed(
    run_dir: pathlib.Path, saved: dict[str, Any], overrides: dict[str, Any], argv: list[str]
) -> dict[str, Any]:
    """What a resumed run keeps in its run_info: the first command's argv and every resume's
    (`resumed_argv`); warns of the values the resume changes beyond the run's length."""
    extends = ("sac.num_timesteps", "sac.max_seconds")
    changed = [
        f"{key} {saved[key]!r} -> {value!r}"
        for key, value in overrides.items()
        if key in saved and key not in extends and json.dumps(saved[key]) != json.dumps(value)
    ]
    if changed:
        logger.warning("resuming with changed values: %s", ", ".join(changed))
    before = json.loads((run_dir / "config.json").read_text()).get("run_info", {})
    return {
        "argv": before.get("argv", argv),
        "resumed_argv": [*before.get("resumed_argv", []), argv],
    }


if __name__ == "__main__":
    cli.exit_process(main())
