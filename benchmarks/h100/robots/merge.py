"""Puts the Menagerie robots' train rows beside the paper robot's in benchmarks/h100.json.

    python benchmarks/h100/robots/merge.py benchmarks/h100/robots/bench_*_train.json \
        --into benchmarks/h100.json

Each input is one `python -m quadcos.bench --robot=... --only physics,train` process; its train
rows (named by robot, impl and terrain) are merged with `quadcos.benchmarking.results.merge_results`,
each carrying `physics_env_steps_per_s`: the raw physics rate its own process measured at the
row's envs, over the robot's physics steps per env step. The top-level physics and env rates are
left out: they are keyed by env count alone and would mix robots.
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
    parser.add_argument("inputs", nargs="+", type=pathlib.Path)
    parser.add_argument("--into", type=pathlib.Path, required=True)
    args = parser.parse_args()
    merged = json.loads(args.into.read_text())
    for path in args.inputs:
        merged = results_lib.merge_results(merged, train_rows(path))
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
