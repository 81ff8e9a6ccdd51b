"""C MuJoCo's solver iterations against one policy's episodes: a Markdown row per evaluation JSON
(`python -m quadcos.sim2sim --physics=...`), sorted by solver then line-search iterations.

    python experiments/robots/solver/table.py FILE.json [FILE.json ...]
"""

import json
import pathlib
import sys


def main(paths: list[str]) -> None:
    rows = []
    for path in map(pathlib.Path, paths):
        result = json.loads(path.read_text())
        physics = result["setup"]["physics"]
        rows.append((physics["iterations"], physics["ls_iterations"], result, path.name))
    print("| solver / line-search iterations | episodes | crossed | falls | speed m/s | file |")
    print("|---|---:|---:|---:|---:|---|")
    for iterations, ls_iterations, result, name in sorted(rows, key=lambda row: row[:2]):
        print(
            f"| {iterations} / {ls_iterations} | {result['num_episodes']} |"
            f" {result['success_rate']:.3f} | {result['fall_rate']:.3f} |"
            f" {result['mean_forward_speed']:.2f} | `{name}` |"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
