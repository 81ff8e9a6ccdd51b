"""Draws every experiment's figures (PNG) from training metrics and evaluation traces.

    python experiments/figures.py

Inputs: the committed `metrics.jsonl` of the runs, and the traces that each experiment's
evaluation command writes with `--trace` (traces are not committed: rerun the commands in the
experiment's README first). Outputs go next to them.
"""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
# `python experiments/figures.py` puts this directory first on sys.path, where experiments/warp
# would shadow the warp package that MJX imports.
sys.path = [entry for entry in sys.path if Path(entry or ".").resolve() != HERE]

from quadcos.viz import plots  # noqa: E402


def main() -> None:
    flat, xy, slope5, fixed = (HERE / name for name in ("flat", "reward_xy", "slope5", "fixed_params"))
    seeds = [flat / f"flat_s{seed}" for seed in range(3)]
    plots.plot_learning_curves({"oscillator + SAC (3 seeds)": seeds}, path=flat / "fig7_reward.png")
    plots.plot_learning_curves(
        {"oscillator (3 seeds)": seeds, "joint targets, DRL-only (1 seed)": [HERE / "drl_only" / "joint_s0"]},
        "eval/forward_speed",
        title="forward speed: rhythm controller vs DRL-only",
        path=HERE / "drl_only" / "speed_vs_oscillator.png",
    )
    plots.plot_cog(flat / "trace_flat.json", title="flat: CoG (Fig. 8)", path=flat / "fig8_cog.png")
    plots.plot_attitude(
        {"r (Eq. 13)": flat / "trace_flat.json", "r_xy": xy / "trace_xy_s0.json"},
        title="flat: attitude, full reward vs r_xy (Fig. 9)",
        path=xy / "fig9_attitude.png",
    )
    # experiments/policies/slope5 (from scratch, spawns along the course; traced on the CPU)
    for course, figs in (("slope5", "12-14"), ("s4", "17-19")):
        trace = slope5 / f"trace_{course}.json"
        plots.plot_cog(trace, title=f"{course}: CoG", path=slope5 / f"{course}_cog.png")
        plots.plot_attitude(trace, title=f"{course}: attitude", path=slope5 / f"{course}_attitude.png")
        plots.plot_controller(trace, title=f"{course}: controller outputs (Figs. {figs})",
                              path=slope5 / f"{course}_controller.png")
    plots.plot_cog(fixed / "trace_slope5.json", title="best fixed parameters on slope5 (Fig. 15)",
                   path=fixed / "fig15_cog.png")
    plots.plot_attitude(fixed / "trace_slope5.json", title="best fixed parameters on slope5: attitude",
                        path=fixed / "fig15_attitude.png")


if __name__ == "__main__":
    main()
