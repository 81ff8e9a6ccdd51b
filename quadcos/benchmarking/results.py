"""The bench's results: the JSON skeleton, merging a run into earlier results, Markdown tables."""

import dataclasses
import datetime
import os
import pathlib
import platform
from collections.abc import Sequence
from typing import Any

import jax

from quadcos import robot as robot_lib
from quadcos._util import provenance
from quadcos.benchmarking.settings import Settings, TrainRow
from quadcos.env import backends

_VERSIONED_PACKAGES = ("jax", "jaxlib", "mujoco", "mujoco-mjx", "brax", "flax", "optax", "numpy")


def _cpu_model() -> str:
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def empty_results(
    settings: Settings, argv: Sequence[str], substeps: int, cache: str
) -> dict[str, Any]:
    """The results skeleton: every key of the issue's schema, numbers still None/empty. `cache`:
    the JAX compilation cache's state when the process switched it on ("cold" or "warm")."""
    device = jax.devices()[0]
    return {
        "device": device.device_kind,
        "platform": device.platform,
        "device_count": jax.device_count(),
        "process_count": jax.process_count(),
        "host": {"cpu": _cpu_model(), "cores": os.cpu_count()},
        "substeps_per_env_step": substeps,
        "physics_steps_per_s": {},
        "gait_physics_steps_per_s": {},
        "env_steps_per_s": {},
        "train": [],
        "compile_s": {"quadcos": None, "stock_brax": None},
        "time_to_walk_flat_s": None,
        "time_to_cross_slope5_s": None,
        "details": {},
        "command": " ".join(["python -m quadcos.bench", *argv]),
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "versions": provenance.versions(_VERSIONED_PACKAGES, python=True),
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
        "compilation_cache_dir": jax.config.jax_compilation_cache_dir,
        "terrain": settings.terrain,
        "robot": settings.robot,
        "randomized": settings.randomize,
        "env": env_text(settings.env),
        "sac": env_text(settings.sac),
        "impl": backends.resolve_impl(
            settings.impl, robot_lib.load(settings.robot).preset.gpu_physics
        ),
        "cache": cache,
        "settings": {
            **dataclasses.asdict(settings),
            "train_rows": [str(row) for row in settings.train_rows],
            "stock_rows": [str(row) for row in settings.stock_rows],
        },
    }


_MERGED_TABLES = (
    "physics_steps_per_s",
    "gait_physics_steps_per_s",
    "env_steps_per_s",
    "details",
    "compile_s",
)


