"""MJX-Warp's physics with its scratch arrays from an arena (`warp.arena`), and recorded by XLA
(`warp.graph_mode=jax`, which needs the arena and `warp.graph_conditional=false`), against MJX's
default (Warp's own graph a call) and against a second run of the default (how far two runs of
the same physics drift apart on a GPU): 1024 robots on flat and slope5 (or $TERRAINS),
100 env steps of random actions from the same reset; prints each variant's rate (one jitted env
step a call) and its largest differences from the default. Run: python
benchmarks/h200/arena/parity.py (a GPU, warp-lang installed)."""

import json
import os
import time

import jax
import jax.numpy as jnp

from quadcos.env import make_env

ENVS, STEPS = 1024, 100
VARIANTS = {
    "default": {},
    "default_again": {},  # how far two runs of the same physics drift apart on a GPU
    "arena": {"warp.arena": True},
    "jax_gc0": {"warp.graph_mode": "jax", "warp.graph_conditional": False},
}
results = {}
for terrain in os.environ.get("TERRAINS", "flat slope5").split():
    states = {}
    for name, overrides in VARIANTS.items():
        try:
            env = make_env(terrain, impl="warp", **overrides)
            state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), ENVS))
            step = jax.jit(jax.vmap(env.step))
            keys = jax.random.split(jax.random.PRNGKey(1), STEPS)
            actions = [
                jax.random.uniform(k, (ENVS, env.action_size), minval=-1, maxval=1) for k in keys
            ]
            state = jax.block_until_ready(step(state, actions[0]))  # compiles
            start = time.perf_counter()
            for action in actions[1:]:
                state = step(state, action)
            jax.block_until_ready(state)
        except Exception as error:  # noqa: BLE001 — a variant that fails is a result
            print(terrain, name, "FAILS:", str(error).splitlines()[0][:300], flush=True)
            results[f"{terrain}_{name}"] = {"error": str(error).splitlines()[0][:300]}
            continue
        rate = (STEPS - 1) * ENVS / (time.perf_counter() - start)
        states[name] = state
        row = {"k_env_steps_per_s": round(rate / 1e3, 1)}
        base = states["default"]
        for field in ("qpos", "qvel"):
            diff = getattr(state.pipeline_state, field) - getattr(base.pipeline_state, field)
            row[f"{field}_max_abs_diff"] = float(jnp.abs(diff).max())
        row["done_differs"] = int((state.done != base.done).sum())
        results[f"{terrain}_{name}"] = row
        print(terrain, name, json.dumps(row), flush=True)
print(json.dumps(results, indent=1))
