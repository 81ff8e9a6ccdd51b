"""The arena / graph-mode table of docs/benchmarks.md from campaign folders' bench JSONs: per
row its raw physics and training rates, and training against the raw physics of the default row
of the same folder (the same machine, the fastest physics).

    python benchmarks/h200/arena/table.py benchmarks/h200/arena/{main,eight,slope5,gc0} \
        benchmarks/h100/arena
"""

import json
import pathlib
import sys

SETTINGS = {  # row name without its terrain -> what it sets
    "default": "MJX's default (Warp's own graph a call)",
    "arena": "`warp.arena=true`",
    "gc0": "`warp.graph_conditional=false` (Warp's own graphs)",
    "jax_gc0": "`graph_mode=jax`, `graph_conditional=false`",
    "jax_gc0_while": "`graph_mode=jax`, `graph_conditional=false`, loops in command buffers",
    "jax_gc0_unroll": "`graph_mode=jax`, `graph_conditional=false`, `substep_unroll=10`",
}


def rates(path: pathlib.Path) -> tuple[float | None, dict[int, float]]:
    """Raw physics (env steps/s; None where the bench ran --only=train) and training (env
    steps/s by updates per env step)."""
    bench = json.loads(path.read_text())
    physics = bench.get("physics_steps_per_s", {}).get("4096")
    if physics is not None:
        physics /= bench["substeps_per_env_step"]
    train = {row["updates_per_step"]: row["quadcos_env_steps_per_s"] for row in bench["train"]}
    return physics, train


def rows(folders: list[pathlib.Path], settings: dict[str, str]):
    """(folder, terrain, label, raw physics, training by updates, the default row's raw physics)
    of each row of `settings` (row name without its terrain -> label) found in the folders."""
    for folder in folders:
        for terrain in ("flat", "slope5"):
            default = folder / f"bench_default_{terrain}.json"
            if not default.exists():
                continue
            base, _ = rates(default)
            for name, label in settings.items():
                path = folder / f"bench_{name}_{terrain}.json"
                if path.exists():
                    yield (folder, terrain, label, *rates(path), base)


def main(folders: list[pathlib.Path]) -> None:
    print(
        "| campaign | terrain | row | raw physics (k env-steps/s) | train, 1 update"
        " | / default's physics | train, 8 updates |"
    )
    print("|---|---|---|---:|---:|---:|---:|")
    for folder, terrain, label, physics, train, base in rows(folders, SETTINGS):
        eight = f"{train[8] / 1e3:.0f} k" if 8 in train else "—"
        raw = f"{physics / 1e3:.0f}" if physics else "—"
        ratio = f"{train[1] / base:.2f}" if base else "—"
        campaign = f"{folder.parent.name}/{folder.name}"
        print(
            f"| {campaign} | {terrain} | {label} | {raw} | {train[1] / 1e3:.0f} k"
            f" | {ratio} | {eight} |"
        )


if __name__ == "__main__":
    main([pathlib.Path(folder) for folder in sys.argv[1:]])
