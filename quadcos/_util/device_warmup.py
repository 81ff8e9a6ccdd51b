"""The accelerator set up while a command imports the rest of itself.

A process's first device use starts JAX's back end and reserves its share of the GPU's memory
(XLA preallocates 75 %): 2.4 s on an H200, all of it on the main thread after the imports
(4-6 s, mostly MJX with its Warp kernels). JAX releases the interpreter lock while it does so,
so `start` runs that first use in a thread of its own from the command's first line; the main
thread's own first use then waits for it only if it is not done yet
(`benchmarks/h200/startup_levers/`: process start to the first device put, 9.0 → 6.1 s, median
of 5).
"""

import os
import threading
from collections.abc import Sequence

# XLA options read when the back end starts: set before `start` (and by in-process callers).
XLA_FLAGS = "--xla_gpu_triton_gemm_any=true"


def start(argv: Sequence[str]) -> threading.Thread | None:
    """Starts the first device use in a daemon thread; None (nothing started) for `--help`, and
    for a run over several processes (`--coordinator`: `jax.distributed.initialize` must come
    before any device use)."""
    os.environ.setdefault("XLA_FLAGS", XLA_FLAGS)
    if any(arg in ("-h", "--help") or arg.startswith("--coordinator") for arg in argv):
        return None
    thread = threading.Thread(target=_first_use, name="quadcos-device-warmup", daemon=True)
    thread.start()
    return thread


def _first_use() -> None:
    try:
        import jax

        jax.device_put(0.0).block_until_ready()
    except Exception:  # noqa: BLE001 — the main thread meets the same error and reports it
        pass
