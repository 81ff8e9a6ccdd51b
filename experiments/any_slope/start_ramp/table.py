"""The start-ramp table: the flat step-off of two `--preset=any_slope` seeds' kept policies,
evaluated with the rhythm let in over the first `env.start_ramp_s` seconds (0: none, as trained).

    python experiments/any_slope/start_ramp/table.py   # reads s{1,2}_r*.json beside it

Each JSON is `python -m quadcos.evaluate --policy=experiments/any_slope/seeds_no_ramp/runs/
any_slope_promote2_sN/policy_best --terrain=flat --num_envs=8 --seconds=3 --env.start_ramp_s=R`
on a CPU (../README.md has the loop).
"""

import json
import pathlib

HERE = pathlib.Path(__file__).parent


def main() -> None:
    print(
        "| seed | start_ramp_s | success | max \\|pitch − θ\\| | max \\|roll\\| | max \\|yaw\\| "
        "| max attitude | speed over 3 s (m/s) |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for path in sorted(
        HERE.glob("s*_r*.json"), key=lambda p: (p.stem.split("_r")[0], float(p.stem.split("_r")[1]))
    ):
        seed, ramp = path.stem.split("_r")
        result = json.loads(path.read_text())
        angles = [result[f"mean_max_abs_{key}"] for key in ("pitch_error", "roll", "yaw")]
        cells = [
            seed[1:],
            ramp,
            f"{result['success_rate']:.3f}",
            *(f"{a:.3f}" for a in angles),
            f"**{max(angles):.3f}**",
            f"{result['mean_forward_speed']:.2f}",
        ]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
