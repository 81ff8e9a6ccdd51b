"""`python -m quadcos.train` with every thread's Python stack written to stderr every DUMP_EVERY s
(where a run that stops making progress waits), and the jax path's XLA options patched: COND=1
puts branches (CONDITIONAL) back into XLA's command buffers, SERIAL=1 drops their concurrent
scheduling. Run from the project root (see probe.sh)."""

import faulthandler
import os
import sys

from quadcos import train
from quadcos.env import backends

faulthandler.dump_traceback_later(float(os.environ.get("DUMP_EVERY", "60")), repeat=True)
if os.environ.get("COND") and "CONDITIONAL" not in backends._COMMAND_BUFFERS:
    backends._COMMAND_BUFFERS += ",CONDITIONAL"
if os.environ.get("SERIAL"):
    _concurrent = backends.compiler_options

    def _serial(impl, warp_config):
        options = dict(_concurrent(impl, warp_config))
        options.pop("xla_gpu_command_buffer_scheduling_mode", None)
        return options

    backends.compiler_options = _serial
print(
    f"command buffers: {backends._COMMAND_BUFFERS}; serial: {bool(os.environ.get('SERIAL'))}",
    file=sys.stderr,
)
sys.exit(train.main())
