"""Where on flat ground the generalist's largest pitch error comes: its first second or its walk.

    python experiments/any_slope/posture/flat_start/start_vs_walk.py > experiments/any_slope/posture/flat_start/start_vs_walk.txt

Reads the traces of four of the 16 CPU episodes (`trace_flat_e{0,5,10,15}.json`, made by the
commands in ../../README.md) and prints max |pitch − θ|, |yaw| and |roll| (rad) over
t < 1 s and t ≥ 1 s of each.
"""

import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

print("episode | max |pitch − θ|: t < 1 s, t ≥ 1 s | max |yaw|: t < 1 s, t ≥ 1 s | max |roll|: t < 1 s, t ≥ 1 s")
for path in sorted(HERE.glob("trace_flat_e*.json"), key=lambda p: int(p.stem.split("_e")[1])):
    trace = json.loads(path.read_text())
    series = {key: np.asarray(value) for key, value in trace["series"].items()}
    start = series["time"] < 1.0
    pitch_error = np.abs(series["pitch"] - series["expected_pitch"])
    cells = [
        f"{values[start].max():.3f}, {values[~start].max():.3f}"
        for values in (pitch_error, np.abs(series["yaw"]), np.abs(series["roll"]))
    ]
    print(f"{trace['episode']} | " + " | ".join(cells))
