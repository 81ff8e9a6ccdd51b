"""Splat-constant broadcasts in the compiled env step's substep loop (MJX-Warp, flat, 8 robots).

    python benchmarks/h200/model_barrier/hlo_broadcasts.py

Needs warp-lang (its CPU kernels do; no GPU). Compiles `jax.vmap(env.step)` for this machine's
backend and counts the broadcast fusions (`wrapped_broadcast`, each a kernel on a GPU) referenced
in the body of the while loop that holds MJX-Warp's call, and in the entry computation.
"""

import re

import jax
import jax.numpy as jnp

from quadcos.benchmarking.settings import make_bench_env

ROBOTS = 8


def main() -> None:
    env = make_bench_env("flat", "gpu", "warp")
    keys = jax.random.split(jax.random.PRNGKey(0), ROBOTS)
    states = jax.jit(jax.vmap(env.reset))(keys)
    action = jnp.zeros((ROBOTS, env.action_size))
    text = jax.jit(lambda s: jax.vmap(env.step)(s, action)).lower(states).compile().as_text()
    computations = {}
    for block in re.split(r"\n(?=%|ENTRY)", text):
        name = re.match(r"(?:ENTRY )?%?([\w.\-]+)", block)
        if name:
            computations[name.group(1)] = block
    for body in re.findall(r"while\(.*?body=%?([\w.\-]+)", text):
        block = computations.get(body, "")
        if "custom-call(" in block:
            print(f"substep loop body {body}: {block.count('wrapped_broadcast')} broadcast references")
    entry = next(block for block in computations.values() if block.startswith("ENTRY"))
    print(f"entry: {entry.count('wrapped_broadcast')} broadcast references")


if __name__ == "__main__":
    main()
