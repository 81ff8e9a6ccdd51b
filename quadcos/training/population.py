"""`python -m quadcos.train --population=N`: N runs of one command, a GPU each, and the best kept.

Each member is the same `python -m quadcos.train` command with its own seed (the run's seed + its
index) and run directory (`DIR/member_I`), started as a process of its own on one GPU (the I-th of
`CUDA_VISIBLE_DEVICES`, or of the host's GPUs; without a GPU all members share the CPU). When all
have ended, each member's `policy_best` (else its last policy) is evaluated, one after another in
this process, on held-out courses (`--population_terrain`: by default the run's terrain,
`testset:4242` where it trains on random courses), and the best member's policies are copied to
`DIR/policy_best` and `DIR/policy`: the highest worst-course success, then mean course success (a
test set), or the highest success, then mean episode reward. `DIR/population.json` records every
member (seed, GPU, exit status, the policy compared, its evaluation) and the choice.

The runs of one command differ by seed more than by cold or warm caches (experiments/any_slope):
N GPUs give a user N draws in the time of one."""

import functools
import json
import logging
import math
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence

from quadcos._util import files
from quadcos._util.cli import UsageError
from quadcos.training import metrics_log

logger = logging.getLogger("quadcos.train")

# Flags of the population's command line that its members do not take (or take their own of).
_OWN_FLAGS = (
    "--population", "--population_terrain", "--population_envs", "--population_seconds",
    "--output_dir", "--seed", "--config.sac.seed", "--numbered",
)
_VALUED = frozenset(_OWN_FLAGS) - {"--numbered"}
_NVIDIA_GPUS = pathlib.Path("/proc/driver/nvidia/gpus")
MEMBER_ENV = "QUADCOS_POPULATION_MEMBER"  # set in a member's environment: its index


def member_argv(argv: Sequence[str], seed: int, run_dir: pathlib.Path) -> list[str]:
    """The population's command line as member `seed`'s: without the population's own flags
    (`--flag=value` or `--flag value`), with its seed and run directory."""
    kept, skip = [], False
    for arg in argv:
        name = arg.split("=", 1)[0]
        if skip:
            skip = False
        elif name in _OWN_FLAGS:
            skip = "=" not in arg and name in _VALUED
        else:
            kept.append(arg)
    return [*kept, f"--seed={seed}", f"--output_dir={run_dir}"]


def gpus() -> list[str]:
    """The GPUs a member may be pinned to: CUDA_VISIBLE_DEVICES's entries where it is set, else
    the host's NVIDIA GPUs by index (none on a machine without them)."""
    visible = os.environ.get("CUDA_VISIBLE_DEVICES")
    if visible is not None:
        return [entry.strip() for entry in visible.split(",") if entry.strip()]
    return [str(index) for index in range(len(list(_NVIDIA_GPUS.glob("*"))))]


def score(evaluation: dict) -> tuple[float, float]:
    """A member's rank: worst-course then mean course success (a test set's evaluation), or
    success then mean episode reward; a value that is not a finite number ranks lowest."""
    return tuple(_finite(evaluation.get(key)) for key in _score_keys(evaluation))


def _score_keys(evaluation: dict) -> tuple[str, str]:
    if "worst_course_success_rate" in evaluation:
        return ("worst_course_success_rate", "mean_course_success_rate")
    return ("success_rate", "mean_episode_reward")


def _finite(value) -> float:
    return float(value) if isinstance(value, (int, float)) and math.isfinite(value) else -math.inf


def selection_terrain(terrain: str) -> str:
    """Where members are compared by default: held-out courses for a run on random courses."""
    return "testset:4242" if terrain.startswith("random") else terrain


def selection_seconds(terrain: str) -> float:
    """The default episode length of the comparison: 40 s on a test set (courses of up to five
    sections of up to 3 m and a run-out, walked at 0.5-1 m/s), else 20 s."""
    return 40.0 if terrain.startswith("testset") else 20.0


