"""Draws the paper's figures (PNG) of the experiments from training metrics and evaluation traces.

    python experiments/figures.py

Inputs: the runs' `metrics.jsonl` (committed under tests/data/trained) and the traces that the
evaluation commands write with `--trace` (not committed). A figure whose inputs are not there is
skipped with a line naming the command that writes them; the others are drawn next to their
experiment's README. Exit status 1 where nothing could be drawn.
"""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
# `python experiments/figures.py` puts this directory first on sys.path, where experiments/warp
# would shadow the warp package that MJX imports.
sys.path = [entry for entry in sys.path if Path(entry or ".").resolve() != HERE]

from quadcos.viz import plots  # noqa: E402

TRAINED = HERE.parent / "tests" / "data" / "trained"  # the runs' committed metrics
FLAT_SEEDS = [TRAINED / "flat" / f"flat_s{seed}" for seed in range(3)]
DRL_ONLY = TRAINED / "drl_only" / "joint_s0"
BEST_FIXED = "fixed:0.415688,0.13653,0.539947,1.63701,-1.50056"  # experiments/fixed_params
EVALUATE = "python -m quadcos.evaluate --num_envs=64"
# trace -> the command that writes it
TRACES = {
    HERE / "flat" / "trace_flat.json":
        f"{EVALUATE} --policy=experiments/policies/flat --trace=experiments/flat/trace_flat.json",
    HERE / "reward_xy" / "trace_xy_s0.json":
        "bash experiments/run_gpu.sh reward_xy, then copy $OUT/trace_xy_s0.json here",
    HERE / "slope5" / "trace_slope5.json":
        f"{EVALUATE} --policy=experiments/policies/slope5 --terrain=slope5 --seconds=40"
        " --trace=experiments/slope5/trace_slope5.json",
    HERE / "slope5" / "trace_s4.json":
        f"{EVALUATE} --policy=experiments/policies/slope5 --terrain=s4 --seconds=30"
        " --trace=experiments/slope5/trace_s4.json",
    HERE / "fixed_params" / "trace_slope5.json":
        f"{EVALUATE} --policy={BEST_FIXED} --terrain=slope5 --seconds=40"
        " --trace=experiments/fixed_params/trace_slope5.json",
}


def figures() -> list[tuple[Path, list[Path], object]]:
    """(PNG, its inputs, a function drawing it there) for each figure."""
    names = ("flat", "reward_xy", "slope5", "fixed_params")
    flat, xy, slope5, fixed = (HERE / name for name in names)
    trace_flat, trace_xy = flat / "trace_flat.json", xy / "trace_xy_s0.json"
    found = [
        (flat / "fig7_reward.png", [run / "metrics.jsonl" for run in FLAT_SEEDS],
         lambda path: plots.plot_learning_curves(
             {"oscillator + SAC (3 seeds)": FLAT_SEEDS}, path=path)),
        (HERE / "drl_only" / "speed_vs_oscillator.png",
         [run / "metrics.jsonl" for run in (*FLAT_SEEDS, DRL_ONLY)],
         lambda path: plots.plot_learning_curves(
             {"oscillator (3 seeds)": FLAT_SEEDS, "joint targets, DRL-only (1 seed)": [DRL_ONLY]},
             "eval/forward_speed", title="forward speed: rhythm controller vs DRL-only",
             path=path)),
        (flat / "fig8_cog.png", [trace_flat],
         lambda path: plots.plot_cog(trace_flat, title="flat: CoG (Fig. 8)", path=path)),
        (xy / "fig9_attitude.png", [trace_flat, trace_xy],
         lambda path: plots.plot_attitude(
             {"r (Eq. 13)": trace_flat, "r_xy": trace_xy},
             title="flat: attitude, full reward vs r_xy (Fig. 9)", path=path)),
    ]
    # experiments/policies/slope5 (from nothing, spawns along the course)
    for course, numbers in (("slope5", "12-14"), ("s4", "17-19")):
        trace = slope5 / f"trace_{course}.json"
        found += [
            (slope5 / f"{course}_cog.png", [trace],
             lambda path, t=trace, c=course: plots.plot_cog(t, title=f"{c}: CoG", path=path)),
            (slope5 / f"{course}_attitude.png", [trace],
             lambda path, t=trace, c=course: plots.plot_attitude(
                 t, title=f"{c}: attitude", path=path)),
            (slope5 / f"{course}_controller.png", [trace],
             lambda path, t=trace, c=course, n=numbers: plots.plot_controller(
                 t, title=f"{c}: controller outputs (Figs. {n})", path=path)),
        ]
    trace = fixed / "trace_slope5.json"
    found += [
        (fixed / "fig15_cog.png", [trace],
         lambda path: plots.plot_cog(
             trace, title="best fixed parameters on slope5 (Fig. 15)", path=path)),
        (fixed / "fig15_attitude.png", [trace],
         lambda path: plots.plot_attitude(trace, title="best fixed parameters on slope5: attitude",
                                          path=path)),
    ]
    return found


def _writer_of(path: Path) -> str:
    """The command that writes `path`, an input of a figure."""
    if path in TRACES:
        return TRACES[path]
    return (f"the run folder of `{path.parent.name}` (its experiment's run_gpu.sh) copied to"
            f" {path.parent.relative_to(HERE.parent)}")


def main() -> int:
    drawn = 0
    for png, inputs, draw in figures():
        missing = [path for path in inputs if not path.is_file()]
        if missing:
            print(f"skipped {png.relative_to(HERE)}: no {missing[0].relative_to(HERE.parent)}"
                  f" (written by: {_writer_of(missing[0])})")
            continue
        draw(png)
        drawn += 1
        print(f"drew {png.relative_to(HERE)}")
    return 0 if drawn else 1


if __name__ == "__main__":
    sys.exit(main())
