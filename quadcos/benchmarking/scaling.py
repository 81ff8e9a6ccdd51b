"""`python -m quadcos.benchmarking.scaling`: bench results on 1 and N devices side by side.

    python -m quadcos.benchmarking.scaling --out benchmarks/h200x2.json RESULT.json ...

Each input is a `python -m quadcos.bench` JSON of one process (`--num_devices`, `--terrain`,
sections train / walk / slope5). The output keeps every input whole (`runs`) and adds `rows`: per
terrain and device count, the training rate at its per-device envs and the times to walk / to
cross slope5, with `speedup` = rate on N devices / rate on one at equal per-device envs.
"""

import argparse
import json
import pathlib
import sys
from collections.abc import Sequence
from typing import Any

from quadcos._util import cli, files

_PROG = "quadcos.benchmarking.scaling"
# What a row on N devices shares with the one-device row it is compared with.
_SAME_WORK = ("terrain", "impl", "envs_per_device", "batch_per_device", "updates_per_step")


def scaling_rows(runs: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (terrain, device count, train row) of the runs, with the speedup over the
    one-device row of the same terrain, physics and per-device envs, batch and updates."""
    rows = []
    for run in runs:
        devices = int(run["settings"]["num_devices"])
        processes = int(run.get("process_count", 1))
        times = {
            "time_to_walk_flat_s": run.get("time_to_walk_flat_s"),
            "time_to_cross_slope5_s": run.get("time_to_cross_slope5_s"),
        }
        for entry in run["train"] or [None]:  # a run of the walk / slope5 sections alone: times
            num_envs = batch = updates = rate = None
            if entry is not None:
                num_envs, batch = int(entry["num_envs"]), int(entry["batch_size"])
                updates, rate = int(entry["updates_per_step"]), entry.get("quadcos_env_steps_per_s")
            rows.append(
                {
                    "terrain": run["terrain"],
                    "impl": run["impl"],
                    "num_devices": devices,
                    # a run over several processes (a GPU each): how many
                    **({"num_processes": processes} if processes > 1 else {}),
                    "num_envs": num_envs,
                    "envs_per_device": num_envs and num_envs // devices,
                    "batch_per_device": batch and batch // devices,
                    "updates_per_step": updates,
                    "env_steps_per_s": rate,
                    **times,
                }
            )
    for row in rows:
        same = lambda other: all(  # noqa: E731
            other[key] == row[key]
            for key in _SAME_WORK
        )
        base = next((other for other in rows if other["num_devices"] == 1 and same(other)), None)
        rate, base_rate = row["env_steps_per_s"], base and base["env_steps_per_s"]
        row["speedup"] = rate / base_rate if rate and base_rate else None
    return sorted(
        rows,
        key=lambda row: (
            row["terrain"],
            row["envs_per_device"] or 0,
            row["updates_per_step"] or 0,
            row["num_devices"],
        ),
    )


def table(rows: Sequence[dict[str, Any]]) -> str:
    """The rows as Markdown."""

    def number(value: float | None, form: str) -> str:
        return "—" if value is None else format(value, form)

    lines = [
        "| terrain | physics | devices | envs (per device) | updates / env step | env-steps/s"
        " | × one device | time to walk (s) | time to cross slope5 (s) |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        envs = "—" if row["num_envs"] is None else f"{row['num_envs']} ({row['envs_per_device']})"
        processes = row.get("num_processes")
        devices = f"{row['num_devices']}" + (f" ({processes} processes)" if processes else "")
        lines.append(
            f"| {row['terrain']} | {row['impl']} | {devices} | {envs}"
            f" | {number(row['updates_per_step'], 'd')} | {number(row['env_steps_per_s'], ',.0f')}"
            f" | {number(row['speedup'], '.2f')}"
            f" | {number(row['time_to_walk_flat_s'], '.1f')}"
            f" | {number(row['time_to_cross_slope5_s'], '.1f')} |"
        )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = cli.raising(argparse.ArgumentParser(prog=f"python -m {_PROG}", description=__doc__))
    parser.add_argument("inputs", nargs="+", help="bench result JSONs")
    parser.add_argument("--out", required=True, help="the combined JSON")
    try:
        args = parser.parse_args(argv)
        runs = []
        for name in args.inputs:
            try:
                runs.append(json.loads(pathlib.Path(name).read_text()))
            except (OSError, ValueError) as error:
                raise cli.UsageError(f"{name}: not a readable bench JSON ({error})") from None
        rows = scaling_rows(runs)
    except (cli.UsageError, KeyError, ValueError) as error:
        cli.print_error(_PROG, error)
        return cli.EXIT_USAGE
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    record = {"rows": rows, "runs": runs, "inputs": args.inputs}
    files.atomic_write_text(out, json.dumps(record, separators=(",", ":")) + "\n")
    print(table(rows))
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
