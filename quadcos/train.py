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
import ast
import contextlib
import json
import logging
import math
import os
import pathlib
import re
import sys
from collections.abc import Iterator, Sequence
from typing import Any

import jax
import ml_collections

from quadcos import caches, cli, run_dirs
from quadcos import env as env_lib
from quadcos import gait_search, oscillator, provenance
from quadcos import terrain as terrain_lib
from quadcos.cli import UsageError
from quadcos.training import parallel
from quadcos.overrides import apply_overrides, flat_keys

# Presets: overrides of the default config, applied before the flags.
# SAC set up to start from the env's action centre (the fixed trot, or the gait a search found) and
# explore around it: a fresh
# policy's mean is the centre with a small exploration std, the prefill acts with it, and the
# actor waits until the critics have seen its data (experiments/README.md, "learning to walk").
_START_FROM_THE_TROT: dict[str, Any] = {
    "sac.policy_output_scale": 0.01,
    "sac.init_std": 0.15,
    "sac.init_alpha": 0.01,
    "sac.prefill_actions": "policy",
    "sac.actor_warmup_steps": 2_000,
}

PRESETS: dict[str, dict[str, Any]] = {
    # A complete, tiny run (a few minutes on two CPU cores, mostly compilation); used by tests.
    "smoke": {
        "sac.num_envs": 4,
        "sac.num_timesteps": 1_024,
        "sac.episode_length": 100,
        "sac.batch_size": 32,
        "sac.replay_size": 4_096,
        "sac.min_replay_size": 256,
        "sac.hidden_sizes.policy": (32, 32),
        "sac.hidden_sizes.q": (32, 32),
        "sac.steps_per_chunk": 32,
        "sac.eval_interval": 512,
        "sac.num_eval_envs": 2,
        "sac.eval_episode_length": 50,
        "sac.checkpoint_interval": 512,
    },
    # The paper's flat experiment at CPU scale: `make train`.
    "cpu": {
        "sac.num_envs": 32,
        "sac.num_timesteps": 200_000,
        "sac.episode_length": 500,
        "sac.batch_size": 256,
        # 4 updates per env step lose the trot at the actor's first updates and end no faster
        # than it; 12 learn past it (experiments/make_train/sweep).
        "sac.updates_per_step": 12,
        "sac.replay_size": 200_000,
        "sac.min_replay_size": 4_096,
        "sac.hidden_sizes.policy": (128, 128),
        "sac.hidden_sizes.q": (128, 128),
        **_START_FROM_THE_TROT,
        "sac.reward_scaling": 0.1,
        "sac.learning_rate.actor": 3e-4,
        "sac.learning_rate.critic": 1e-3,
        "sac.learning_rate.alpha": 1e-3,
        "sac.steps_per_chunk": 100,
        "sac.eval_interval": 50_000,
        "sac.num_eval_envs": 16,
        "sac.eval_episode_length": 500,
        "sac.checkpoint_interval": 50_000,
    },
    # The fast path: thousands of robots on one GPU.
    "gpu": {
        "sac.num_envs": 4_096,
        "sac.num_timesteps": 10_000_000,
        "sac.episode_length": 1_000,
        "sac.batch_size": 8_192,
        # 1 update per step loses the trot at the actor's first updates; 8 learns
        # (experiments/flat_gpu).
        "sac.updates_per_step": 8,
        "sac.replay_size": 4_000_000,
        "sac.min_replay_size": 65_536,
        "sac.hidden_sizes.policy": (256, 256),
        "sac.hidden_sizes.q": (256, 256),
        **_START_FROM_THE_TROT,
        "sac.reward_scaling": 0.1,
        "sac.learning_rate.actor": 3e-4,
        "sac.learning_rate.critic": 1e-3,
        "sac.learning_rate.alpha": 1e-3,
        "sac.steps_per_chunk": 50,
        "sac.eval_interval": 2_000_000,
        "sac.num_eval_envs": 1_024,
        "sac.eval_episode_length": 400,
        "sac.checkpoint_interval": 2_000_000,
    },
}
# From scratch on one GPU (experiments/from_scratch): no gait is given. The run first searches
# constant rhythm parameters (quadcos.gait_search, a few seconds on a GPU), then SAC starts from
# the gait found, exploring around it as the trot start does around the trot. Eq. 9's r_s is paid
# only while the robot moves (≥ 0.1 m/s, low-passed over 1 s): paid for standing too, SAC
# unlearns the found gait and stands (experiments/from_scratch, run scratch_alive_s0). 20 M env
# steps (about 3 minutes on an H100 with Warp): speed and pitch error still improve after 10 M;
# the policy of the best evaluation is kept beside the last, which one seed lost in its last
# million steps (experiments/from_scratch, "20 M env steps").
PRESETS["scratch"] = {
    **PRESETS["gpu"],
    "env.action_centre": "search",
    "env.survival_min_speed": 0.1,
    "sac.num_timesteps": 20_000_000,
    "sac.eval_interval": 1_000_000,
    "sac.keep_best_policy": True,
}

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
}


