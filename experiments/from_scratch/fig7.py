"""Fig. 7 from scratch: learning curves of `--preset=scratch` on flat (gpu/scratch_best: gait search,
then SAC for 20 M env steps, 3 seeds, each alone on an H100) beside the trot-start runs of ../flat
(3 seeds, 10 M env steps), and each seed's time to walk.

    python experiments/from_scratch/fig7.py     # -> fig7_from_scratch.png, fig7_summary.json

and prints a Markdown table of the final policies' 1024-episode evaluations (gpu/**/eval_*.json,
summaries written by `quadcos.evaluate`) beside the trot-start policies' (../flat/eval_flat*.json).

A run's curve starts with its gait search: one point per search round (the best candidate's
5-s episodes, and the fraction of all candidates' robots that fell), then SAC's evaluations
(1024 deterministic 20-s episodes). "Walking" is the issue's target: at most 1 % of the
evaluation episodes fall and the mean forward speed is at least 0.5 m/s.
"""

import gzip
import json
import re
from pathlib import Path

HERE = Path(__file__).resolve().parent
# `--preset=scratch`: clock from process start; s0 ran first on a cold machine.
RUNS = {f"scratch s{seed}": HERE / "gpu" / "scratch_best" / f"scratch_best_s{seed}" for seed in range(3)}
ABLATIONS = {
    "full 5-D box s0 (10 M)": HERE / "gpu" / "scratch_full_box_s0",
    "r_s alive s0": HERE / "gpu" / "scratch_alive_s0",
    # §5's DRL-only (joint targets) with the same learner less the search, 20 M env steps (the
    # three seeds shared one GPU; the 10 M-step runs: ../drl_only/joint_scratch_s*).
    **{f"DRL-only s{seed}": HERE.parent / "drl_only" / f"joint20_s{seed}" for seed in range(3)},
}
TROT_START = {f"trot start s{seed}": HERE.parent / "flat" / f"flat_s{seed}" for seed in range(3)}
EVALUATIONS = {
    **{
        f"scratch s{seed}, 20 M, {which} policy": HERE
        / "gpu"
        / "scratch_best"
        / f"eval_scratch_best_s{seed}_{which}.json"
        for seed in range(3)
        for which in ("last", "best")
    },
    **{
        f"scratch s{seed}, 20 M, no best kept": HERE
        / "gpu"
        / "scratch20"
        / f"eval_scratch20_s{seed}.json"
        for seed in range(3)
    },
    "scratch s0, 10 M (GPU, Warp)": HERE / "gpu" / "eval_scratch_s0_rerun.json",
    "s0 first run (cold, capped)": HERE / "gpu" / "eval_scratch_s0.json",
    **{f"scratch s{seed}, 10 M": HERE / "gpu" / f"eval_scratch_s{seed}.json" for seed in (1, 2)},
    "full 5-D box s0": HERE / "gpu" / "eval_scratch_full_box_s0.json",
    **{
        f"trot start {name} (CPU, experiments/flat)": HERE.parent / "flat" / f"eval_{name}.json"
        for name in ("flat", "flat_s1", "flat_s2")
    },
}
_COLUMNS = (
    "success_rate",
    "fall_rate",
    "mean_forward_speed",
    "mean_max_abs_roll",
    "mean_max_abs_yaw",
    "mean_max_abs_pitch_error",
    "mean_lateral_drift",
)
MAX_FALL_RATE = 0.01
MIN_SPEED = 0.5
_ROUND = re.compile(
    r"gait search round (\d+)/\d+ \(([\d.]+) s\): (\d+) of (\d+) candidates never fell; best (\S+) at (-?[\d.]+) m/s"
)


def search_rounds(run: Path) -> list[dict]:
    """The search rounds logged in a run's train.log."""
    rounds = []
    for match in _ROUND.finditer((run / "train.log").read_text()):
        index, seconds, never_fell, candidates, _, speed = match.groups()
        rounds.append(
            {
                "round": int(index),
                "wall_time_s": float(seconds),
                "candidates_that_fell": 1 - int(never_fell) / int(candidates),
                "best_speed": float(speed),
            }
        )
    return rounds


