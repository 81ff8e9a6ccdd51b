"""The tables of experiments/any_slope/README.md from the evaluation JSONs.

    python experiments/any_slope/tables.py > experiments/any_slope/tables.md

The committed JSONs are summaries (no per-episode values): the table of where failed episodes end
needs the full JSONs that `bash experiments/run_gpu.sh any_slope` writes.
"""

import collections
import gzip
import json
from pathlib import Path

import numpy as np

from quadcos import terrain

HERE = Path(__file__).resolve().parent
SCRATCH = HERE.parent / "from_scratch" / "gpu"
BEST = HERE / "best_obs"
POSTURE = HERE / "posture"
TESTSET = "testset:2026"
# label -> (directory of the named-course JSONs, their file prefix, the test-set JSON); named
# courses: eval_PREFIX_{slope5,s4,flat}.json
POLICIES = {
    "hip offsets + r_y capped at 0.8 m/s, s0, best policy (policies/any_slope)": (
        POSTURE / "posture_cap_s0", "posture_cap_s0", POSTURE / "posture_cap_s0" / "eval_posture_cap_s0_testset.json"
    ),
    "the same, its last policy": (
        None, None, POSTURE / "posture_cap_s0" / "eval_posture_cap_s0_last_testset.json"
    ),
    "hip offsets, no cap, s0, best policy": (
        POSTURE / "posture_s0", "posture_s0", POSTURE / "posture_s0" / "eval_posture_s0_testset.json"
    ),
    "the same, its last policy ": (
        None, None, POSTURE / "posture_s0" / "eval_posture_s0_last_testset.json"
    ),
    **{
        f"neither option, s{seed}, best policy": (
            BEST, f"any_obs_best{suffix}", BEST / f"eval_any_obs_best{suffix}_testset.json"
        )
        for seed, suffix in ((0, ""), (1, "_s1"))
    },
    **{
        f"slope5 specialist from scratch s{seed}" + (" (policies/slope5)" if seed == 0 else ""): (
            SCRATCH, f"scratch_slope5_s{seed}", SCRATCH / f"eval_scratch_slope5_s{seed}_testset.json"
        )
        for seed in range(3)
    },
}


def _load(path: Path) -> dict | None:
    for candidate in (path, path.with_name(path.name + ".gz")):
        if candidate.exists():
            opener = gzip.open if candidate.suffix == ".gz" else open
            with opener(candidate, "rt") as file:
                return json.load(file)
    return None


def _section_kind(angle: float) -> str:
    if abs(angle) < 1e-3:
        return "level"
    return f"{'up' if angle > 0 else 'down'} {'≥' if abs(angle) >= 6 else '<'} 6°"


def _where_failures_end(test: dict, ground: terrain.Terrain) -> collections.Counter:
    """Failed test-course episodes by how they ended (fell / stalled: timed out before the end)
    and the ground where they ended (the slope under the torso's last x on its lane)."""
    if "episodes" not in test:  # the committed JSONs are summaries: rerun the evaluations
        return collections.Counter()
    failed = [e for e in test["episodes"] if not e["success"] and ground.lanes[e["lane"]].name.startswith("test")]
    x = np.array([e["final_x"] for e in failed])
    y = ground.lane_y[[e["lane"] for e in failed]]
    angles = np.rad2deg(np.asarray(ground.slope_at(x, y)))
    return collections.Counter(
        ("fell" if e["fell"] else "stalled", _section_kind(float(angle))) for e, angle in zip(failed, angles)
    )


def main() -> None:
    paths = [path for *_, path in POLICIES.values()]
    if missing := [str(path.relative_to(HERE.parent)) for path in paths if _load(path) is None]:
        raise SystemExit(f"tables.py: {len(missing)} test-set evaluations missing: "
                         f"{', '.join(missing)} (not in git: experiments/run_gpu.sh writes them)")
    print("| policy | test set: mean course success | worst course | falls | named courses (1024 episodes each): slope5, s4, flat success | flat: max pitch err / yaw / roll (rad), lateral drift (m) |")
    print("|---|---:|---|---:|---|---|")
    tests = {}
    for label, (named_dir, prefix, test_path) in POLICIES.items():
        test = tests[label] = _load(test_path)
        named = {
            c: None if named_dir is None else _load(named_dir / f"eval_{prefix}_{c}.json")
            for c in ("slope5", "s4", "flat")
        }
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
    print(f"Where the failed episodes of the 64 test courses end ({TESTSET}, 4096 episodes a policy;"
          " 40-s episodes unless said):"
          " fell / stalled (timed out before the course end), by the ground under the torso at the end")
    ground = terrain.parse(TESTSET)
    counts = {label: _where_failures_end(test, ground) for label, test in tests.items()}
    kinds = sorted({key for c in counts.values() for key in c})
    print("| policy | " + " | ".join(f"{how}: {where}" for how, where in kinds) + " |")
    print("|---|" + "---:|" * len(kinds))
    for label, count in counts.items():
        print(f"| {label} | " + " | ".join(str(count.get(k, 0)) for k in kinds) + " |")
    print()
    print(f"Test set {TESTSET}, per course (64 episodes each, 40 s unless said): success (falls) per policy")
    print("| course | " + " | ".join(tests) + " |")
    print("|---|" + "---:|" * len(tests))
    first = next(iter(tests.values()))
    for name in first["courses"]:
        cells = [
            f"{t['courses'][name]['success_rate']:.2f} ({t['courses'][name]['fall_rate']:.2f})"
            for t in tests.values()
        ]
        print(f"| {name} | " + " | ".join(cells) + " |")
    print()
    print("Slope estimate RMS (rad) per named course:")
    for label, test in tests.items():
        print(f"- {label}:", {n: round(test["courses"][n]["slope_error_rms"], 3) for n in ("flat", "slope5", "s4")},
              f"whole test set {test['slope_error_rms']:.3f}")


if __name__ == "__main__":
    main()
