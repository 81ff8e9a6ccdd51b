"""`python -m quadcos.bench`: throughput, compile time and time to walk on one device, as JSON.

    python -m quadcos.bench --out benchmarks/h100.json
    python -m quadcos.bench --preset cpu --out benchmarks/cpu.json --skip stock,walk,slope5
    python -m quadcos.bench --out benchmarks/h100.json --merge --only walk --walk_timeout_s 420
    python -m quadcos.bench --table benchmarks/h100.json      # the results as Markdown
    python -m quadcos.bench --only train --num_devices 2 --out b.json \
        --coordinator localhost:1234 --num_processes 2 --process_id I   # each of 2 processes

Sections (each can be left out with --skip or chosen with --only):
  physics  raw MJX physics steps/s: `mjx.step` of the env's model, vmapped over the envs, one
           call = `substeps` physics steps (one env step's worth), the robots standing.
  gait     the same physics of robots walking the fixed trot (the zero action's joint targets,
           set at each env step's start), 16 env steps a call: the motion that the env and the
           trainer step, stepped as a training chunk steps it.
  env      env-steps/s of `jax.vmap(env.step)` (oscillator, estimator, reward inside) with the
           constant zero action (the action centre: the fixed trot).
  train    our trainer (`SACTrainer.train_chunk`) per row NUM_ENVSxBATCHxUPDATES.
  stock    stock `brax.training.agents.sac.train.train` on the same env and settings.
  walk     time until the deterministic policy, after the actor has started learning, survives
           20 s and moves >= 0.3 m/s in >= 99 % of evaluation episodes on flat.
  slope5   the same for crossing the slope5 course (the torso passes its end without a fall,
           within the time that 0.3 m/s takes), trained with spawns along the course
           (`benchmarking.settings.SECTION_COURSES`); evaluations start at x = 0.
Evaluation episodes are `quadcos.evaluation` rollouts of the deterministic policy, trained in
the trainer's own host loop. The work is done by `quadcos.benchmarking`; this module is its
command line.

Every timed function is compiled by a first call on the very carry that is then timed (one trace,
checked), and timing ends with `block_until_ready`. Start-up-relative times (`compile_s`,
`time_to_*`) are "process start -> event" for a process that did only that section: the
process's start-up (imports, backend) plus the seconds since the section started building its env
from nothing. The JSON is rewritten after every measurement, so a crash keeps what came before;
a measurement that raises is recorded in `details.errors`, the rest still run, and the exit
status is 1.
Compile times are only meaningful without the JAX persistent compilation cache (the JSON records
`compilation_cache_dir`).
"""

import argparse
import dataclasses
import functools
import json
import os
import pathlib
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import jax

from quadcos import training
from quadcos._util import caches, cli, files, quiet
from quadcos.benchmarking import physics, trainers
from quadcos.benchmarking import results as results_lib
from quadcos.benchmarking.settings import (
    BENCH_PRESETS,
    SECTION_COURSES,
    SECTIONS,
    Settings,
    TrainRow,
    make_bench_env,
    searches_gait,
    settings_from_args,
    trainer_config,
)
from quadcos.benchmarking.time_to_walk import rollout_evaluator, terrain_goal, time_to_success
from quadcos.benchmarking.timing import log, since_start
from quadcos.env import backends
from quadcos.evaluation import gait_search
from quadcos.training import parallel, presets
from quadcos.training.presets import PRESETS as TRAIN_PRESETS

