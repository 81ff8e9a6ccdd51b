"""The overlap table of docs/benchmarks.md from the campaign folders' bench JSONs: per row its
raw physics (its own process, under its own settings) and training rates at 1 and 8 updates per
env step, and training against the raw physics of the default row of the same folder and terrain
(the same machine, the fastest physics).

    python benchmarks/h200/overlap/table.py benchmarks/h200/overlap/{code,barrier,main}
"""

import json
import pathlib
import sys

_CONC = "XLA's graphs concurrent"
SETTINGS = {  # row name without its terrain -> what it sets
    "default": "default (MJX-Warp's own graphs, the model behind a barrier in `code/` only)",
    "default8": "default",
    "fast": "`graph_mode=jax`, `graph_conditional=false`, `overlap_updates` (options by the code)",
    "overlap": "`overlap_updates`",
    "gc0": "`graph_conditional=false` (Warp's own graphs)",
    "jax": "`graph_mode=jax`, `graph_conditional=false`, loops in XLA's graphs",
    "jax_overlap": "as `jax`, `overlap_updates`",
    "jax_conc": f"as `jax`, {_CONC}",
    "jax_conc_overlap": f"as `jax`, {_CONC}, `overlap_updates`",
    "jax_conc_overlap8": f"as `jax`, {_CONC}, `overlap_updates`",
    "jax_conc_barrier": f"as `jax`, {_CONC}, the model behind a barrier",
    "jax_conc_overlap8_barrier": f"as `jax`, {_CONC}, `overlap_updates`, model behind a barrier",
}


def rates(path: pathlib.Path) -> tuple[float, dict[int, float]]:
    """Raw physics (env steps/s at 4096 envs) and training (env steps/s by updates per step)."""
    bench = json.loads(path.read_text())
    physics = bench["physics_steps_per_s"]["4096"] / bench["substeps_per_env_step"]
    train = {row["updates_per_step"]: row["quadcos_env_steps_per_s"] for row in bench["train"]}
    return physics, train


def main(folders: list[pathlib.Path]) -> None:
    print(
        "| campaign | terrain | row | raw physics, own settings (k env-steps/s) | train, 1 update"
        " | / default's physics | train, 8 updates | / default's physics |"
    )
    print("|---|---|---|---:|---:|---:|---:|---:|")
    for folder in folders:
        for terrain in ("flat", "slope5"):
            default = folder / f"bench_default_{terrain}.json"
            if not default.exists():
                continue
            base, _ = rates(default)
            for name, label in SETTINGS.items():
                path = folder / f"bench_{name}_{terrain}.json"
                if not path.exists():
                    continue
                physics, train = rates(path)
                cells = []
                for updates in (1, 8):
                    rate = train.get(updates)
                    if rate is None:
                        cells += ["—", "—"]
                    else:
                        cells += [f"{rate / 1e3:.0f} k", f"{rate / base:.2f}"]
                print(
                    f"| {folder.name} | {terrain} | {label} | {physics / 1e3:.0f} | "
                    + " | ".join(cells)
                    + " |"
                )


if __name__ == "__main__":
    main([pathlib.Path(arg) for arg in sys.argv[1:]])