logger = logging.getLogger("quadcos.train")  # also when run as __main__


def default_config() -> ml_collections.ConfigDict:
    """The whole run's config: {"env": env config, "sac": trainer config}."""
    from quadcos.training.config import default_config as sac_config

    config = ml_collections.ConfigDict()
    config.env = env_lib.default_config()
    config.sac = sac_config()
    return config


def _parse_value(text: str) -> Any:
    """A flag value as a Python literal when it is one (1e-3, (64, 64), True), a float for nan
    and inf, else a string."""
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        pass
    try:
        return float(text)
    except ValueError:
        return text


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m quadcos.train",
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
            " heightfield:FILE.npy;x_range=MIN,MAX;y_range=MIN,MAX, or MODULE:NAME (a Terrain,"
            " factory or registered name from your module) (default: flat)"
        ),
    )
    parser.add_argument("--num_envs", type=int, help="parallel training envs")
    parser.add_argument(
        "--num_timesteps", type=int, help="total env steps (raise it with --resume to extend a run)"
    )
    parser.add_argument("--seed", type=int, help="seed of everything random")
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
        help="sizes for: smoke (tiny test run), cpu (default), gpu",
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
    parser.add_argument(
        "--print_config", action="store_true", help="print the resolved config as JSON and exit"
    )
    parser.add_argument(
        "--no_progress", action="store_true", help="plain log lines even on a terminal"
    )
    return parser


def resolve(argv: Sequence[str]) -> tuple[argparse.Namespace, dict[str, Any]]:
    """Parse the command line into (flags, the config overrides it names). Raises UsageError."""
    parser = cli.raising(_parser())  # one line, no SystemExit from inside the library
    args, rest = parser.parse_known_args(argv)
    overrides = {}
    for flag, key in FLAGS.items():
        value = getattr(args, flag)
        if value is not None and value is not False:
            overrides[key] = value
    for item in rest:
        if not item.startswith("--config.") or "=" not in item:
            raise UsageError(
                f"unrecognised argument {item!r} (config overrides look like --config.sac.batch_size=1024)"
            )
        key, text = item[len("--config.") :].split("=", 1)
        overrides[key] = _parse_value(text)
    return args, overrides


def build_config(base: dict[str, Any], overrides: dict[str, Any]) -> ml_collections.ConfigDict:
    """default_config() with `base` then `overrides` applied, then checked (terrain spec, env and
    trainer values) so that a bad value is reported before anything is built or written."""
    from quadcos import training

    try:
        config = apply_overrides(default_config(), base)
        overrides = _expand_groups(overrides, flat_keys(config))
        centre = overrides.get("env.action_centre")
        if isinstance(centre, tuple) and all(isinstance(v, (int, float)) for v in centre):
            overrides["env.action_centre"] = oscillator.centre_spec(centre)  # A_k,A_h,T,φ1,φ3
        non_finite = {
            key: value
            for key, value in overrides.items()
            if isinstance(value, float) and not math.isfinite(value)
        }
        finite = {key: value for key, value in overrides.items() if key not in non_finite}
        config = apply_overrides(config, finite)
        # apply_overrides refuses non-finite floats before any range check: set them here, so
        # that the checks below name the allowed range.
        for key, value in non_finite.items():
            try:
                apply_overrides(config, {key: 1.0})  # the key exists and takes floats
            except ValueError:
                apply_overrides(config, {key: value})  # raises naming the key and the value
            *parents, leaf = key.split(".")
            node = config
            for parent in parents:
                node = node[parent]
            node[leaf] = value
        terrain_lib.parse(config.env.terrain)
        env_lib.validate_config(config.env)
        try:
            training.check_config(config.sac)
        except training.ConfigError as error:  # it names fields as config.<sac key>
            raise ValueError(re.sub(r"\bconfig\.", "config.sac.", str(error))) from None
        if non_finite:  # in range, as far as the checks above know
            key, value = next(iter(non_finite.items()))
            raise ValueError(f"bad value {value} for config key {key!r}: it must be finite")
    except (ValueError, TypeError) as error:
        raise UsageError(str(error)) from None
    return config


def _expand_groups(overrides: dict[str, Any], known: list[str]) -> dict[str, Any]:
    """A group key (`sac.learning_rate`) as each of its values (`sac.learning_rate.actor`, ...)."""
    expanded = {}
    for key, value in overrides.items():
        members = [name for name in known if name.startswith(key + ".")]
        expanded |= dict.fromkeys(members, value) if members and key not in known else {key: value}
    return expanded


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    # Read when JAX starts its backend (building the env), so it is set before anything else.
    os.environ.setdefault("XLA_FLAGS", "--xla_gpu_triton_gemm_any=true")
    with _logging_to_stderr():
        return _main(argv)