def run(
    argv: Sequence[str],
    size: int,
    run_dir: pathlib.Path,
    seed: int,
    terrain: str,
    compare: Callable[[pathlib.Path], dict],
    poll_s: float = 30.0,
) -> int:
    """Trains and compares the members (module docstring): `compare(policy_dir)` evaluates a
    member's policy on `terrain` and returns the evaluation's summary. The exit status: 0 with a
    policy chosen, 1 when no member left one, 130 when Ctrl-C or SIGTERM stopped the members
    (population.json then says `interrupted`). The chosen policies and population.json are
    written whole or not at all."""
    devices = gpus()
    if devices and len(devices) < size:
        raise UsageError(
            f"--population={size} runs a member per GPU, and {len(devices)} are visible"
            f" ({', '.join(devices)}); set --population to at most {len(devices)}"
        )
    if not devices:
        logger.warning("population: no GPU; the %d members share the CPU", size)
    run_dir.mkdir(parents=True, exist_ok=True)
    start = time.monotonic()
    members = [
        {"index": index, "seed": seed + index, "gpu": devices[index] if devices else None,
         "run_dir": str(run_dir / f"member_{index}")}
        for index in range(size)
    ]
    commands = [
        [sys.executable, "-m", "quadcos.train",
         *member_argv(argv, member["seed"], pathlib.Path(member["run_dir"])), "--no_progress"]
        for member in members
    ]
    record = {"format": "quadcos.population", "size": size, "terrain": terrain, "members": members}
    try:
        _train_all(members, commands, run_dir, poll_s)
    except KeyboardInterrupt:
        record.update(chosen=None, interrupted=True,
                      wall_time_s=round(time.monotonic() - start, 1))
        files.atomic_write_text(run_dir / "population.json", json.dumps(record, indent=1) + "\n")
        logger.error("population: stopped; the members' runs are in %s/member_I (--resume"
                     " continues one that checkpointed)", run_dir)
        return 130
    for member in members:  # the policy compared: the run's kept one, else its last
        folder = pathlib.Path(member["run_dir"])
        kept = [name for name in ("policy_best", "policy") if (folder / name).is_dir()]
        member["compared"] = kept[0] if member["train_exit"] == 0 and kept else None
    candidates = [member for member in members if member["compared"]]
    for member in candidates:
        policy = pathlib.Path(member["run_dir"]) / member["compared"]
        logger.info("population: member %d's %s on %s", member["index"], member["compared"],
                    terrain)
        try:
            evaluation = compare(policy)
        except Exception as error:  # noqa: BLE001 — one member's failure leaves the others
            member["selection_error"] = f"{type(error).__name__}: {error}"
            continue
        member["selection"] = {key: value for key, value in evaluation.items()
                               if isinstance(value, (int, float, str)) and key != "format"}
    ranked = [member for member in candidates if "selection" in member]
    chosen = max(ranked, key=lambda member: score(member["selection"]), default=None)
    record.update(chosen=chosen and chosen["index"],
                  wall_time_s=round(time.monotonic() - start, 1))
    if chosen is not None:
        for name in ("policy_best", "policy"):
            source = pathlib.Path(chosen["run_dir"]) / name
            if source.is_dir():
                files.atomic_replace_dir(run_dir / name, functools.partial(_copy, source))
    files.atomic_write_text(run_dir / "population.json", json.dumps(record, indent=1) + "\n")
    for member in members:
        logger.info(
            "population: member %d (seed %d): train exit %d, %s", member["index"],
            member["seed"], member["train_exit"],
            "selection: %s" % ", ".join(
                f"{key} {value:.3f}"
                for key, value in zip(_score_keys(member["selection"]), score(member["selection"]))
            )
            if "selection" in member else "not compared",
        )
    if chosen is None:
        logger.error("population: no member left a policy to compare; logs in %s", run_dir)
        return 1
    logger.info("population: member %d chosen, its policies in %s", chosen["index"], run_dir)
    return 0


def _train_all(
    members: list[dict], commands: list[list[str]], run_dir: pathlib.Path, poll_s: float
) -> None:
    """Starts `commands` (one per member, on its GPU), logs each to run_dir/member_I.log, reports
    the members' env steps every `poll_s` and sets each one's "train_exit". Ctrl-C or SIGTERM
    (turned into KeyboardInterrupt while the members run) stops every member that is running
    (SIGTERM: one in its training loop checkpoints after its chunk), waits for them and raises
    KeyboardInterrupt."""
    processes = []
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        for member, command in zip(members, commands, strict=True):
            env = {**os.environ, MEMBER_ENV: str(member["index"])}
            if member["gpu"] is not None:
                env["CUDA_VISIBLE_DEVICES"] = member["gpu"]
            with open(run_dir / f"member_{member['index']}.log", "w") as log:
                processes.append(subprocess.Popen(
                    command, env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL
                ))
        report_at = time.monotonic() + poll_s
        while any(process.poll() is None for process in processes):
            time.sleep(min(poll_s, 1.0))
            if time.monotonic() >= report_at:
                report_at += poll_s
                logger.info("population: %s", "; ".join(
                    f"member {member['index']}: {_where(member, run_dir)}" for member in members))
    except KeyboardInterrupt:
        logger.warning("population: stopping %d members", len(processes))
        for process in processes:
            if process.poll() is None:
                process.terminate()
        raise
    finally:
        _wait_for(processes)
        for member, process in zip(members, processes):
            member["train_exit"] = process.returncode
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _wait_for(processes: list[subprocess.Popen]) -> None:
    """Waits for every member, however many more Ctrl-Cs or SIGTERMs come (`timeout -s INT`
    signals the population twice): the population ends after its members, with each one's exit
    status, and no member writes into its run after the population has said where things are."""
    while True:
        try:
            for process in processes:
                process.wait()
            return
        except KeyboardInterrupt:
            running = [process.pid for process in processes if process.poll() is None]
            logger.warning("population: waiting for members %s to stop (kill -9 to force)", running)


def _copy(source: pathlib.Path, folder: pathlib.Path) -> None:
    shutil.copytree(source, folder, dirs_exist_ok=True)


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt(f"signal {signum}")


def _where(member: dict, run_dir: pathlib.Path) -> str:
    """Where a member stands: its env step once it has trained, else the last of its log's lines
    that quadcos wrote (the gait search's rounds; not XLA's or Warp's)."""
    step = _last_step(member)
    if step:
        return f"env step {step:,}"
    log = run_dir / f"member_{member['index']}.log"
    lines = log.read_text(errors="replace").splitlines() if log.exists() else []
    ours = [line[len(_PREFIX):] for line in lines if line.startswith(_PREFIX)]
    last = ours[-1].strip() if ours else "starting"
    return last if len(last) <= 80 else last[:77] + "..."


_PREFIX = "quadcos.train: "  # the start of the lines a member's logger writes


def _last_step(member: dict) -> int:
    """The env step of a member's last metrics row (0 before its first)."""
    rows = metrics_log.read_rows(pathlib.Path(member["run_dir"]) / "metrics.jsonl")
    return int(rows[-1]["step"]) if rows else 0  # (a torn last line is skipped)
