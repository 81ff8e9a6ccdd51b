"""The tables of experiments/any_slope/README.md from the committed evaluation JSONs.

    python experiments/any_slope/tables.py
"""

import gzip
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
SLOPE5 = HERE.parent / "slope5" / "slope5_spawn_s0"
POLICIES = {
    "any_slope (generalist)": (HERE, "any_slope"),
    "slope5 retrained, spawns along the course": (SLOPE5, "slope5_spawn"),
    "committed experiments/policies/slope5": (HERE, "committed_slope5"),
}


def _load(path: Path) -> dict | None:
    for candidate in (path, path.with_name(path.name + ".gz")):
        if candidate.exists():
            opener = gzip.open if candidate.suffix == ".gz" else open
            with opener(candidate, "rt") as file:
                return json.load(file)
    return None


def main() -> None:
    print("| policy | test set: mean course success | worst course | falls | named courses (1024 episodes each): slope5, s4, flat success | flat: max pitch err / yaw / roll (rad), lateral drift (m) |")
    print("|---|---:|---|---:|---|---|")
    for label, (directory, prefix) in POLICIES.items():
        test = _load(HERE / f"eval_{prefix}_testset.json")
        named = {c: _load(directory / f"eval_{prefix}_{c}.json") for c in ("slope5", "s4", "flat")}
        rates = ", ".join("—" if e is None else f"{e['success_rate']:.3f}" for e in named.values())
        flat = named["flat"]
        attitude = "—" if flat is None else (
            f"{flat['mean_max_abs_pitch_error']:.3f} / {flat['mean_max_abs_yaw']:.3f} /"
            f" {flat['mean_max_abs_roll']:.3f}, {flat['mean_max_lateral_deviation']:.3f}"
        )
        print(
            f"| {label} | {test['mean_course_success_rate']:.3f} | {test['worst_course']}"
            f" {test['worst_course_success_rate']:.3f} | {test['fall_rate']:.3f} | {rates} | {attitude} |"
        )
    print()
    print("Test set testset:2026, per course (64 episodes each): success (falls) per policy")
    tests = {label: _load(HERE / f"eval_{prefix}_testset.json") for label, (_, prefix) in POLICIES.items()}
    print("| course | " + " | ".join(tests) + " |")
    print("|---|" + "---:|" * len(tests))
    first = next(iter(tests.values()))
    for name in first["courses"]:
        cells = [
            f"{t['courses'][name]['success_rate']:.2f} ({t['courses'][name]['fall_rate']:.2f})"
            for t in tests.values()
        ]
        print(f"| {name} | " + " | ".join(cells) + " |")
    slope = {label: t["courses"] for label, t in tests.items()}
    print()
    print("slope estimate RMS (rad), generalist, per named course:",
          {n: round(slope["any_slope (generalist)"][n]["slope_error_rms"], 3) for n in ("flat", "slope5", "s4")})


if __name__ == "__main__":
    main()
