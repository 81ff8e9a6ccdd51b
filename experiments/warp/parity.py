"""MJX-JAX vs MJX-Warp on the committed policies: the same deterministic evaluation with each
physics implementation, then the differences and a figure of one episode's trajectory.

    python experiments/warp/parity.py run --num_envs=1024     # on a GPU with warp-lang: eval_*.json, trace_*.json
    python experiments/warp/parity.py run --num_envs=16 --seconds_scale=0.25 --dir=experiments/warp/cpu16  # the CPU check
    python experiments/warp/parity.py report [--dir=...]       # anywhere: parity.json, parity.png
"""

import argparse
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
POLICIES = Path(__file__).resolve().parent.parent / "policies"
CASES = {"flat": ("flat", 20.0), "slope5_trot": ("slope5", 40.0)}  # policy -> (terrain, seconds)
IMPLS = ("jax", "warp")
SUCCESS_TOLERANCE = 0.02  # the bounds
SPEED_TOLERANCE = 0.03


def run(out: Path, num_envs: int, seconds_scale: float = 1.0) -> None:
    from quadcos import evaluation
    from quadcos._util import caches

    caches.enable()
    for policy, (terrain, seconds) in CASES.items():
        for impl in IMPLS:
            result = evaluation.evaluate(
                str(POLICIES / policy),
                terrain,
                num_envs=num_envs,
                seconds=seconds * seconds_scale,
                env_overrides={"impl": impl},
            )
            evaluation.write_json(out / f"eval_{policy}_{impl}.json", result.to_json())
            evaluation.write_json(out / f"trace_{policy}_{impl}.json", result.trace)
            print(policy, impl, json.dumps({k: result.summary[k] for k in ("success_rate", "mean_forward_speed")}))


def _missing(out: Path, kind: str) -> str:
    """The `kind` files (eval, trace) that `run` writes and `out` lacks, and the command."""
    names = [f"{kind}_{policy}_{impl}.json" for policy in CASES for impl in IMPLS]
    missing = [name for name in names if not (out / name).exists()]
    return f"{', '.join(missing)} missing in {out} (parity.py run --dir={out})" if missing else ""


def report(out: Path) -> None:
    if missing := _missing(out, "eval"):
        raise SystemExit(f"parity.py report: {missing}")
    rows = {}
    for policy in CASES:
        summary = {impl: json.loads((out / f"eval_{policy}_{impl}.json").read_text()) for impl in IMPLS}
        success = {impl: summary[impl]["success_rate"] for impl in IMPLS}
        speed = {impl: summary[impl]["mean_forward_speed"] for impl in IMPLS}
        rows[policy] = {
            "episodes": summary["jax"]["setup"]["num_envs"],
            "success": success,
            "speed": speed,
            "success_difference": success["warp"] - success["jax"],
            "speed_ratio": speed["warp"] / speed["jax"],
            "within_tolerance": abs(success["warp"] - success["jax"]) <= SUCCESS_TOLERANCE
            and abs(speed["warp"] / speed["jax"] - 1) <= SPEED_TOLERANCE,
        }
    (out / "parity.json").write_text(json.dumps(rows, indent=1) + "\n")
    print(json.dumps(rows, indent=1))
    missing = _missing(out, "trace")  # the traces stay out of git
    print(f"parity.png not redrawn: {missing}") if missing else _figure(out)


def _figure(out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from quadcos.viz import plots

    fig, axes = plt.subplots(len(CASES), 2, figsize=(10, 6), constrained_layout=True)
    for row, policy in enumerate(CASES):
        for impl, style in zip(IMPLS, ("-", "--")):
            series = json.loads((out / f"trace_{policy}_{impl}.json").read_text())["series"]
            time = np.asarray(series["time"])
            axes[row, 0].plot(time, series["cog_x"], style, label=f"impl={impl}")
            axes[row, 1].plot(time, series["pitch"], style, label=f"impl={impl}")
        axes[row, 0].set(title=f"{policy}: CoG x", xlabel="t (s)", ylabel="x (m)")
        axes[row, 1].set(title=f"{policy}: pitch", xlabel="t (s)", ylabel="rad")
        axes[row, 0].legend()
    plots.save(fig, out / "parity.png")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("mode", choices=("run", "report"))
    parser.add_argument("--num_envs", type=int, default=1024)
    parser.add_argument("--seconds_scale", type=float, default=1.0, help="shorter episodes (CPU)")
    parser.add_argument("--dir", type=Path, default=HERE, help="where the JSON and figure go")
    args = parser.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)
    run(args.dir, args.num_envs, args.seconds_scale) if args.mode == "run" else report(args.dir)
