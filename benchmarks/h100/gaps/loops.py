"""Raw physics and env steps of 4096 robots (flat, MJX-Warp), a call an env step against 64 env
steps in one call (a `lax.scan`, as a training chunk runs them), each timed and then traced.

    python benchmarks/h100/gaps/loops.py OUT_DIR [TERRAIN]

Writes OUT_DIR/loops.json (env-steps/s of each) and a jax.profiler trace of each under
OUT_DIR/trace/NAME (summarise with `python -m quadcos.benchmarking.profile DIR --gaps`).
"""

import json
import pathlib
import sys

import jax
import jax.numpy as jnp
from mujoco import mjx

from quadcos.benchmarking import physics
from quadcos.benchmarking.settings import make_bench_env
from quadcos.benchmarking.timing import log, time_calls

ENVS, CALLS, SCAN = 4096, 40, 64


def main(out: pathlib.Path, terrain: str = "flat") -> None:
    env = make_bench_env(terrain, "gpu", "warp")
    reset = physics.make_batch_reset(env)
    step_all = jax.vmap(mjx.step, in_axes=(None, 0))
    env_step_all = jax.vmap(env.step)
    action = jnp.zeros((ENVS, env.action_size))

    def physics_step(data):
        for _ in range(env.substeps):
            data = step_all(env.model, data)
        return data

    def env_step(state):
        return env_step_all(state, action)

    def scanned(step):
        return lambda carry: jax.lax.scan(lambda c, _: (step(c), None), carry, None, SCAN)[0]

    cases = {
        "physics_call": (physics_step, 1, True),
        "physics_scan64": (scanned(physics_step), SCAN, True),
        "env_call": (env_step, 1, False),
        "env_scan64": (scanned(env_step), SCAN, False),
    }
    rates = {}
    for name, (step, env_steps, raw) in cases.items():
        states = reset(ENVS)
        carry = states.pipeline_state if raw else states
        calls = max(CALLS // env_steps, 3)
        timing = time_calls(step, carry, calls)
        rates[name] = ENVS * env_steps * timing.calls / timing.seconds
        log(f"{name}: {rates[name]:,.0f} env-steps/s ({timing.calls} calls)")
        jitted = jax.jit(step, donate_argnums=0)
        carry = jax.block_until_ready(jitted(reset(ENVS).pipeline_state if raw else reset(ENVS)))
        with jax.profiler.trace(str(out / "trace" / name), create_perfetto_trace=True):
            for _ in range(max(8 // env_steps, 1)):
                carry = jitted(carry)
            jax.block_until_ready(carry)
    out.mkdir(parents=True, exist_ok=True)
    (out / "loops.json").write_text(
        json.dumps({"terrain": terrain, "envs": ENVS, **rates}, indent=2)
    )


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]), *sys.argv[2:])
