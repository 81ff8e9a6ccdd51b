"""Where on flat ground a policy's largest attitude error comes: the step off from standing or the
walk after it.

    python experiments/any_slope/step_off.py TRACE.json ... \
        > experiments/any_slope/seeds/step_off.txt

Each TRACE is one flat episode of `python -m quadcos.evaluate --trace` (`any_slope_seeds` writes
`trace_NAME_flat.json`; traces are large and stay out of git). Prints, per trace, max |pitch − θ|
(θ the ground's slope under the robot), |yaw| and |roll| (rad) over t < 1 s and t ≥ 1 s, and when
the largest |pitch − θ| came.
"""

import json
import pathlib
import sys

import numpy as np


def main(paths: list[str]) -> None:
    print(
        "| trace | max \\|pitch − θ\\|: t < 1 s, t ≥ 1 s (at s) | max \\|yaw\\|: t < 1 s, t ≥ 1 s"
        " | max \\|roll\\|: t < 1 s, t ≥ 1 s |"
    )
    print("|---|---|---|---|")
    for path in map(pathlib.Path, paths):
        series = {k: np.asarray(v) for k, v in json.loads(path.read_text())["series"].items()}
        start = series["time"] < 1.0
        pitch_error = np.abs(series["pitch"] - series["expected_pitch"])
        at = series["time"][pitch_error.argmax()]
        cells = [
            f"{values[start].max():.3f}, {values[~start].max():.3f}"
            for values in (pitch_error, np.abs(series["yaw"]), np.abs(series["roll"]))
        ]
        cells[0] += f" ({at:.2f})"
        print(f"| {path.stem} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
