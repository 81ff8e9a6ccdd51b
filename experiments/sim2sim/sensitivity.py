"""How much the slope5 policy's S-4 result in C MuJoCo moves with the physics settings that MJX
and C MuJoCo treat differently: solver convergence, step size, and the heightfield's triangles (C
MuJoCo makes one contact per triangle prism a foot touches, MJX at most 4 per foot, within 1 mm
of the deepest). Each variant runs episodes 0..N-1 of `mujoco_s4.json` (same reset seeds: paired).

    PYTHONPATH=. python experiments/sim2sim/sensitivity.py --episodes=128 \
        --out=experiments/sim2sim/sensitivity_s4.json
"""

import argparse

from quadcos import evaluation
from quadcos.deploy import engines

S4 = "sections:5@1.4,0@1.4,9@1.2,0@1.4"  # = the registered "s4"
VARIANTS = {  # name: (env overrides, terrain)
    "solver 50/50 iterations": ({"solver_iterations": 50, "ls_iterations": 50}, S4),
    "physics_dt 2.5 ms": ({"physics_dt": 0.0025}, S4),
    "heightfield cells 2.5 cm": ({}, S4 + ";resolution=0.025"),
}
KEYS = ("success_rate", "fall_rate", "mean_forward_speed", "mean_distance", "mean_episode_reward")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--episodes", type=int, default=128)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    rows = {}
    for name, (overrides, terrain) in VARIANTS.items():
        result = engines.evaluate(
            "experiments/policies/slope5_trot", terrain, engine="mujoco", episodes=args.episodes,
            seconds=30.0, env_overrides=overrides,
        ).summary
        rows[name] = {"env_overrides": overrides, "terrain": terrain}
        rows[name] |= {key: result[key] for key in KEYS}
        print(name, {key: round(result[key], 3) for key in KEYS}, flush=True)
    evaluation.write_json(args.out, {"episodes": args.episodes, "seconds": 30.0, "variants": rows})


if __name__ == "__main__":
    main()
