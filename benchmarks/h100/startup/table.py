"""Markdown tables of start-up runs (`before_after.sh`'s output folder):

    python benchmarks/h100/startup/table.py benchmarks/h100/startup/runs [--events RUN]

First, per run: process start → first chunk done, → first evaluation done, and the whole
process's wall time (from `status`). With `--events RUN`: that run's events, each with its share
of the seconds and of JAX's tracing, lowering and compiling or loading."""

import argparse
import json
import pathlib
import re


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("folder", type=pathlib.Path)
    parser.add_argument("--events")
    args = parser.parse_args()
    walls = dict(re.findall(r"(\S+) process wall ([\d.]+) s", (args.folder / "status").read_text()))
    print("| run | first chunk done | first evaluation done | process wall |")
    print("|---|---:|---:|---:|")
    for path in sorted(args.folder.glob("*.startup.json")):
        name = path.name.removesuffix(".startup.json")
        if name == "fill":
            continue
        record = json.loads(path.read_text())
        seconds = record.get("seconds", record)
        print(f"| {name} | {seconds['first_chunk']:.1f} | {seconds['first_evaluation']:.1f} "
              f"| {float(walls[name]):.1f} |")
    if args.events:
        record = json.loads((args.folder / f"{args.events}.startup.json").read_text())
        print(f"\n| event ({args.events}) | s | + s | trace | lower | compile or load |")
        print("|---|---:|---:|---:|---:|---:|")
        previous = 0.0
        for event, at in record["seconds"].items():
            jax_s = record["compile"][event]
            print(f"| {event} | {at:.2f} | {at - previous:.2f} | {jax_s['trace_s']:.2f} "
                  f"| {jax_s['lower_s']:.2f} | {jax_s['compile_s']:.2f} |")
            previous = at


if __name__ == "__main__":
    main()
