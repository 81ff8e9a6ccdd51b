"""What a bench run measures and at which sizes (`Settings`, `BENCH_PRESETS`), and the env and
trainer config of a `quadcos.train` preset that it measures with."""

import argparse
import dataclasses
from typing import Any

import ml_collections

from quadcos import env as env_lib
from quadcos import terrain as terrain_lib
from quadcos import training
from quadcos._util.overrides import apply_overrides, parse_value
from quadcos.equations import oscillator
from quadcos.training.presets import PRESETS as TRAIN_PRESETS

SECTIONS = ("physics", "gait", "env", "train", "stock", "walk", "slope5")


@dataclasses.dataclass(frozen=True)
class Course:
    """What a time-to-walk section trains on. Evaluations start at the spawn point (x = 0).

    Attributes:
      result_key: the key of the section's time in the results JSON.
      terrain: the training terrain spec.
      env: env overrides for training (not for evaluation).
      sac: trainer overrides.
    """

    result_key: str
    terrain: str
    env: dict[str, Any] = dataclasses.field(default_factory=dict)
    sac: dict[str, Any] = dataclasses.field(default_factory=dict)


# The walk section trains on flat as the preset does; the slope5 section as experiments/slope5 and
# experiments/from_scratch do: slope5's sections with a 10-m run-out (robots that walk on do not
# fall off the heightfield), robots spawned along the course, 20-s training episodes.
SECTION_COURSES = {
    "walk": Course("time_to_walk_flat_s", "flat"),
    "slope5": Course(
        "time_to_cross_slope5_s",
        "sections:5@3,0@3,-5@3;run_out=10",
        env={"spawn_x_max": 10.0},
        sac={"episode_length": 400},
    ),
}


@dataclasses.dataclass(frozen=True)
class TrainRow:
    """One training configuration: parallel envs, SAC batch size, updates per vectorised step."""

    num_envs: int
    batch_size: int
    updates_per_step: int

    @classmethod
    def parse(cls, text: str) -> "TrainRow":
        """'4096x8192x8' -> TrainRow(4096, 8192, 8)."""
        parts = text.strip().lower().split("x")
        try:
            values = [int(part) for part in parts]
        except ValueError:
            values = []
        if len(values) != 3 or min(values) < 1:
            raise ValueError(
                f"bad train row {text!r}; expected NUM_ENVSxBATCHxUPDATES, e.g. 4096x8192x8"
            )
        return cls(*values)

    def __str__(self) -> str:
        return f"{self.num_envs}x{self.batch_size}x{self.updates_per_step}"


@dataclasses.dataclass(frozen=True)
class Settings:
    """What one bench run measures, and at which sizes.

    Attributes:
      env_counts: parallel envs of the physics and env measurements.
      train_rows: rows of the train and stock sections.
      stock_rows: the rows also measured with stock Brax (a subset of `train_rows`).
      steps: timed calls (env steps) per physics / env measurement.
      train_seconds: timed training seconds per row (after the compiling first chunk / epoch).
      stock_epoch_steps: vectorised env steps per stock Brax epoch (the unit it reports in).
      stock_timeout_s: a stock row stops at its first report after this many seconds.
      training_preset: the `quadcos.train` preset whose `sac.*` / `env.*` values the physics,
        env, train and stock sections use.
      walk_training_preset: the preset the walk and slope5 sections train with (from scratch:
        its gait search is part of the timed section).
      walk_timeout_s: the walk and slope5 sections give up after this many seconds.
      walk_eval_interval: env steps between evaluations of the walk and slope5 sections.
      walk_eval_episodes: evaluation episodes per evaluation.
      sections: the sections to run, in order.
      terrain: the terrain of the physics, env, train and stock sections.
      impl: the MJX implementation ("auto", "jax" or "warp"; see quadcos.backends).
      robot: the quadruped of every section (a `quadcos.robot.load` spec).
      randomize: the env, train and stock sections' robots draw their own physics
        (`env.randomization`, its default ranges).
      env: env config overrides ((dotted key, value), ...) of the physics, env, train and stock
        sections (`--env substep_unroll=10`).
      sac: trainer config overrides of the train section's rows (`--sac steps_per_chunk=8`).
      num_devices: devices the train, walk and slope5 sections' trainers spread over
        (data-parallel; rows stay global: per-device envs = num_envs / num_devices).
    """

    env_counts: tuple[int, ...]
    train_rows: tuple[TrainRow, ...]
    stock_rows: tuple[TrainRow, ...]
    steps: int
    train_seconds: float
    stock_epoch_steps: int
    stock_timeout_s: float
    training_preset: str
    walk_timeout_s: float
    walk_eval_interval: int
    walk_eval_episodes: int
    walk_training_preset: str
    sections: tuple[str, ...]
    terrain: str = "flat"
    impl: str = "auto"
    num_devices: int = 1
    robot: str = "quadcos"
    randomize: bool = False
    profile_dir: str | None = None
    profile_python: bool = False
    env: tuple[tuple[str, Any], ...] = ()
    sac: tuple[tuple[str, Any], ...] = ()


