"""The robots experiments' table and figure, from what `bash experiments/run_gpu.sh robots` and
`robots_alone` wrote (summaries copied into experiments/robots).

    python experiments/robots/table.py experiments/robots --traces DIR   # prints the Markdown
                                            # table, draws walking.png from DIR's flat traces

Per run folder `runs/NAME` (config.json, metrics.jsonl) and evaluation files `eval_NAME_{flat,
slope5,s4}.json`, `sim2sim_NAME_{flat,slope5}.json`: time to walk for runs trained on flat (process
start to the first training evaluation in which >= 99 % of its 1024 deterministic 20-s episodes
survive at >= 0.5 m/s: the run's `wall_time_s` counts from the process's start), and the
evaluations of its `policy_best`. Traces (`trace_NAME_flat.json`, `quadcos.evaluate --trace`)
are large and stay out of git.
"""

import argparse
import json
import math
import pathlib
import sys

WALK_SURVIVAL = 0.99
WALK_SPEED = 0.5  # m/s


def _read(path: pathlib.Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def time_to_walk(run: pathlib.Path) -> float | None:
    """s from process start to the first evaluation that walks (None: none did)."""
    for line in (run / "metrics.jsonl").read_text().splitlines():
        row = json.loads(line)
        if "eval/fall_rate" not in row:
            continue
        if 1 - row["eval/fall_rate"] >= WALK_SURVIVAL and row["eval/forward_speed"] >= WALK_SPEED:
            return row["wall_time_s"]
    return None


def best_training_eval(run: pathlib.Path) -> dict | None:
    """The training evaluation whose policy `policy_best` keeps (the highest episode reward), as
    the aggregates of an evaluation file (success = survival on flat)."""
    rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
    rows = [row for row in rows if isinstance(row.get("eval/episode_reward"), float)]
    if not rows:
        return None
    best = max(rows, key=lambda row: row["eval/episode_reward"])
    return {
        "success_rate": 1 - best["eval/fall_rate"],
        "mean_forward_speed": best["eval/forward_speed"],
        "training_eval_step": best["step"],
    }


def _percent(result: dict | None, key: str = "success_rate") -> str:
    return "—" if result is None else f"{100 * result[key]:.1f} %"


def rows(folder: pathlib.Path) -> list[dict]:
    found = []
    for run in sorted((folder / "runs").iterdir()):
        name = run.name
        config = json.loads((run / "config.json").read_text())
        flat, slope5, s4 = (
            _read(folder / f"eval_{name}_{t}.json") for t in ("flat", "slope5", "s4")
        )
        mujoco = _read(folder / f"sim2sim_{name}_flat.json")
        mujoco_slope5 = _read(folder / f"sim2sim_{name}_slope5.json")
        on_flat = config["run_info"]["env"]["terrain"] == "flat"
        found.append(
            {
                "run": name,
                "robot": config["run_info"]["robot"]["name"],
                "walk_s": time_to_walk(run) if on_flat else None,
                "flat": flat,
                "flat_training": (best_training_eval(run) if flat is None and on_flat else None),
                "slope5": slope5,
                "s4": s4,
                "mujoco": mujoco,
                "mujoco_slope5": mujoco_slope5,
            }
        )
    return found


def table(found: list[dict], masses: dict[str, float]) -> str:
    lines = [
        "| run | mass kg | time to walk | flat success | speed m/s | pitch err / roll / yaw rad"
        " | slope5 | S-4 | slope RMS on slope5 | C MuJoCo flat / slope5 |",
        "|---|---:|---:|---:|---:|---|---:|---:|---:|---:|",
    ]
    for row in found:
        flat = row["flat"]
        walk = "—" if row["walk_s"] is None else f"{row['walk_s']:.0f} s"
        attitude = "—"
        speed = "—"
        if flat is not None:
            speed = f"{flat['mean_forward_speed']:.2f}"
            attitude = (
                f"{flat['mean_max_abs_pitch_error']:.3f} / {flat['mean_max_abs_roll']:.3f} /"
                f" {flat['mean_max_abs_yaw']:.3f}"
            )
        if flat is None and row["flat_training"] is not None:
            training = row["flat_training"]
            speed = f"{training['mean_forward_speed']:.2f}*"
            flat = training
        rms = "—"
        if row["slope5"] is not None and row["slope5"]["slope_error_rms"] is not None:
            rms = f"{math.degrees(row['slope5']['slope_error_rms']):.2f}°"
        lines.append(
            f"| {row['run']} | {masses.get(row['robot'], math.nan):.1f} | {walk} |"
            f" {_percent(flat)} | {speed} | {attitude} | {_percent(row['slope5'])} |"
            f" {_percent(row['s4'])} | {rms} |"
            f" {_percent(row['mujoco'])} / {_percent(row['mujoco_slope5'])} |"
        )
    lines.append(
        "\n\\* no separate evaluation: the training evaluation (1024 deterministic 20-s episodes)"
        " whose policy `policy_best` keeps."
    )
    return "\n".join(lines)


def figure(found: list[dict], folder: pathlib.Path, out: pathlib.Path) -> None:
    """Forward position against time of each robot's traced flat episode."""
    from matplotlib.figure import Figure

    from quadcos.viz import plots

    traces = {row["run"]: _read(folder / f"trace_{row['run']}_flat.json") for row in found}
    traces = {run: trace for run, trace in traces.items() if trace is not None}
    if not traces:  # keep the figure there is rather than draw an empty one
        print(f"table.py: no trace_NAME_flat.json in {folder}; {out} kept", file=sys.stderr)
        return
    fig = Figure(figsize=(7, 4))
    ax = fig.subplots()
    for run, trace in traces.items():
        ax.plot(trace["series"]["time"], trace["series"]["cog_x"], label=run)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("forward position of the torso (m)")
    ax.set_title("policy_best on flat ground, one deterministic episode each")
    ax.legend()
    fig.tight_layout()
    plots.save(fig, out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=pathlib.Path)
    parser.add_argument(
        "--traces", type=pathlib.Path, help="folder of trace_NAME_flat.json (default: folder)"
    )
    args = parser.parse_args()
    if not (args.folder / "runs").is_dir():  # run folders stay out of git
        parser.error(f"{args.folder / 'runs'} missing: copy the run folders (config.json,"
                     " metrics.jsonl) that experiments/run_gpu.sh robots_alone wrote")
    from quadcos import robot

    found = rows(args.folder)
    masses = {}
    for row in found:
        spec = json.loads((args.folder / "runs" / row["run"] / "config.json").read_text())
        masses[row["robot"]] = robot.load(spec["run_info"]["env"]["robot"]).description.mass
    print(table(found, masses))
    figure(found, args.traces or args.folder, args.folder / "walking.png")


if __name__ == "__main__":
    main()