_PROG = "quadcos.bench"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m quadcos.bench",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--out", help="results JSON (rewritten after every measurement)")
    parser.add_argument(
        "--merge",
        action="store_true",
        help="merge into --out's existing results instead of replacing them",
    )
    parser.add_argument("--table", metavar="FILE.json", help="print FILE's results as Markdown")
    parser.add_argument("--preset", choices=tuple(BENCH_PRESETS), default="gpu")
    parser.add_argument("--env_counts", help="physics / env sizes, e.g. 1024,4096")
    parser.add_argument("--train_rows", help="NUM_ENVSxBATCHxUPDATES,... e.g. 4096x8192x8")
    parser.add_argument("--stock_rows", help="rows also run with stock Brax (default: preset's)")
    parser.add_argument("--steps", type=int, help="timed calls per physics / env measurement")
    parser.add_argument("--train_seconds", type=float, help="timed seconds per training row")
    parser.add_argument("--stock_epoch_steps", type=int, help="vectorised steps per stock epoch")
    parser.add_argument("--stock_timeout_s", type=float, help="cap per stock row, compile included")
    parser.add_argument("--training_preset", choices=tuple(TRAIN_PRESETS))
    parser.add_argument(
        "--walk_training_preset",
        choices=tuple(TRAIN_PRESETS),
        help="what the walk and slope5 sections train with (gpu bench preset: scratch)",
    )
    parser.add_argument("--terrain", default="flat", help="terrain of physics/env/train/stock")
    parser.add_argument(
        "--robot",
        default="quadcos",
        help="the quadruped of every section: quadcos, quad12, an MJCF path or menagerie:NAME",
    )
    parser.add_argument("--impl", default="auto", choices=backends.IMPLS, help="MJX implementation")
    parser.add_argument(
        "--profile_dir",
        help="also trace two training chunks of each train row with jax.profiler into"
        " DIR/ROW (summarise with python -m quadcos.benchmarking.profile DIR/ROW)",
    )
    parser.add_argument(
        "--profile_python",
        action="store_true",
        help="with --profile_dir: record every Python call too (the host's finer detail, at the"
        " cost of a host 1.3-1.6x slower in the traced chunks)",
    )
    parser.add_argument(
        "--env",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="env config override of the physics, env, train and stock sections (repeatable),"
        " e.g. substep_unroll=10 or warp.graph_conditional=false",
    )
    parser.add_argument(
        "--sac",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="trainer config override of the train section's rows (repeatable),"
        " e.g. steps_per_chunk=8",
    )
    parser.add_argument(
        "--randomize",
        action="store_true",
        help="env, train and stock sections with domain randomisation (its default ranges;"
        " the physics section stays nominal)",
    )
    parser.add_argument(
        "--num_devices",
        type=int,
        default=1,
        help="devices the train / walk / slope5 trainers spread over (rows stay global)",
    )
    parser.add_argument(
        "--coordinator",
        help="HOST:PORT of process 0: one bench of the train rows over several processes"
        " (`jax.distributed`; e.g. one per GPU of a host, each shown its GPU by"
        " CUDA_VISIBLE_DEVICES), --num_devices the devices of all of them; process 0 writes --out,"
        " process I OUT.processI.json",
    )
    parser.add_argument("--num_processes", type=int, help="with --coordinator: processes in all")
    parser.add_argument("--process_id", type=int, help="with --coordinator: this one, 0 to N-1")
    parser.add_argument("--walk_timeout_s", type=float, help="cap of the walk / slope5 sections")
    parser.add_argument("--walk_eval_interval", type=int, help="env steps between evaluations")
    parser.add_argument("--walk_eval_episodes", type=int, help="episodes per evaluation")
    parser.add_argument("--skip", default="", help=f"sections to leave out: {','.join(SECTIONS)}")
    parser.add_argument("--only", default="", help="the sections to run (the others are skipped)")
    parser.add_argument(
        "--verbose",
        action="store_true",
        help="let Warp print its line per kernel module loaded (silenced by default)",
    )
    return parser


def run(
    settings: Settings,
    out: pathlib.Path,
    results: dict[str, Any],
    startup_s: float,
    previous: dict[str, Any] | None = None,
) -> int:
    """Runs the chosen sections into `results`, writing them to `out` (merged into `previous`'s
    results when given) after every measurement.

    A measurement that raises (e.g. out of device memory) is recorded in `details.errors` and
    the others still run. Returns the number of failed measurements.
    """
    results["details"]["startup_s"] = startup_s
    bench = _Sections(settings, results, startup_s, out, previous)
    bench.save()
    sections = settings.sections
    if {"physics", "gait", "env"} & set(sections):
        bench.simulation(sections)
    if "train" in sections:
        for row in settings.train_rows:
            bench.attempt(f"train {row}", functools.partial(bench.ours, row))
    if "stock" in sections:
        for row in settings.stock_rows:
            bench.attempt(f"stock {row}", functools.partial(bench.stock, row))
    for section in ("walk", "slope5"):
        if section in sections:
            bench.attempt(section, functools.partial(bench.walk, section))
    return len(bench.errors)


