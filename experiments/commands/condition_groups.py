"""Each robustness condition's robots in a training evaluation, against the same condition alone.

A commanded run's training evaluations with `randomization.eval_conditions=robustness` give each
robot one of measure.py's four conditions and report each condition's falls, attitude and
tracking (quadcos.training.periodic_eval): the kept policy must beat its gait in each. This runs
that evaluation of a policy's gait (its run's env, the zero action) and, for each condition, the
same robots all in it (as measure.py's episodes): grouped right, a condition's robots roll and
track as the robots that all take it do, and the four groups differ as the four conditions do.

    python experiments/commands/condition_groups.py \
        --policy=experiments/policies/unitree_go1_command --robots=64 --seconds=5 \
        --out=experiments/commands/condition_groups.json

With `--rank` it runs the trainer's evaluation of the policy itself and of its gait instead, and
each condition's speed and yaw-rate ratio of the two: what the gait rank (`best_policy_by=gait`)
reads of a kept policy, to set beside measure.py's 1024 episodes a condition.
"""

import argparse
import json
from pathlib import Path

KEYS = (
    "fall_rate",
    "mean_max_abs_roll",
    "mean_max_abs_pitch_error",
    "speed_tracking_rms",
    "yaw_rate_tracking_rms",
)


def measure(policy: str, robots: int, seconds: float, rank: bool = False) -> dict:
    """{"mixed": {condition: metrics}, "alone": {condition: metrics}} of the policy's gait; with
    `rank`, {"mixed": ..., "trained": {condition: metrics}, "ratio": {condition: {speed, yaw
    rate}}} of the gait and the policy in the trainer's evaluation."""
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

    def groups(conditions: str, trained: bool = False) -> dict[str, dict[str, float]]:
        env = quadcos.make_env(**{**overrides, "randomization.conditions": conditions})
        steps = round(seconds / env.dt)
        act = (
            quadcos.load_policy(policy).act
            if trained
            else (lambda obs: jnp.zeros(obs.shape[:-1] + (env.action_size,)))
        )
        evaluate = jax.jit(
            lambda k: periodic_eval.evaluate(
                training_wrappers.VmapWrapper(env), act, k, episode_length=steps
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

    gait = groups("robustness")
    if not rank:
        alone = {name: groups(name)[name] for name in randomization.ROBUSTNESS}
        return {"mixed": gait, "alone": alone}
    trained = groups("robustness", trained=True)
    ratio = {
        name: {
            key: round(trained[name][f"{key}_tracking_rms"] / gait[name][f"{key}_tracking_rms"], 3)
            for key in ("speed", "yaw_rate")
        }
        for name in gait
    }
    return {"mixed": gait, "trained": trained, "ratio": ratio}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", required=True)
    parser.add_argument("--robots", type=int, default=64)
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--out", required=True)
    parser.add_argument("--rank", action="store_true", help="the policy against its gait")
    args = parser.parse_args()
    result = measure(args.policy, args.robots, args.seconds, args.rank)
    record = {
        "policy": args.policy,
        "robots": args.robots,
        "seconds": args.seconds,
        "physics": "MJX-JAX",
        **result,
    }
    Path(args.out).write_text(json.dumps(record, indent=1) + "\n")
    if args.rank:
        for name, ratio in result["ratio"].items():
            speed, yaw_rate = ratio["speed"], ratio["yaw_rate"]
            print(f"{name}: speed {speed:.3f}, yaw rate {yaw_rate:.3f} of the gait's")
        return
    for name, mixed in result["mixed"].items():
        alone = result["alone"][name]
        roll, alone_roll = mixed["mean_max_abs_roll"], alone["mean_max_abs_roll"]
        yaw, alone_yaw = mixed["yaw_rate_tracking_rms"], alone["yaw_rate_tracking_rms"]
        print(f"{name}: roll {roll:.3f} (alone {alone_roll:.3f}),", end=" ")
        print(f"yaw rate {yaw:.3f} (alone {alone_yaw:.3f})")


if __name__ == "__main__":
    main()
