"""The 1-update training row (flat, MJX-Warp, 4096 envs) traced without the Python tracer.

    python benchmarks/h200/launch_probes/train_lean_trace.py OUT_DIR [TERRAIN]

`jax.profiler.trace`'s default records every Python call, which slows the host's share of a
training step (MJX-Warp's FFI callbacks are Python) 1.3–1.6×; with `python_tracer_level=0` the
host threads record only XLA's and CUDA's own events. Prints the untraced and the traced seconds
a chunk, and writes the trace under OUT_DIR (`python -m quadcos.benchmarking.profile OUT_DIR
--gaps`).
"""

import pathlib
import sys
import time

import jax

from quadcos import training
from quadcos.benchmarking.settings import TrainRow, make_bench_env, trainer_config

ROW, CHUNKS = "4096x8192x1", 4


def seconds_a_chunk(trainer, state, chunks):
    start = time.perf_counter()
    for _ in range(chunks):
        state, metrics = trainer.train_chunk(state)
    jax.block_until_ready((state, metrics))
    return (time.perf_counter() - start) / chunks, state


def main(out: pathlib.Path, terrain: str = "flat") -> None:
    config = trainer_config("gpu", TrainRow.parse(ROW))
    trainer = training.SACTrainer(make_bench_env(terrain, "gpu", "warp"), config)
    state = jax.block_until_ready(trainer.prefill(trainer.init()))
    _, state = seconds_a_chunk(trainer, state, 1)  # compiles
    untraced, state = seconds_a_chunk(trainer, state, CHUNKS)
    options = jax.profiler.ProfileOptions()
    options.python_tracer_level = 0
    with jax.profiler.trace(str(out), create_perfetto_trace=True, profiler_options=options):
        traced, state = seconds_a_chunk(trainer, state, 2)
    steps = config.steps_per_chunk
    print(
        f"{terrain} {ROW}: {steps} env steps a chunk; untraced {1e3 * untraced / steps:.2f} ms"
        f" an env step, traced {1e3 * traced / steps:.2f} ms"
    )


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]), *sys.argv[2:])
