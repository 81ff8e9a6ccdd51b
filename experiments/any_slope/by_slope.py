"""Held-out success by how steep a course is: the `testset:SEED` courses binned by their steepest
section, the mean course success of each evaluation in each bin.

    python experiments/any_slope/by_slope.py EVAL.json ... > experiments/any_slope/by_slope.md

Each EVAL.json is a `python -m quadcos.evaluate --terrain=testset:SEED` result (its "courses");
a course's steepest section is the largest |slope_at| along its lane, from x = 0 to its end.
"""

import json
import math
import pathlib
import sys

import numpy as np

from quadcos import terrain

BINS_DEG = ((0.0, 8.0), (8.0, 9.5), (9.5, 12.0))


def steepest_deg(spec: str) -> dict[str, float]:
    """Each random course of a test set (not flat / slope5 / s4): its steepest section, degrees."""
    ground = terrain.parse(spec)
    steepest = {}
    for lane in ground.lanes:
        if not lane.name.startswith("test"):
            continue
        x = np.arange(0.0, lane.course_end_x, 0.05)
        slopes = np.asarray(ground.slope_at(x, np.full_like(x, lane.y)))
        steepest[lane.name] = math.degrees(float(np.abs(slopes).max()))
    return steepest


def main(paths: list[str]) -> None:
    evaluations = {
        pathlib.Path(path).stem: json.loads(pathlib.Path(path).read_text()) for path in paths
    }
    specs = {result["setup"]["terrain"] for result in evaluations.values()}
    steepest = {spec: steepest_deg(spec) for spec in specs}
    bins = [f"{low:g}–{high:g}°" for low, high in BINS_DEG]
    print("| evaluation | " + " | ".join(bins) + " |")
    print("|---|" + "---:|" * len(bins))
    for name, result in evaluations.items():
        courses = steepest[result["setup"]["terrain"]]
        cells = []
        for low, high in BINS_DEG:
            inside = [c for c, deg in courses.items() if low < deg <= high]
            success = np.mean([result["courses"][c]["success_rate"] for c in inside])
            cells.append(f"{success:.3f} ({len(inside)})")
        print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