class _Sections:
    """The measurements of one bench run, each writing into `results` (saved to `out` after
    every one)."""

    def __init__(
        self,
        settings: Settings,
        results: dict[str, Any],
        startup_s: float,
        out: pathlib.Path,
        previous: dict[str, Any] | None,
    ):
        self.settings, self.results, self.details = settings, results, results["details"]
        self.startup_s = startup_s
        self.out, self.previous = out, previous
        self.errors: dict[str, str] = {}

    def save(self) -> None:
        results, details = self.results, self.details
        if self.errors:
            details["errors"] = self.errors
        self.out.parent.mkdir(parents=True, exist_ok=True)
        merged = (
            results if self.previous is None else results_lib.merge_results(self.previous, results)
        )
        files.atomic_write_text(self.out, json.dumps(merged, indent=2) + "\n")

    def attempt(self, label: str, measure: Callable[[], str]) -> None:
        """Logs `measure()`'s line, or records its exception in `errors`; then saves."""
        try:
            log(f"{label}: {measure()}")
        except Exception as error:  # noqa: BLE001 - recorded; the other measurements still run
            self.errors[label] = f"{type(error).__name__}: {error}"[:2_000]
            log(f"{label}: FAILED {self.errors[label][:300]}")
        self.save()

    def simulation(self, sections: Sequence[str]) -> None:
        """The physics, gait and env sections: steps per s of one env at each count."""
        settings, results, details = self.settings, self.results, self.details
        env = make_bench_env(
            settings.terrain,
            settings.training_preset,
            settings.impl,
            robot=settings.robot,
            randomize=settings.randomize,
            **dict(settings.env),
        )
        reset_batch = physics.make_batch_reset(env)

        def simulation(section: str, count: int) -> str:
            measure, table, unit_steps = {
                "physics": (physics.measure_physics, "physics_steps_per_s", env.substeps),
                "gait": (
                    physics.measure_gait_physics,
                    "gait_physics_steps_per_s",
                    env.substeps * physics.GAIT_STEPS_PER_CALL,
                ),
                "env": (physics.measure_env, "env_steps_per_s", 1),
            }[section]
            timing = measure(env, reset_batch(count), settings.steps)
            rate = count * unit_steps * timing.calls / timing.seconds
            results[table][str(count)] = rate
            details.setdefault(f"{section}_first_call_s", {})[str(count)] = timing.first_call_s
            return (
                f"{results_lib.format_rate(rate)} steps/s (first call {timing.first_call_s:.1f} s)"
            )

        for count in settings.env_counts:
            for section in ("physics", "gait", "env"):
                if section in sections:
                    self.attempt(
                        f"{section} {count} envs", functools.partial(simulation, section, count)
                    )

    def ours(self, row: TrainRow) -> str:
        """Our trainer's row: env steps per s and start-up."""
        settings, results, details = self.settings, self.results, self.details
        startup_s = self.startup_s
        measured = trainers.measure_trainer(
            row,
            settings.training_preset,
            settings.train_seconds,
            startup_s,
            settings.terrain,
            settings.impl,
            settings.num_devices,
            settings.robot,
            settings.randomize,
            settings.profile_dir and f"{settings.profile_dir}/{row}",
            dict(settings.env),
            dict(settings.sac),
            settings.profile_python,
        )
        entry = results_lib.train_row(results, row)
        entry["quadcos_env_steps_per_s"] = measured["env_steps_per_s"]
        # Raw physics at the row's envs, measured in this process (the physics and gait sections).
        for table in ("physics", "gait_physics"):
            physics_rate = results[f"{table}_steps_per_s"].get(str(row.num_envs))
            if physics_rate is not None:
                entry[f"{table}_env_steps_per_s"] = physics_rate / results["substeps_per_env_step"]
        entry["quadcos_first_chunk_s"] = measured["first_chunk_s"]
        entry["quadcos_start_to_first_step_s"] = measured["start_to_first_step_s"]
        if results["compile_s"]["quadcos"] is None:
            results["compile_s"]["quadcos"] = measured["start_to_first_step_s"]
            details["compile_s_row"] = str(row)
        return (
            f"{results_lib.format_rate(measured['env_steps_per_s'])} env-steps/s, first chunk"
            f" {measured['first_chunk_s']:.1f} s, start -> first step"
            f" {measured['start_to_first_step_s']:.1f} s"
        )

    def stock(self, row: TrainRow) -> str:
        """Stock Brax SAC's row, on the same env."""
        settings, results, details = self.settings, self.results, self.details
        startup_s = self.startup_s
        section_start = time.perf_counter()
        measured = trainers.measure_stock_brax(
            make_bench_env(
                settings.terrain,
                settings.training_preset,
                settings.impl,
                robot=settings.robot,
                randomize=settings.randomize,
                **dict(settings.env),
            ),
            trainer_config(settings.training_preset, row),
            settings.train_seconds,
            settings.stock_epoch_steps,
            settings.stock_timeout_s,
            section_start,
            startup_s,
        )
        entry = results_lib.train_row(results, row)
        entry["stock_brax_env_steps_per_s"] = measured["env_steps_per_s"]
        entry["stock_brax_start_to_first_step_s"] = measured["start_to_first_step_s"]
        entry["stock_brax_timed_out"] = bool(measured["timed_out"])
        if results["compile_s"]["stock_brax"] is None:
            results["compile_s"]["stock_brax"] = measured["start_to_first_step_s"]
            details["stock_compile_s_row"] = str(row)
        return (
            f"{results_lib.format_rate(measured['env_steps_per_s'])} env-steps/s, start -> first step"
            f" {measured['start_to_first_step_s']:.1f} s"
        )

    def walk(self, section: str) -> str:
        """Time until a fresh trainer's policy crosses the section's course."""
        settings, results, details = self.settings, self.results, self.details
        startup_s = self.startup_s
        course = SECTION_COURSES[section]
        section_start = time.perf_counter()
        centre = None
        preset = settings.walk_training_preset
        if searches_gait(preset):  # part of the timed section
            found = gait_search.find_gait(
                presets.build_config(
                    TRAIN_PRESETS[preset],
                    {"env.terrain": course.terrain, "env.robot": settings.robot},
                )
            )
            centre = found["action_centre"]
            details[f"{section}_gait_search"] = {
                "action_centre": centre,
                "seconds": found["setup"]["wall_time_s"],
                "rounds": found["rounds"],
            }
        env = make_bench_env(
            course.terrain, preset, action_centre=centre, robot=settings.robot, **course.env
        )
        eval_env = env  # evaluations start at x = 0: without the training spawns
        if course.env:
            eval_env = make_bench_env(
                course.terrain, preset, action_centre=centre, robot=settings.robot
            )
        config = trainer_config(preset, num_devices=settings.num_devices, **course.sac)
        trainer = training.SACTrainer(env, config, eval_env=eval_env)
        goal = terrain_goal(eval_env)
        outcome = time_to_success(
            trainer,
            rollout_evaluator(trainer, goal, settings.walk_eval_episodes),
            timeout_s=settings.walk_timeout_s,
            eval_interval=settings.walk_eval_interval,
            section_start=section_start,
            startup_s=startup_s,
            label=f"{section}: ",
        )
        results[course.result_key] = outcome["seconds"]
        details[section] = {
            **outcome,
            "goal": dataclasses.asdict(goal),
            "course": dataclasses.asdict(course),
        }
        details[section]["episodes"] = settings.walk_eval_episodes
        return f"{results_lib.format_seconds(outcome['seconds'])} {outcome['reason'] or ''}"


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    # The same XLA flags as `python -m quadcos.train`, set before the backend starts.
    os.environ.setdefault("XLA_FLAGS", "--xla_gpu_triton_gemm_any=true")
    cache_state = caches.enable()["state"]  # before anything compiles into it
    try:
        args = cli.raising(_parser()).parse_args(argv)
        quiet.quiet_warp(args.verbose)  # before anything loads a Warp module
        if args.table:
            table = results_lib.markdown_table(json.loads(pathlib.Path(args.table).read_text()))
            print(table, end="")
            return cli.EXIT_OK
        if not args.out:
            raise cli.UsageError("--out is required (or --table to print results)")
        settings = settings_from_args(args)
        for row in settings.train_rows + settings.stock_rows:
            trainer_config(settings.training_preset, row, **dict(settings.sac))
        out = _distributed(args, settings)
        previous = json.loads(out.read_text()) if args.merge and out.exists() else None

        jax.devices()  # starts the backend: part of the start-up
        startup_s = since_start()
        substeps = make_bench_env("flat", settings.training_preset, robot=settings.robot).substeps
        results = results_lib.empty_results(settings, argv, substeps, cache_state)
        if previous is not None:
            # Fails for another device, before measuring.
            results_lib.merge_results(previous, results)
    except (ValueError, OSError) as error:
        cli.print_error(_PROG, error)
        return cli.EXIT_USAGE
    log(f"{results['device']}: sections {', '.join(settings.sections)} -> {out}")
    failures = run(settings, out, results, startup_s, previous)
    log(
        f"done: {out}"
        + (f"; {failures} measurement(s) failed, see details.errors" if failures else "")
    )
    return cli.EXIT_FAILURE if failures else cli.EXIT_OK


def _distributed(args: argparse.Namespace, settings: Settings) -> pathlib.Path:
    """Starts `jax.distributed` where `--coordinator` asks for several processes (before the
    backend starts) and returns the file this process writes: `--out`, or beside it for a
    process other than 0.

    Raises:
      UsageError: sections other than train, or `--num_devices` other than all processes'.
      ValueError: `parallel.initialize_distributed`'s, a flag without the others."""
    out = pathlib.Path(args.out)
    if args.coordinator is not None and settings.sections != ("train",):
        raise cli.UsageError("--coordinator benches the train rows only: add --only train")
    parallel.initialize_distributed(args.coordinator, args.num_processes, args.process_id)
    if args.coordinator is None:
        return out
    if settings.num_devices != jax.device_count():
        raise cli.UsageError(
            f"--num_devices={settings.num_devices}: the {args.num_processes} processes have"
            f" {jax.device_count()} devices in all; give that number"
        )
    return out if args.process_id == 0 else out.with_suffix(f".process{args.process_id}.json")


if __name__ == "__main__":
    cli.exit_process(main())
