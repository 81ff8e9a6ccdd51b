"""The idle-lever table of docs/benchmarks.md from this folder's bench JSONs.

    python benchmarks/h200/idle_levers/table.py benchmarks/h200/idle_levers
"""

import json
import pathlib
import sys

ROWS = ("flat_cond", "flat_select", "flat_cond_gc0", "flat_select_gc0")
ROWS += ("slope5_cond", "slope5_select", "slope5_select_gc0")


def main(folder: pathlib.Path) -> None:
    print("| row | raw physics (k env-steps/s) | train, 1 update | ratio | train, 8 updates |")
    print("|---|---:|---:|---:|---:|")
    for name in ROWS:
        bench = json.loads((folder / f"bench_{name}.json").read_text())
        trains = {row["updates_per_step"]: row["quadcos_env_steps_per_s"] for row in bench["train"]}
        physics = bench["physics_steps_per_s"]["4096"] / bench["substeps_per_env_step"]
        eight = f"{trains[8] / 1e3:.0f}" if 8 in trains else "—"
        print(
            f"| {name} | {physics / 1e3:.0f} | {trains[1] / 1e3:.0f} | {trains[1] / physics:.2f}"
            f" | {eight} |"
        )


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]))
