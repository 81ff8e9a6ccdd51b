"""The overlap table of docs/benchmarks.md from the campaign folders' bench JSONs: per row its
raw physics (its own process, under its own settings) and training rates at 1 and 8 updates per
env step, and training against the raw physics of the default row of the same folder and terrain
(the same machine, the fastest physics).

    python benchmarks/h200/overlap/table.py benchmarks/h200/overlap/{code,barrier,main}
"""

import importlib.util
import pathlib
import sys

# The bench JSONs' rows as the arena table reads them.
_spec = importlib.util.spec_from_file_location(
    "arena_table", pathlib.Path(__file__).parents[1] / "arena" / "table.py"
)
_arena = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_arena)

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


def main(folders: list[pathlib.Path]) -> None:
    print(
        "| campaign | terrain | row | raw physics, own settings (k env-steps/s) | train, 1 update"
        " | / default's physics | train, 8 updates | / default's physics |"
    )
    print("|---|---|---|---:|---:|---:|---:|---:|")
    for folder, terrain, label, physics, train, base in _arena.rows(folders, SETTINGS):
        cells = []
        for updates in (1, 8):
            rate = train.get(updates)
            if rate is None:
                cells += ["—", "—"]
            else:
                cells += [f"{rate / 1e3:.0f} k", f"{rate / base:.2f}"]
        cells = " | ".join(cells)
        print(f"| {folder.name} | {terrain} | {label} | {physics / 1e3:.0f} | {cells} |")


if __name__ == "__main__":
    main([pathlib.Path(arg) for arg in sys.argv[1:]])
