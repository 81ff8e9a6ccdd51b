"""Each robustness condition's robots in a training evaluation, against the same condition alone.

A commanded run's training evaluations with `randomization.eval_conditions=robustness` give each
robot one of measure.py's four conditions and report each condition's falls, attitude and
tracking (quadcos.training.periodic_eval): the kept policy must beat its gait in each. This runs
that evaluation of a policy's gait (its run's env, the zero action) and, for each condition, the
same robots all in it (as measure.py's episodes): grouped right, a condition's robots roll and
track as the robots that all take it do, and the four groups differ as the four conditions do.

    python experiments/commands/condition_groups.py --policy=experiments/policies/unitree_go1_command \
        --robots=64 --seconds=5 --out=experiments/commands/condition_groups.json
"""

import argparse
import json
from pathlib import Path

KEYS = ("fall_rate", "mean_max_abs_roll", "mean_max_abs_pitch_error", "speed_tracking_rms",
        "yaw_rate_tracking_rms")


def measure(policy: str, robots: int, seconds: float) -> dict:
    """{"mixed": {condition: metrics}, "alone": {condition: metrics}} of the policy's gait."""
    import jax
    import jax.numpy as jnp
    from brax.envs.wrappers import training as training_wrappers

    import quadcos
    from quadcos.env import randomization
    from quadcos.training import periodic_eval, run_config

    saved = json.loads((Path(policy) / "policy.json").read_text())["config"]
    overrides = run_config.env_overrides(run_config.migrate(saved))
    overrides |= {"impl": "jax", "randomization.enabled": True, "terrain": "flat"}
    keys = jax.random.split(jax.random.PRNGKey(0), robots)

    def groups(conditions: str) -> dict[str, dict[str, float]]:
        env = quadcos.make_env(**overrides, **{"randomization.conditions": conditions})
        steps = round(seconds / env.dt)
        gait = lambda obs: jnp.zeros(obs.shape[:-1] + (env.action_size,))  # noqa: E731
        evaluate = jax.jit(
            lambda k: periodic_eval.evaluate(
                training_wrappers.VmapWrapper(env), gait, k, episode_length=steps
            )
        )
        metrics = evaluate(keys)
        names = randomization.condition_names(conditions)
        return {
            name: {
                key: round(float(metrics[f"eval/{randomization.condition_key(name)}/{key}"]), 4)
                for key in KEYS
            }
            for name in names
        }

    return {
        "mixed": groups("robustness"),
        "alone": {name: groups(name)[name] for name in randomization.ROBUSTNESS},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", required=True)
    parser.add_argument("--robots", type=int, default=64)
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    result = measure(args.policy, args.robots, args.seconds)
    record = {"policy": args.policy, "robots": args.robots, "seconds": args.seconds,
              "physics": "MJX-JAX", **result}
    Path(args.out).write_text(json.dumps(record, indent=1) + "\n")
    for name, mixed in result["mixed"].items():
        alone = result["alone"][name]
        print(f"{name}: roll {mixed['mean_max_abs_roll']:.3f} (alone {alone['mean_max_abs_roll']:.3f}),"
              f" yaw rate {mixed['yaw_rate_tracking_rms']:.3f}"
              f" (alone {alone['yaw_rate_tracking_rms']:.3f})")


if __name__ == "__main__":
    main()
