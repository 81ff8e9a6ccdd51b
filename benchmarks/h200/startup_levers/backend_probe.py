"""Does starting JAX's GPU back end in a thread overlap the imports that follow it?

    python benchmarks/h200/startup_levers/backend_probe.py serial|thread|thread_put

One fresh process per call: imports JAX, then (thread: with `jax.devices()` started in a thread
first; thread_put: `jax.device_put` of a scalar, which sets up the device's memory) imports what
`quadcos.train` imports, then builds the back end and Warp's runtime on the
main thread (a no-op where the thread already did). Prints one JSON line of seconds since process
start at each mark."""

import json
import os
import pathlib
import sys
import threading
import time

# As quadcos._util.provenance.process_start, without importing quadcos (whose package imports
# MJX).
fields = pathlib.Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()
age = time.clock_gettime(time.CLOCK_BOOTTIME) - int(fields[19]) / os.sysconf("SC_CLK_TCK")
start = time.monotonic() - age
mode = sys.argv[1]
marks = {}


def mark(name: str) -> None:
    marks[name] = round(time.monotonic() - start, 3)


import jax  # noqa: E402

mark("jax_imported")
worker = None
if mode in ("thread", "thread_put"):
    target = jax.devices if mode == "thread" else lambda: jax.device_put(0.0).block_until_ready()
    worker = threading.Thread(target=target, daemon=True)
    worker.start()
import quadcos.train  # noqa: E402,F401

mark("quadcos_train_imported")
jax.devices()
mark("backend_ready")
try:
    import warp
except ImportError:  # no Warp (a CPU machine)
    warp = None
if warp is not None:
    warp.config.quiet = True
    warp.init()
    mark("warp_ready")
jax.device_put(1.0).block_until_ready()
mark("first_put")
label = mode + ("_noprealloc" if os.environ.get("XLA_PYTHON_CLIENT_PREALLOCATE") == "false" else "")
print(json.dumps({"mode": label, **marks}))
