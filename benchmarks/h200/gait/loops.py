"""Raw physics of standing robots, of robots walking the fixed trot, and env steps (4096 robots,
MJX-Warp), a call an env step against 16 env steps in one call (a `lax.scan`, as a training
chunk runs them).

    python benchmarks/h200/gait/loops.py OUT.json TERRAIN [--env KEY=VALUE ...]

Writes OUT.json: env-steps/s of each.
"""

import json
import pathlib
import sys

import jax
import jax.numpy as jnp

from quadcos._util.overrides import parse_value
from quadcos.benchmarking import physics
from quadcos.benchmarking.settings import make_bench_env
from quadcos.benchmarking.timing import log, time_calls

ENVS, CALLS, SCAN = 4096, 64, 16


def main(out: pathlib.Path, terrain: str, overrides: list[str]) -> None:
    env_overrides = {}
    for text in overrides:
        key, value = text.split("=", 1)
        env_overrides[key] = parse_value(value)
    env = make_bench_env(terrain, "gpu", "warp", **env_overrides)
    reset = physics.make_batch_reset(env)
    targets_at = jax.vmap(env.zero_action_targets)
    controls = jax.vmap(env.layout.controls)
    env_step_all = jax.vmap(env.step)
    action = jnp.zeros((ENVS, env.action_size))

    def standing(data):
        return physics.env_step_of_physics(env, data)

    def walking(data):
        data = data.replace(ctrl=controls(targets_at(data.time), data))
        return physics.env_step_of_physics(env, data)

    def env_step(state):
        return env_step_all(state, action)

    def scanned(step):
        return lambda carry: jax.lax.scan(lambda c, _: (step(c), None), carry, None, SCAN)[0]

    cases = {
        "standing_call": (standing, 1, True),
        "standing_scan16": (scanned(standing), SCAN, True),
        "walking_call": (walking, 1, True),
        "walking_scan16": (scanned(walking), SCAN, True),
        "env_call": (env_step, 1, False),
        "env_scan16": (scanned(env_step), SCAN, False),
    }
    rates = {}
    for name, (step, env_steps, raw) in cases.items():
        states = reset(ENVS)
        timing = time_calls(step, states.pipeline_state if raw else states, CALLS // env_steps)
        rates[name] = ENVS * env_steps * timing.calls / timing.seconds
        log(f"{name}: {rates[name]:,.0f} env-steps/s ({timing.calls} calls)")
    out.write_text(json.dumps({"terrain": terrain, "env": overrides, **rates}, indent=2) + "\n")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]), sys.argv[2], [a for a in sys.argv[3:] if a != "--env"])