def evaluations(run: Path) -> list[dict]:
    rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
    return [row for row in rows if "eval/fall_rate" in row]


def time_to_walk(rows: list[dict]) -> dict | None:
    for row in rows:
        if row["eval/fall_rate"] <= MAX_FALL_RATE and row["eval/forward_speed"] >= MIN_SPEED:
            return {"env_steps": row["step"], "wall_time_s": row["wall_time_s"]}
    return None


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from quadcos.viz import plots

    curves = {**RUNS, **ABLATIONS, **TROT_START}
    missing = [str(run.relative_to(HERE.parent)) for run in curves.values() if not run.is_dir()]
    if missing:  # run folders stay out of git
        raise SystemExit(f"fig7.py: {len(missing)} run folders missing: {', '.join(missing)}"
                         " (experiments/run_gpu.sh writes them under $OUT/runs)")
    summary = {}
    fig, axes = plt.subplots(2, 3, figsize=(15, 8), constrained_layout=True)
    for name, run in curves.items():
        rows = evaluations(run)
        style = {} if name in RUNS else {"ls": ":" if name in TROT_START else "--"}
        config = json.loads((run / "config.json").read_text())
        summary[name] = {
            "run": str(run.relative_to(HERE.parent)),
            "action_centre": config["run_info"]["env"].get("action_centre"),
            "gait_search_s": config["run_info"].get("gait_search_s"),
            "time_to_walk": time_to_walk(rows),
            "final": {
                key: rows[-1][f"eval/{key}"]
                for key in ("episode_reward", "fall_rate", "forward_speed")
            },
            "final_env_steps": rows[-1]["step"],
        }
        for column, key in enumerate(("episode_reward", "fall_rate", "forward_speed")):
            values = [row[f"eval/{key}"] for row in rows]
            line = axes[0, column].plot(
                [row["step"] / 1e6 for row in rows], values, marker=".", label=name, **style
            )
            axes[1, column].plot(
                [row["wall_time_s"] for row in rows], values, marker=".", color=line[0].get_color(), **style
            )
            if name in RUNS and key != "episode_reward":
                rounds = search_rounds(run)
                search = [r["candidates_that_fell" if key == "fall_rate" else "best_speed"] for r in rounds]
                axes[1, column].plot(
                    [r["wall_time_s"] for r in rounds], search, "x:", color=line[0].get_color()
                )
    for column, label in enumerate(("episode reward (20 s)", "fall rate", "forward speed (m/s)")):
        axes[0, column].set(xlabel="env steps (M), SAC", ylabel=label)
        axes[1, column].set(xlabel="wall time (s)", ylabel=label)
    axes[0, 1].axhline(MAX_FALL_RATE, color="grey", lw=0.5)
    axes[0, 2].axhline(MIN_SPEED, color="grey", lw=0.5)
    axes[0, 0].legend(fontsize=8)
    axes[1, 1].set_title("x: gait search rounds (share of candidates that fell)", fontsize=9)
    axes[1, 2].set_title("x: gait search rounds (best candidate's 5-s speed)", fontsize=9)
    fig.suptitle(
        "Flat, 1024 eval episodes. From scratch (--preset=scratch: gait search, then SAC): H100,"
        " Warp physics, each run alone, wall time from process start (s0: cold caches);\n"
        "trot start (dotted): H200, JAX physics, clock from its training loop's start; ablations"
        " (dashed): clock from the search's start, DRL-only runs shared the GPU"
    )
    plots.save(fig, HERE / "fig7_from_scratch.png", dpi=110)
    (HERE / "fig7_summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    print(json.dumps(summary, indent=1))
    print(evaluation_table())


def evaluation_table() -> str:
    lines = ["| policy | " + " | ".join(_COLUMNS) + " |", "|---" * (len(_COLUMNS) + 1) + "|"]
    for name, path in EVALUATIONS.items():
        if path.is_file():
            opener = gzip.open if path.suffix == ".gz" else open
            with opener(path, "rt") as file:
                result = json.load(file)
            cells = " | ".join(f"{result[key]:.3f}" for key in _COLUMNS)
            lines.append(f"| {name} ({result['num_episodes']} episodes) | {cells} |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
