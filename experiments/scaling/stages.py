"""Each compiled stage of a data-parallel trainer on the quadruped, one after another, with the
seconds each takes (first call: compile + run): where a device count fails, the last line says
at which stage. `python -X faulthandler experiments/scaling/stages.py NUM_DEVICES IMPL MODE`;
MODE `shard_map` (the trainer's) or `gspmd` (the one-device program, jitted on sharded inputs:
XLA partitions it) or `step` (shard_map of the batched env step alone)."""

import sys
import time

import jax
from jax.sharding import PartitionSpec

from quadcos import env as env_lib
from quadcos.benchmarking.settings import TrainRow, trainer_config
from quadcos.training import SACTrainer, parallel

devices, impl, mode = int(sys.argv[1]), sys.argv[2], sys.argv[3]
env = env_lib.make_env("flat", impl=impl)
if mode == "step":
    layout = parallel.make_layout(devices)
    keys = jax.random.split(jax.random.PRNGKey(0), 1024 * devices)
    state = jax.jit(jax.vmap(env.reset))(keys)
    spec = jax.tree.map(lambda leaf: PartitionSpec(parallel.AXIS) if leaf.ndim else PartitionSpec(), state)
    step = parallel.sharded(
        lambda s: jax.vmap(env.step)(s, jax.numpy.zeros((s.obs.shape[0], env.action_size))),
        layout, in_specs=(spec,), out_specs=spec,
    )
    start = time.perf_counter()
    jax.block_until_ready(step(jax.device_put(state, parallel.named_shardings(layout, spec))))
    print(f"step: {time.perf_counter() - start:.1f} s", flush=True)
    sys.exit(0)
config = trainer_config("gpu", TrainRow(1024 * devices, 1024 * devices, 1), devices if mode == "shard_map" else 1)
trainer = SACTrainer(env, config)


def init(_):
    state = trainer.init()
    if mode != "gspmd":
        return state
    layout = parallel.make_layout(devices)
    specs = parallel.state_specs(state, ("env_state", "exploration_noise", "replay"), config.num_envs)
    specs = specs.replace(replay=jax.tree.map(
        lambda leaf: PartitionSpec(parallel.AXIS) if leaf.ndim else PartitionSpec(), state.replay))
    return jax.device_put(state, parallel.named_shardings(layout, specs))


for name, call in (
    ("init", init),
    ("prefill", trainer.prefill),
    ("train_chunk", lambda state: trainer.train_chunk(state)[0]),
    ("train_chunk again", lambda state: trainer.train_chunk(state)[0]),
    ("evaluate", lambda state: (trainer.evaluate(state.normalizer_params, state.policy_params), state)[1]),
):
    start = time.perf_counter()
    print(f"{name} ...", flush=True)
    state = jax.block_until_ready(call(None if name == "init" else state))
    print(f"{name}: {time.perf_counter() - start:.1f} s", flush=True)
