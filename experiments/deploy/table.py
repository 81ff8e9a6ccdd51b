"""The deploy table from `run.sh`'s JSONs: success, falls and speed per policy, terrain and condition.

    python experiments/deploy/table.py OUT
"""

import json
import pathlib
import sys

CONDITIONS = (
    ("nominal", "nominal"),
    ("latency20", "20 ms latency"),
    ("latency40", "40 ms latency"),
    ("noise", "observation noise, std 0.02"),
)


def main() -> None:
    folder = pathlib.Path(sys.argv[1])
    print("| policy (.onnx) | terrain | condition | success | falls | speed m/s |")
    print("|---|---|---|---:|---:|---:|")
    for policy, terrain in (("flat", "flat"), ("flat_robust", "flat"), ("slope5", "slope5")):
        for key, label in CONDITIONS:
            path = folder / f"{policy}_{terrain}_{key}.json"
            if not path.is_file():
                continue
            result = json.loads(path.read_text())
            print(
                f"| {policy} | {terrain} | {label} | {result['success_rate']:.3f} |"
                f" {result['fall_rate']:.3f} | {result['mean_forward_speed']:.2f} |"
            )


if __name__ == "__main__":
    main()