def merge_results(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    """`old` updated with what `new` measured: dict entries and train rows are merged key by key
    (a None in `new` keeps `old`'s value); the commands, dates and settings of both runs are kept
    (as lists), and so are the errors of both (`details.errors`).

    Raises:
      ValueError: the two come from different devices.
    """
    if old.get("device") != new["device"]:
        raise ValueError(f"cannot merge results of {new['device']!r} into {old.get('device')!r}")
    if old.get("env", "") != new.get("env", ""):  # physics and env rates are not kept apart
        raise ValueError(
            f"cannot merge results measured with --env {new.get('env')!r} into ones measured"
            f" with {old.get('env') or 'none'!r}"
        )
    merged = {**old}
    for key, value in new.items():
        if key == "train":
            rows = {_row_key(row): dict(row) for row in old.get("train", [])}
            for row in value:
                if _row_key(row) in rows:
                    measured = {name: entry for name, entry in row.items() if entry is not None}
                    rows[_row_key(row)].update(measured)
                else:
                    rows[_row_key(row)] = dict(row)
            merged["train"] = list(rows.values())
        elif key in _MERGED_TABLES:
            merged[key] = {**old.get(key, {}), **{k: v for k, v in value.items() if v is not None}}
            if key == "details" and "errors" in old.get(key, {}):
                merged[key]["errors"] = {**old[key]["errors"], **value.get("errors", {})}
        elif key in ("command", "date", "settings"):
            merged[key] = _as_list(old.get(key)) + [value] if old.get(key) != value else old[key]
        elif value is not None or key not in old:
            merged[key] = value
    return merged


def env_text(env: Sequence[tuple[str, Any]]) -> str:
    """`--env` / `--sac` overrides as one string ("substep_unroll=10,warp.graph_mode=jax"; ""
    for none)."""
    return ",".join(f"{key}={value}" for key, value in env)


def _row_key(row: dict[str, Any]) -> tuple[Any, ...]:
    # Rows measured before robot, terrain, impl, cache, randomisation and env / trainer overrides
    # were recorded: the paper's robot on flat, JAX, no cache, nominal physics, no overrides.
    context = (
        row.get("robot", "quadcos"),
        row.get("terrain", "flat"),
        row.get("impl", "jax"),
        row.get("cache", "cold"),
        row.get("randomized", False),
        row.get("env", ""),
        row.get("sac", ""),
    )
    return row["num_envs"], row["batch_size"], row["updates_per_step"], *context


def _as_list(value: Any) -> list[Any]:
    if value is None:
        return []
    return list(value) if isinstance(value, list) else [value]


def train_row(results: dict[str, Any], row: TrainRow) -> dict[str, Any]:
    """The results' entry for `row`, created (with every field None) if missing."""
    for entry in results["train"]:
        context = (
            results.get("robot", "quadcos"),
            results["terrain"],
            results["impl"],
            results["cache"],
            results.get("randomized", False),
            results.get("env", ""),
            results.get("sac", ""),
        )
        if _row_key(entry) == (row.num_envs, row.batch_size, row.updates_per_step, *context):
            return entry
    entry = {
        "num_envs": row.num_envs,
        "batch_size": row.batch_size,
        "updates_per_step": row.updates_per_step,
        "robot": results.get("robot", "quadcos"),
        "terrain": results["terrain"],
        "impl": results["impl"],
        "cache": results["cache"],
        "randomized": results.get("randomized", False),
        "env": results.get("env", ""),
        "sac": results.get("sac", ""),
        "quadcos_env_steps_per_s": None,
        "stock_brax_env_steps_per_s": None,
    }
    results["train"].append(entry)
    return entry


def format_rate(value: float | None, unit: str = "") -> str:
    if value is None:
        return "—"
    for scale, prefix in ((1e9, " G"), (1e6, " M"), (1e3, " k")):
        if abs(value) >= scale:
            return f"{value / scale:.3g}{prefix}{unit}"
    return f"{value:.3g}{' ' + unit if unit else ''}"


def format_seconds(value: float | None) -> str:
    return "—" if value is None else f"{value:.1f} s"


def _outcome(results: dict[str, Any], key: str, section: str) -> str:
    """A time-to-walk entry: the seconds, why there are none, or "—" when not measured."""
    if results[key] is not None:
        return format_seconds(results[key])
    detail = results["details"].get(section)
    return detail["reason"] if detail and detail.get("reason") else "—"


def markdown_table(results: dict[str, Any]) -> str:
    """The results as Markdown tables: simulation throughput, training throughput (ours and
    stock Brax), start-up to the first training step, and time to walk."""
    header = (
        f"Device: {results['device']} ({results['platform']}); "
        f"{results['substeps_per_env_step']} physics steps per env step."
    )
    lines = [
        header,
        "",
        "| envs | raw MJX physics steps/s, standing | the same, walking the trot | env steps/s"
        " (`make_env`) |",
        "|---:|---:|---:|---:|",
    ]
    tables = ("physics_steps_per_s", "gait_physics_steps_per_s", "env_steps_per_s")
    # Results written before the gait section was measured have no such table.
    counts = sorted({count for table in tables for count in results.get(table, {})}, key=int)
    for count in counts:
        rates = " | ".join(format_rate(results.get(table, {}).get(count)) for table in tables)
        lines.append(f"| {int(count):,} | {rates} |")
    lines += [
        "",
        "| robot | terrain | impl | envs | batch | updates/step | quadcos env-steps/s | stock Brax"
        " env-steps/s | ours / stock | ours / raw physics (standing, walking) | quadcos start →"
        " first step |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in sorted(results["train"], key=lambda row: (_row_key(row)[3:], _row_key(row))):
        ours, stock = row["quadcos_env_steps_per_s"], row["stock_brax_env_steps_per_s"]
        ratio = f"{ours / stock:.2f}" if ours and stock else "—"
        of_physics = ", ".join(
            f"{ours / row[key]:.2f}" if ours and row.get(key) else "—"
            for key in ("physics_env_steps_per_s", "gait_physics_env_steps_per_s")
        )
        robot, terrain, impl, cache, randomized, env, sac = _row_key(row)[3:]
        context = f"{robot} | {terrain} | {impl}{', randomised' if randomized else ''}"
        context += "".join(f", {overrides}" for overrides in (env, sac) if overrides)
        sizes = f"{row['num_envs']:,} | {row['batch_size']:,} | {row['updates_per_step']}"
        start = row.get("quadcos_start_to_first_step_s")
        start = f"{format_seconds(start)} ({cache} cache)" if start is not None else "—"
        lines.append(
            f"| {context} | {sizes} | {format_rate(ours)} | {format_rate(stock)} | {ratio} |"
            f" {of_physics} | {start} |"
        )
    compile_s = results["compile_s"]
    ours, stock = (
        format_seconds(compile_s.get("quadcos")),
        format_seconds(compile_s.get("stock_brax")),
    )
    walk = _outcome(results, "time_to_walk_flat_s", "walk")
    cross = _outcome(results, "time_to_cross_slope5_s", "slope5")
    lines += [
        "",
        "| from process start | quadcos | stock Brax |",
        "|---|---:|---:|",
        f"| to the first training step (compile) | {ours} | {stock} |",
        f"| to walking on flat | {walk} | — |",
        f"| to crossing slope5 | {cross} | — |",
    ]
    return "\n".join(lines) + "\n"
