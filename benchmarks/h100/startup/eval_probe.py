"""How long the gpu preset's training-time evaluation (400 control steps) takes once compiled,
against the number of evaluation robots: what bounds the step-0 evaluation in the start-up.

    python benchmarks/h100/startup/eval_probe.py [--impl warp] [--eval_envs 256,1024,4096]

Prints one JSON line per robot count: seconds of three calls (the first compiles or loads)."""

import argparse
import json
import time

import jax
import ml_collections

from quadcos import env as env_lib
from quadcos._util import caches
from quadcos.training import presets, sac


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--impl", default="warp")
    parser.add_argument("--eval_envs", default="256,1024,4096")
    args = parser.parse_args()
    caches.enable()
    for eval_envs in (int(n) for n in args.eval_envs.split(",")):
        config = presets.build_config(
            presets.PRESETS["gpu"],
            {"env.terrain": "flat", "env.impl": args.impl, "sac.num_eval_envs": eval_envs},
        )
        config.env.warp.max_envs = max(config.sac.num_envs, eval_envs)
        env = env_lib.QuadrupedEnv(config.env.terrain, ml_collections.ConfigDict(config.env))
        trainer = sac.SACTrainer(env, config.sac)
        state = trainer.init()
        seconds = []
        for _ in range(3):
            start = time.monotonic()
            jax.block_until_ready(trainer.evaluate(state.normalizer_params, state.policy_params))
            seconds.append(round(time.monotonic() - start, 3))
        steps = config.sac.eval_episode_length
        print(json.dumps({"eval_envs": eval_envs, "control_steps": steps, "seconds": seconds,
                          "ms_per_control_step": round(1000 * seconds[-1] / steps, 2)}), flush=True)


if __name__ == "__main__":
    main()
