"""The paper robot stepped with its 10 physics substeps in one MuJoCo Warp call against one call a
substep (`warp.one_call_substeps`; needs one_call_substeps.patch applied), on the GPU: 1024
randomised robots (pushes every 0.5 s on average) on flat and slope5, 100 env steps of random
actions from the same reset; prints the largest differences and the rates.
Run: python benchmarks/h100/one_call/parity.py"""

import json
import time

import jax
import jax.numpy as jnp
import numpy as np

from quadcos.env import make_env

ENVS, STEPS = 1024, 100
results = {}
for terrain in ("flat", "slope5"):
    states = {}
    for one_call in (False, True):
        env = make_env(
            terrain,
            impl="warp",
            **{
                "warp.one_call_substeps": one_call,
                "randomization.enabled": True,
                "randomization.push_interval_s": 0.5,
            },
        )
        assert env.one_call_substeps == one_call
        state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), ENVS))
        step = jax.jit(jax.vmap(env.step))
        keys = jax.random.split(jax.random.PRNGKey(1), STEPS)
        actions = [jax.random.uniform(k, (ENVS, env.action_size), minval=-1, maxval=1) for k in keys]
        state = jax.block_until_ready(step(state, actions[0]))  # compiles
        start = time.perf_counter()
        for action in actions[1:]:
            state = step(state, action)
        jax.block_until_ready(state)
        rate = (STEPS - 1) * ENVS / (time.perf_counter() - start)
        states[one_call] = state
        print(terrain, "one_call" if one_call else "per_substep", f"{rate / 1e3:.0f} k env-steps/s")
    a, b = states[False], states[True]
    row = {
        field: float(jnp.abs(getattr(a.pipeline_state, field) - getattr(b.pipeline_state, field)).max())
        for field in ("qpos", "qvel", "time", "ctrl")
    }
    row["obs"] = float(jnp.abs(a.obs - b.obs).max())
    row["reward"] = float(jnp.abs(a.reward - b.reward).max())
    row["done_differs"] = int((a.done != b.done).sum())
    row["x_spread_m"] = float(np.ptp(np.asarray(b.pipeline_state.qpos[:, 0])))
    results[terrain] = row
    print(terrain, json.dumps(row))
print(json.dumps(results, indent=1))