_GPU_ROWS = "4096x8192x1,4096x8192x8,16384x16384x4"
BENCH_PRESETS: dict[str, dict[str, Any]] = {
    # The sizes, for one GPU.
    "gpu": {
        "env_counts": "1024,4096,16384,65536",
        "train_rows": _GPU_ROWS,
        "stock_rows": _GPU_ROWS,
        "steps": 50,
        "train_seconds": 15.0,
        "stock_epoch_steps": 50,
        "stock_timeout_s": 300.0,
        "training_preset": "gpu",
        # From scratch (gait search, then SAC); `--walk_training_preset=gpu`: the trot start's row.
        "walk_training_preset": "scratch",
        "walk_timeout_s": 420.0,
        "walk_eval_interval": 1_000_000,
        "walk_eval_episodes": 1_024,
    },
    # Small sizes for a CPU (benchmarks/cpu.json); on two cores mostly compilation.
    "cpu": {
        "env_counts": "16,64",
        "train_rows": "32x256x4",
        "stock_rows": "32x256x4",
        "steps": 20,
        "train_seconds": 5.0,
        "stock_epoch_steps": 20,
        "stock_timeout_s": 300.0,
        "training_preset": "cpu",
        "walk_training_preset": "cpu",
        "walk_timeout_s": 300.0,
        "walk_eval_interval": 25_000,
        "walk_eval_episodes": 64,
    },
}


def _preset_overrides(preset: str, prefix: str) -> dict[str, Any]:
    return {
        key[len(prefix) :]: value
        for key, value in TRAIN_PRESETS[preset].items()
        if key.startswith(prefix)
    }


def _overrides(
    flag: str, items: list[str], config: ml_collections.ConfigDict
) -> tuple[tuple[str, Any], ...]:
    """`--FLAG KEY=VALUE` flags as (key, value) pairs, checked against `config`.

    Raises:
      ValueError: a flag without "=", or a key or value the config does not take.
    """
    pairs = []
    for item in items:
        key, equals, text = item.partition("=")
        if not equals or not key:
            raise ValueError(f"--{flag} takes KEY=VALUE, got {item!r}")
        pairs.append((key, parse_value(text)))
    apply_overrides(config, dict(pairs))
    return tuple(pairs)


def make_bench_env(
    terrain: str,
    preset: str,
    impl: str = "auto",
    action_centre: str | None = None,
    robot: str = "quadcos",
    randomize: bool = False,
    **env_overrides: Any,
) -> env_lib.QuadrupedEnv:
    """The env as `python -m quadcos.train --preset=PRESET --terrain=TERRAIN` builds it, then
    `env_overrides`; a from-scratch preset's (action centre "search") needs the `action_centre`
    its search found. `randomize`: domain randomisation on (its default ranges)."""
    overrides = {**_preset_overrides(preset, "env."), "impl": impl, "robot": robot, **env_overrides}
    if randomize:
        overrides["randomization.enabled"] = True
    if action_centre is not None:
        overrides["action_centre"] = action_centre
    return env_lib.make_env(terrain, **overrides)


