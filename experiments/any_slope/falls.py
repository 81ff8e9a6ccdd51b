"""Where the held-out test set's failed episodes end: on which kind of ground a policy falls.

    python experiments/any_slope/falls.py EVAL.json ... [--keep DIR] > falls.md

Each EVAL is a `python -m quadcos.evaluate --terrain=testset:SEED` result with its "episodes" (the
committed evaluation summaries have none: `bash experiments/run_gpu.sh any_slope_seeds` writes the
full ones), or what `--keep DIR` wrote from one: DIR/NAME.episodes.json.gz, the setup and each
episode's lane, fall and end position, which this reads again in place of the full file
(experiments/any_slope/seeds/falls.md: `python experiments/any_slope/falls.py
experiments/any_slope/seeds/*.episodes.json.gz`). A fall is counted by the ground's slope where
the robot ended (uphill / downhill: steeper than 3°, else level) and by whether the slope changes
by more than 3° within 0.4 m of that point (a crest or a dip).
"""

import argparse
import collections
import gzip
import json
import math
import pathlib

import numpy as np

from quadcos import terrain

STEEP_DEG = 3.0
NEAR_M = 0.4
KINDS = [(ground, change) for ground in ("up", "down", "level") for change in (True, False)]
KEPT = ("lane", "fell", "final_x")  # what --keep keeps of each episode
SUFFIX = ".episodes.json.gz"


def read(path: pathlib.Path) -> dict:
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt") as file:
        return json.load(file)


def name(path: pathlib.Path) -> str:
    return path.name.removesuffix(SUFFIX).removesuffix(".json")


def keep(result: dict, path: pathlib.Path) -> None:
    episodes = [{key: episode[key] for key in KEPT} for episode in result["episodes"]]
    with gzip.open(path, "wt") as file:
        json.dump({"setup": {"terrain": result["setup"]["terrain"]}, "episodes": episodes}, file)


def _slope_deg(ground, x: float, y: float) -> float:
    return math.degrees(float(np.asarray(ground.slope_at(np.array([x]), np.array([y])))[0]))


def fall_kinds(result: dict) -> collections.Counter:
    """The failed episodes of one evaluation, counted by (ground, near a slope change)."""
    ground = terrain.parse(result["setup"]["terrain"])
    counts = collections.Counter()
    for episode in result["episodes"]:
        if not episode["fell"]:
            continue
        y = ground.lanes[episode["lane"]].y
        x = episode["final_x"]
        here = _slope_deg(ground, x, y)
        change = abs(_slope_deg(ground, x + NEAR_M, y) - _slope_deg(ground, x - NEAR_M, y))
        kind = "up" if here > STEEP_DEG else "down" if here < -STEEP_DEG else "level"
        counts[kind, change > STEEP_DEG] += 1
    return counts


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("evaluations", nargs="+", type=pathlib.Path)
    parser.add_argument("--keep", type=pathlib.Path, help="write NAME.episodes.json.gz here")
    args = parser.parse_args(argv)
    labels = [f"{ground}{', at a change' if change else ''}" for ground, change in KINDS]
    print("| evaluation | falls | " + " | ".join(labels) + " |")
    print("|---|---:|" + "---:|" * len(KINDS))
    for path in args.evaluations:
        result = read(path)
        if args.keep:
            keep(result, args.keep / (name(path) + SUFFIX))
        counts = fall_kinds(result)
        cells = [str(counts[kind]) for kind in KINDS]
        print(f"| {name(path)} | {sum(counts.values())} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
