"""The README's tables from measure.py's JSON: python experiments/robots/physics/table.py RESULTS."""

import json
import pathlib
import sys


def _pct(value):
    return "NaN" if value is None else f"{100 * value:.1f}"


def _speed(value):
    return "–" if value is None else f"{value:.2f}"


def main(path: str) -> None:
    results = json.loads(pathlib.Path(path).read_text())
    print(
        "| robot | setting | hold err vs standing h., flat / slope5 (%) | hold err vs settled ref., flat / slope5 (%) |"
        " NaN (hold+trot, flat / slope5) | falls (flat / slope5) | trot speed flat / slope5 (m/s) |"
        " run s (flat) | pass |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for robot, settings in results.items():
        for label, record in settings.items():
            flat, slope = record["terrains"]["flat"], record["terrains"]["slope5"]
            cells = [
                robot.removeprefix("menagerie:"),
                label,
                f"{_pct(flat['hold']['max_height_error_5s'])} / {_pct(slope['hold']['max_height_error_5s'])}",
                f"{_pct(flat['hold']['max_reference_error_5s'])} / {_pct(slope['hold']['max_reference_error_5s'])}",
                " / ".join(f"{t['hold']['nan']}+{t['trot']['nan']}" for t in (flat, slope)),
                " / ".join(f"{t['hold']['falls']}+{t['trot']['falls']}" for t in (flat, slope)),
                f"{_speed(flat['trot']['speed_5s'])} / {_speed(slope['trot']['speed_5s'])}",
                f"{flat['run_s']:.1f}",
                "yes" if record["passed"] else "no",
            ]
            print("| " + " | ".join(cells) + " |")
    print()
    print("| robot | setting | upright gaits (5 s) | fastest upright gait: A_h, A_k, T → m/s |")
    print("|---|---|---|---|")
    for robot, settings in results.items():
        for label, record in settings.items():
            gaits = record.get("gaits")
            if not gaits:
                continue
            upright = [g for g in gaits if not g["fell_5s"]]
            best = max(upright, key=lambda g: g["speed_5s"], default=None)
            text = (
                "–"
                if best is None
                else f"{best['amplitude_hip']}, {best['amplitude_knee']}, {best['period']} → {best['speed_5s']:.2f}"
            )
            print(
                f"| {robot.removeprefix('menagerie:')} | {label} | {len(upright)}/{len(gaits)} | {text} |"
            )


if __name__ == "__main__":
    main(sys.argv[1])
