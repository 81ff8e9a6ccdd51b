"""Why the randomised policies walk faster on slippery ground: the rhythm a policy chooses (its
parameters, averaged over an episode) and the speed it gets, on the nominal robot at each friction.

    python experiments/robustness/friction_gait.py --policy=experiments/policies/flat_robust_scratch \
        --policy=experiments/policies/flat --friction 0.4 1.5 --num_envs=8 \
        --out=experiments/robustness/friction_gait.json

Each row: one deterministic evaluation on flat (measure.py's nominal robot with the friction set),
mean forward speed over its episodes, and the mean over the traced episode's steps of each rhythm
parameter the policy commands (A_k, A_h rad, T s, φ1, φ3 rad; quadcos.equations.oscillator), how
far the joints lag the controller's targets and the torso's height. If
the parameters stay while the speed changes, the ground makes the difference; if they change, the
policy reads the friction from its observations and answers with another gait.
"""

import argparse
import json
from pathlib import Path

import numpy as np

from quadcos import evaluation
from quadcos._util import caches
from quadcos.env.randomization import NOMINAL


def gait_at(policy: str, friction: float, num_envs: int, seconds: float) -> dict:
    result = evaluation.evaluate(
        policy,
        "flat",
        num_envs=num_envs,
        seconds=seconds,
        env_overrides={**NOMINAL, "randomization.friction": (friction, friction)},
    )
    series = result.trace["series"]
    parameters = {
        key.split("/", 1)[1]: float(np.mean(values))
        for key, values in series.items()
        if key.startswith("parameter/")
    }
    joints = [key.split("/", 1)[1] for key in series if key.startswith("controller/")]
    tracking = np.mean(
        [np.abs(np.subtract(series[f"joint/{j}"], series[f"controller/{j}"])) for j in joints]
    )
    return {
        "policy": policy,
        "friction": friction,
        "episodes": num_envs,
        "success_rate": result.summary["success_rate"],
        "mean_forward_speed": result.summary["mean_forward_speed"],
        "rhythm_means": parameters,
        "mean_abs_joint_tracking_error_rad": float(tracking),
        "mean_torso_height_m": float(np.mean(series["cog_z"])),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--policy", action="append", required=True)
    parser.add_argument("--friction", type=float, nargs="+", default=[0.4, 1.5])
    parser.add_argument("--num_envs", type=int, default=8)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    caches.enable()
    rows = []
    for policy in args.policy:
        for friction in args.friction:
            row = gait_at(policy, friction, args.num_envs, args.seconds)
            print(json.dumps(row), flush=True)
            rows.append(row)
    Path(args.out).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
