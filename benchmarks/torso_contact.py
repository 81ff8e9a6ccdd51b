"""Env-step cost of a torso that collides with the ground, against feet-only contacts.

    python benchmarks/torso_contact.py --num_envs=64 --out=benchmarks/torso_contact_cpu.json

The robot's MJCF lets only the feet touch the ground; this script gives the torso box back its
contact (contype 1, as it had before) and times `jax.vmap(env.step)` both ways on flat ground and
on the slope5 heightfield, with quadcos.benchmarking's timing (warm-up call, then timed calls).
"""

import argparse
import json
import pathlib

import jax
from mujoco import mjx

import quadcos
from quadcos.robot import constants
from quadcos.benchmarking import physics


def env_with_torso_contact(terrain: str, torso_contact: bool) -> quadcos.QuadrupedEnv:
    env = quadcos.make_env(terrain)
    if torso_contact:
        env.mj_model.geom_contype[env.mj_model.geom(constants.TORSO_GEOM).id] = 1
        env.model = mjx.put_model(env.mj_model, impl=env.config.impl)
    return env


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--num_envs", type=int, default=64)
    parser.add_argument("--calls", type=int, default=20)
    parser.add_argument("--terrains", default="flat,slope5")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    results = {"device": jax.devices()[0].device_kind, "num_envs": args.num_envs, "rows": []}
    for terrain in args.terrains.split(","):
        for torso_contact in (True, False):
            env = env_with_torso_contact(terrain, torso_contact)
            states = physics.make_batch_reset(env)(args.num_envs)
            timing = physics.measure_env(env, states, args.calls)
            row = {
                "terrain": terrain,
                "torso_contact": torso_contact,
                "env_steps_per_s": args.num_envs * timing.calls / timing.seconds,
                "first_call_s": timing.first_call_s,
            }
            print(json.dumps(row), flush=True)
            results["rows"].append(row)
    pathlib.Path(args.out).write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
