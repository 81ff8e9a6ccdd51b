"""How often does a random rhythm (one uniform random action, held) walk? The chance that
exploration stumbles on a gait. Runs N robots, each with its own constant random action from a
standing start, for S seconds on flat, and reports the fractions that fall, stand, walk backwards
and walk forwards (mean speed over the last half >= 0.1 m/s), and what Eq. 13 paid them.

    python experiments/from_scratch/random_gaits.py --robots 256 --seconds 5 --out experiments/from_scratch/random_gaits.json
"""

import argparse
import json

import jax
import jax.numpy as jnp
import numpy as np

import quadcos


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--robots", type=int, default=256)
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--symmetric_knees",
        action="store_true",
        help="phi3 = phi1 - pi (each diagonal pair's knees in the same phase relative to its hip)",
    )
    parser.add_argument("--out")
    args = parser.parse_args()
    env = quadcos.make_env("flat", action_centre="midpoint", survival_min_speed=0.1)
    steps = round(args.seconds / env.dt)
    key_reset, key_action = jax.random.split(jax.random.PRNGKey(args.seed))
    actions = jax.random.uniform(key_action, (args.robots, env.action_size), minval=-1, maxval=1)
    if args.symmetric_knees:  # with the midpoint centre, phi = 2 pi a: a3 = a1 - 1/2 (mod 1)
        actions = actions.at[:, 4].set(jnp.where(actions[:, 3] >= -0.5, actions[:, 3] - 0.5, actions[:, 3] + 0.5))

    @jax.jit
    def rollout(keys, actions):
        state = jax.vmap(env.reset)(keys)

        def step(carry, _):
            state, alive = carry
            state = jax.vmap(env.step)(state, actions)
            out = (state.pipeline_state.qpos[:, 0], state.reward * alive, alive)
            return (state, alive & (state.done == 0)), out

        _, (x, reward, alive) = jax.lax.scan(step, (state, jnp.ones(args.robots, bool)), None, steps)
        return x, reward, alive

    x, reward, alive = map(np.asarray, rollout(jax.random.split(key_reset, args.robots), actions))
    fell = ~alive[-1]
    half = steps // 2
    speed = (x[-1] - x[half]) / ((steps - half) * env.dt)
    walking = ~fell & (speed >= 0.1)
    result = {
        "robots": args.robots,
        "seconds": args.seconds,
        "fell": float(fell.mean()),
        "forward_ge_0.1": float(walking.mean()),
        "backward_le_-0.1": float((~fell & (speed <= -0.1)).mean()),
        "forward_ge_0.3": float((~fell & (speed >= 0.3)).mean()),
        "mean_return_per_step": {
            "walking_forward": float(reward[:, walking].sum(0).mean() / steps) if walking.any() else None,
            "fell": float(reward[:, fell].sum(0).mean() / steps) if fell.any() else None,
            "other": float(reward[:, ~walking & ~fell].sum(0).mean() / steps),
        },
        "best_forward_speeds": sorted(map(float, speed[~fell]))[-5:],
        "command": "python experiments/from_scratch/random_gaits.py "
        + f"--robots {args.robots} --seconds {args.seconds} --seed {args.seed}"
        + (" --symmetric_knees" if args.symmetric_knees else ""),
    }
    print(json.dumps(result, indent=1))
    if args.out:
        with open(args.out, "w") as file:
            json.dump(result, file, indent=1)


if __name__ == "__main__":
    main()
