"""Merges train rows measured in separate processes into benchmarks/h100.json.

    python benchmarks/h100/merge.py benchmarks/h100/robots/bench_*_train.json \
        benchmarks/h100/randomized/bench_warp_flat*.json --into benchmarks/h100.json \
        --startup benchmarks/h100/startup/runs/cold_new2.startup.json \
        benchmarks/h100/startup/runs/warm_new4.startup.json

Each input is one `python -m quadcos.bench ... --only physics,train` process; its train rows (named
by robot, impl, terrain, cache and randomisation) are merged with
`quadcos.benchmarking.results.merge_results`, each carrying `physics_env_steps_per_s`: the raw
physics rate its own process measured at the row's envs, over the robot's physics steps per env
step. The top-level physics and env rates are left out: they are keyed by env count alone and
would mix robots. `--startup COLD WARM`: two runs' `startup.json` (`quadcos.train`'s, empty and
warm caches); their `first_chunk` (process start → the first compiled training chunk done)
becomes `startup_cold_s` / `startup_warm_s`, each file's events `startup_cold` / `startup_warm` and
their compile breakdown `startup_cold_compile` / `startup_warm_compile`.
"""

import argparse
import json
import pathlib

from quadcos.benchmarking import results as results_lib


def train_rows(path: pathlib.Path) -> dict:
    """`path`'s results with only its train rows (each with its process's physics rate)."""
    measured = json.loads(path.read_text())
    rows = []
    for row in measured["train"]:
        physics = measured["physics_steps_per_s"].get(str(row["num_envs"]))
        if physics is not None:
            row = {**row, "physics_env_steps_per_s": physics / measured["substeps_per_env_step"]}
        rows.append(row)
    return {"device": measured["device"], "train": rows, "command": measured["command"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("inputs", nargs="*", type=pathlib.Path)
    parser.add_argument("--into", type=pathlib.Path, required=True)
    parser.add_argument("--startup", nargs=2, type=pathlib.Path, metavar=("COLD", "WARM"))
    args = parser.parse_args()
    merged = json.loads(args.into.read_text())
    for path in args.inputs:
        merged = results_lib.merge_results(merged, train_rows(path))
    for cache, path in zip(("cold", "warm"), args.startup or (), strict=False):
        record = json.loads(path.read_text())
        events = record.get("seconds", record)  # older files: the events alone
        merged[f"startup_{cache}_s"] = events["first_chunk"]
        merged[f"startup_{cache}"] = events
        if "compile" in record:
            merged[f"startup_{cache}_compile"] = record["compile"]
    args.into.write_text(json.dumps(merged, indent=1) + "\n")
    for row in merged["train"]:
        physics = row.get("physics_env_steps_per_s")
        ratio = (
            ""
            if not physics
            else f"  ours / physics {row['quadcos_env_steps_per_s'] / physics:.2f}"
        )
        print(
            f"{row.get('robot', 'quadcos')} {row['terrain']} {row['impl']} {row['num_envs']}"
            f"x{row['batch_size']}x{row['updates_per_step']}{ratio}"
        )


if __name__ == "__main__":
    main()
