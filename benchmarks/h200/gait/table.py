"""The gait campaign's table: each row's trainer against the raw physics of standing robots and
of robots walking the fixed trot, both measured in the row's own process, and against the
default's walking physics on the same terrain. Each folder's rows are the `bench_NAME_TERRAIN.json`
it holds (NAME one of ROWS; `warp`, as `benchmarks/h100/run.sh` names its files, is the default).

    python benchmarks/h200/gait/table.py benchmarks/h100/gait/default benchmarks/h100/gait/jax
"""

import json
import pathlib
import sys

ROWS = {
    "default": "MJX's default (Warp's own graphs, the solver's early exit)",
    "warp": "MJX's default (Warp's own graphs, the solver's early exit)",
    "gc0": "`warp.graph_conditional=false`",
    "jax": "`warp.graph_mode=jax`, `graph_conditional=false`",
    "jax_overlap": "the same, `sac.overlap_updates=true`",
}


def main(folders: list[pathlib.Path]) -> None:
    print(
        "| terrain | row | raw physics, standing (k env-steps/s) | walking | train, 1 update |"
        " / standing | / walking | / the default's walking | train, 8 updates | / walking |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    many = len(folders) > 1
    for terrain in ("flat", "slope5"):
        default_walking = None
        found = [  # several folders: each row names its own
            (folder / f"bench_{name}_{terrain}.json", label + f" (`{folder.name}/`)" * many)
            for folder in folders
            for name, label in ROWS.items()
        ]
        for path, label in [(path, label) for path, label in found if path.exists()]:
            results = json.loads(path.read_text())
            rows = {row["updates_per_step"]: row for row in results["train"]}
            one, eight = rows[1], rows[8]
            standing, walking = one["physics_env_steps_per_s"], one["gait_physics_env_steps_per_s"]
            default_walking = default_walking or walking
            train = one["quadcos_env_steps_per_s"]
            print(
                f"| {terrain} | {label} | {standing / 1e3:.0f} | {walking / 1e3:.0f} |"
                f" {train / 1e3:.0f} k | {train / standing:.2f} | {train / walking:.2f} |"
                f" {train / default_walking:.2f} | {eight['quadcos_env_steps_per_s'] / 1e3:.0f} k |"
                f" {eight['quadcos_env_steps_per_s'] / walking:.2f} |"
            )


if __name__ == "__main__":
    main([pathlib.Path(arg) for arg in sys.argv[1:]])
