"""The gait campaign's table: each row's trainer against the raw physics of standing robots and
of robots walking the fixed trot, both measured in the row's own process, and against the
default's walking physics on the same terrain.

    python benchmarks/h200/gait/table.py benchmarks/h200/gait/main
"""

import json
import pathlib
import sys

ROWS = {
    "default": "MJX's default (Warp's own graphs, the solver's early exit)",
    "gc0": "`warp.graph_conditional=false`",
    "jax": "`warp.graph_mode=jax`, `graph_conditional=false`",
    "jax_overlap": "the same, `sac.overlap_updates=true`",
}


def main(folder: pathlib.Path) -> None:
    print(
        "| terrain | row | raw physics, standing (k env-steps/s) | walking | train, 1 update |"
        " / standing | / walking | / the default's walking | train, 8 updates | / walking |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for terrain in ("flat", "slope5"):
        default_walking = None
        for name, label in ROWS.items():
            results = json.loads((folder / f"bench_{name}_{terrain}.json").read_text())
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
    main(pathlib.Path(sys.argv[1]))
