"""Each compiled stage of a data-parallel trainer on the quadruped, one after another, with the
seconds each takes (first call: compile + run): where a device count fails, the last line says
at which stage. `python -X faulthandler experiments/scaling/stages.py NUM_DEVICES [IMPL]`."""

import sys
import time

import jax

from quadcos import env as env_lib
from quadcos.benchmarking.settings import TrainRow, trainer_config
from quadcos.training import SACTrainer

devices, impl = int(sys.argv[1]), sys.argv[2] if len(sys.argv) > 2 else "jax"
config = trainer_config("gpu", TrainRow(1024 * devices, 1024 * devices, 1), devices)
trainer = SACTrainer(env_lib.make_env("flat", impl=impl), config)
for name, call in (
    ("init", lambda state: trainer.init()),
    ("prefill", trainer.prefill),
    ("train_chunk", lambda state: trainer.train_chunk(state)[0]),
    ("evaluate", lambda state: (trainer.evaluate(state.normalizer_params, state.policy_params), state)[1]),
):
    start = time.perf_counter()
    print(f"{name} ...", flush=True)
    state = jax.block_until_ready(call(None if name == "init" else state))
    print(f"{name}: {time.perf_counter() - start:.1f} s", flush=True)