def searches_gait(preset: str) -> bool:
    """Whether a run of the training preset starts with a gait search (from scratch)."""
    return TRAIN_PRESETS[preset].get("env.action_centre") == oscillator.SEARCH_CENTRE


def trainer_config(
    preset: str, row: TrainRow | None = None, num_devices: int = 1, **sac_overrides: Any
) -> ml_collections.ConfigDict:
    """`quadcos.training.default_config()` with the preset's `sac.*` values and `sac_overrides`,
    then `row`'s sizes, spread over `num_devices`."""
    overrides = {**_preset_overrides(preset, "sac."), **sac_overrides, "num_devices": num_devices}
    if row is not None:
        overrides |= {
            "num_envs": row.num_envs,
            "batch_size": row.batch_size,
            "updates_per_step": row.updates_per_step,
        }
    config = apply_overrides(training.default_config(), overrides)
    # A row's envs must fit in the replay buffer and outnumber nothing else.
    config.replay_size = max(config.replay_size, config.num_envs)
    training.check_config(config)
    return config


def _ints(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(part) for part in text.split(",") if part.strip())
    except ValueError:
        values = ()
    if not values or min(values) < 1:
        raise ValueError(f"expected positive integers separated by commas, got {text!r}")
    return values


def _rows(text: str) -> tuple[TrainRow, ...]:
    return tuple(TrainRow.parse(part) for part in text.split(",") if part.strip())


def _sections(text: str) -> set[str]:
    names = {part.strip() for part in text.split(",") if part.strip()}
    if unknown := names - set(SECTIONS):
        raise ValueError(f"unknown section(s) {sorted(unknown)}; known: {', '.join(SECTIONS)}")
    return names


def settings_from_args(args: argparse.Namespace) -> Settings:
    """The preset's sizes with the flags' values on top. Raises ValueError for bad values."""
    preset = {**BENCH_PRESETS[args.preset]}
    for name in preset:
        if getattr(args, name, None) is not None:
            preset[name] = getattr(args, name)
    if args.skip and args.only:
        raise ValueError("--skip and --only exclude each other")
    chosen = _sections(args.only) if args.only else set(SECTIONS) - _sections(args.skip)
    train_rows = _rows(preset["train_rows"])
    # Rows given on the command line are also the stock rows, unless --stock_rows says otherwise.
    stock_text = args.stock_rows or args.train_rows or preset["stock_rows"]
    stock_rows = _rows(stock_text)
    for name in ("steps", "stock_epoch_steps", "walk_eval_interval", "walk_eval_episodes"):
        if preset[name] < 1:
            raise ValueError(f"--{name} must be >= 1, got {preset[name]}")
    if args.num_devices < 1:
        raise ValueError(f"--num_devices must be >= 1, got {args.num_devices}")
    terrain_lib.parse(args.terrain)  # a bad spec says why here, before anything is written
    for name in ("train_seconds", "stock_timeout_s", "walk_timeout_s"):
        if not preset[name] >= 0:
            raise ValueError(f"--{name} must be >= 0, got {preset[name]}")
    return Settings(
        env=_overrides("env", args.env, env_lib.default_config()),
        sac=_overrides("sac", args.sac, training.default_config()),
        env_counts=_ints(preset["env_counts"]),
        train_rows=train_rows,
        stock_rows=stock_rows,
        steps=preset["steps"],
        train_seconds=preset["train_seconds"],
        stock_epoch_steps=preset["stock_epoch_steps"],
        stock_timeout_s=preset["stock_timeout_s"],
        training_preset=preset["training_preset"],
        walk_timeout_s=preset["walk_timeout_s"],
        walk_eval_interval=preset["walk_eval_interval"],
        walk_eval_episodes=preset["walk_eval_episodes"],
        walk_training_preset=preset["walk_training_preset"],
        sections=tuple(name for name in SECTIONS if name in chosen),
        terrain=args.terrain,
        impl=args.impl,
        num_devices=args.num_devices,
        robot=args.robot,
        randomize=args.randomize,
        profile_dir=args.profile_dir,
        profile_python=args.profile_python,
    )
