"""Each compiled stage of the data-parallel trainer on the quadruped, one after another, with the
seconds each takes (first call: compile + run): where a device count fails, the last line says at
which stage. `python -X faulthandler experiments/scaling/stages.py NUM_DEVICES IMPL MODE`, MODE:
`trainer` (SACTrainer over NUM_DEVICES: the one-device program jitted on a sharded state) or `step` (nothing but `jax.vmap(env.step)` under `jax.shard_map`, as the trainer steps
MJX-Warp per device: the reproducer of XLA's GPU compiler crash under Shardy, README.md;
`JAX_USE_SHARDY_PARTITIONER=false` runs it; ENVS_PER_DEVICE, default 1024)."""

import os
import sys
import time

import jax

from quadcos import env as env_lib
from quadcos.benchmarking.settings import TrainRow, trainer_config
from quadcos.training import SACTrainer, parallel


def timed(name, call):
    start = time.perf_counter()
    print(f"{name} ...", flush=True)
    result = jax.block_until_ready(call())
    print(f"{name}: {time.perf_counter() - start:.1f} s", flush=True)
    return result


devices, impl, mode = int(sys.argv[1]), sys.argv[2], sys.argv[3]
env = env_lib.make_env("flat", impl=impl)
if mode == "step":
    layout = parallel.make_layout(devices)
    num_envs = int(os.environ.get("ENVS_PER_DEVICE", "1024")) * devices
    state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), num_envs))

    def step_all(s):
        return jax.vmap(env.step)(s, jax.numpy.zeros((s.obs.shape[0], env.action_size)))

    if layout.mesh is not None:  # as parallel.per_device, but with JAX's partitioner as set
        spec = parallel.env_specs(state, num_envs)
        step_all = jax.shard_map(
            step_all, mesh=layout.mesh, in_specs=(spec,), out_specs=spec, check_vma=False
        )
        state = jax.device_put(state, parallel.named_shardings(layout, spec))
    print(f"Shardy: {jax.config.jax_use_shardy_partitioner}", flush=True)
    timed("step", lambda: jax.jit(step_all)(state))
    sys.exit(0)
trainer = SACTrainer(
    env, trainer_config("gpu", TrainRow(1024 * devices, 1024 * devices, 1), devices)
)
state = timed("init", trainer.init)
state = timed("prefill", lambda: trainer.prefill(state))
state = timed("train_chunk", lambda: trainer.train_chunk(state)[0])
state = timed("train_chunk again", lambda: trainer.train_chunk(state)[0])
timed("evaluate", lambda: trainer.evaluate(state.normalizer_params, state.policy_params))
