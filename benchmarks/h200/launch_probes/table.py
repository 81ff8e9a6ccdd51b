"""The launch-probe table of docs/benchmarks.md from this folder's bench JSONs.

python benchmarks/h200/launch_probes/table.py benchmarks/h200/launch_probes
"""

import json
import pathlib
import sys

# (row, its bench JSON's suffix): each probe beside the plain bench run of the same campaign.
ROWS = (
    ("as it is", "ahead"),
    ("host waits for the GPU before each Warp graph", "synced"),
    ("as it is (second campaign)", "ahead2"),
    ("Warp graphs on a stream of their own", "side"),
)


def main(folder: pathlib.Path) -> None:
    print(
        "| row (Warp, 4096 envs, 1 update) | flat: raw physics | train"
        " | slope5: raw physics | train |"
    )
    print("|---|---:|---:|---:|---:|")
    for label, suffix in ROWS:
        cells = []
        for terrain in ("flat", "slope5"):
            bench = json.loads((folder / f"bench_{terrain}_{suffix}.json").read_text())
            physics = bench["physics_steps_per_s"]["4096"] / bench["substeps_per_env_step"]
            train = bench["train"][0]["quadcos_env_steps_per_s"]
            cells += [f"{physics / 1e3:.0f} k", f"{train / 1e3:.0f} k"]
        print(f"| {label} | {' | '.join(cells)} |")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]))