def _main(argv: list[str]) -> int:
    cache_dirs = caches.enable()
    try:
        args, overrides = resolve(argv)
        run_dir = pathlib.Path(args.output_dir) if args.output_dir else None
        if args.resume:
            config = build_config(_saved_config(run_dir), overrides)
        else:
            config = build_config(PRESETS[args.preset], overrides)
        if args.print_config:
            print(json.dumps(config.to_dict(), indent=2))
            return 0
        if args.resume and (message := run_dirs.finished_run_message(run_dir, config.sac.num_timesteps)):
            logger.info("%s", message)
            return 0
        if args.numbered and args.coordinator:
            raise UsageError("--numbered with --coordinator: give every process the same --output_dir")
        parallel.initialize_distributed(args.coordinator, args.num_processes, args.process_id)
        _physics_for_devices(config)
        writer = parallel.is_writer()  # the other processes neither check nor number run_dir
        if args.numbered and not args.resume and run_dir is not None and writer:
            run_dir = run_dirs.numbered_dir(run_dir)
        if writer or run_dir is None:
            run_dirs.check_output_dir(run_dir, args.resume)
        # Warp's contact buffer is shared by a batch's worlds: size it for the largest batch.
        config.env.warp.max_envs = max(
            config.env.warp.max_envs,
            config.sac.num_envs,
            config.sac.num_eval_envs,
            gait_search.search_envs(config),
        )
        search = gait_search.resolve_centre(config, run_dir)  # None: a centre was given
        env = env_lib.QuadrupedEnv(
            config.env.terrain, ml_collections.ConfigDict(config.env.to_dict())
        )
        # Evaluations start at the spawn point (as quadcos.evaluate's do).
        eval_env = env
        if config.env.spawn_x_max > 0:
            eval_env = env_lib.QuadrupedEnv(
                config.env.terrain,
                ml_collections.ConfigDict({**config.env.to_dict(), "spawn_x_max": 0.0}),
            )
    except (UsageError, ValueError, FileNotFoundError) as error:
        cli.print_error("quadcos.train", error)
        return 2
    except gait_search.NoGaitFound as error:
        cli.print_error("quadcos.train", error)
        return 1

    from quadcos import training

    try:
        result = training.train(
            env,
            config.sac,
            run_dir,
            eval_env=eval_env,
            resume=args.resume,
            progress_bar=not args.no_progress,
            extra_run_info={
                "env": config.env.to_dict(),
                "argv": argv,
                "impl": env.impl,
                "caches": cache_dirs,
                **({"gait_search_s": search["setup"]["wall_time_s"]} if search else {}),
            },
            started_at=provenance.process_start(),
        )
    except training.ConfigError as error:  # raised before anything is written
        cli.print_error("quadcos.train", error)
        return 2
    except training.NonFiniteLossError as error:
        cli.print_error("quadcos.train", error)
        return 1
    if writer:
        logger.info("env step %s: policy in %s", f"{result.env_steps:,}", run_dir / "policy")
        print(run_dir)
    return 0


class _Formatter(logging.Formatter):
    def format(self, record: logging.LogRecord) -> str:
        level = "" if record.levelno < logging.WARNING else f"{record.levelname.lower()}: "
        return f"quadcos.train: {level}{record.getMessage()}"


@contextlib.contextmanager
def _logging_to_stderr() -> Iterator[None]:
    """quadcos's log records at INFO and above as "quadcos.train: ..." lines on stderr."""
    package_logger = logging.getLogger("quadcos")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_Formatter())
    saved = package_logger.level, package_logger.propagate
    package_logger.addHandler(handler)
    package_logger.setLevel(logging.INFO)
    package_logger.propagate = False
    try:
        yield
    finally:
        package_logger.removeHandler(handler)
        package_logger.level, package_logger.propagate = saved


def _physics_for_devices(config: ml_collections.ConfigDict) -> None:
    """Several devices take the JAX physics: MJX-Warp's kernels load on the first GPU only."""
    devices = config.sac.num_devices or len(jax.devices())
    if devices == 1 or config.env.impl == "jax":
        return
    if config.env.impl == "warp":
        raise UsageError(
            f"--config.env.impl=warp runs on one device, not {devices}: add --num_devices=1 or"
            " --config.env.impl=jax"
        )
    logger.info("%d devices: the JAX physics (MJX-Warp runs on one device only)", devices)
    config.env.impl = "jax"


def _saved_config(run_dir: pathlib.Path | None) -> dict[str, Any]:
    """The flattened config a run was trained with (its config.json, migrated), to resume it."""
    from quadcos import runs

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


if __name__ == "__main__":
    sys.exit(main())
