"""Times MJX-Warp's one-time kernel build: the first reset and step of a Warp env (8 robots),
then the same again from Warp's kernel cache in this process. Prints one JSON line.

    python experiments/warp/kernel_build.py   (on a CUDA GPU with warp-lang; caches as set)
"""

import json
import time

import jax
import jax.numpy as jnp

from quadcos import make_env
from quadcos._util import caches


def main() -> None:
    dirs = caches.enable()
    timings = {}
    for terrain in ("flat", "slope5"):
        start = time.perf_counter()
        env = make_env(terrain, impl="warp")
        reset, step = jax.jit(jax.vmap(env.reset)), jax.jit(jax.vmap(env.step))
        state = reset(jax.random.split(jax.random.PRNGKey(0), 8))
        state = step(state, jnp.zeros((8, env.action_size)))
        jax.block_until_ready(state)
        timings[terrain] = time.perf_counter() - start
    print(json.dumps({"first_reset_and_step_s": timings, "caches": dirs, "impl": env.impl}))


if __name__ == "__main__":
    main()
