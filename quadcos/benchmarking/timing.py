"""Timing on a device: process start-up, and compiled calls timed on the very carry that compiled
them (one trace, checked), each ending with `block_until_ready`."""

import time

_IMPORT_TIME = time.perf_counter()

import dataclasses
import os
import pathlib
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp


def _process_age_s() -> float:
    """Seconds since this process started (Linux /proc; 0 elsewhere)."""
    try:
        fields = pathlib.Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()
        started = int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22: starttime, in ticks
        uptime = float(pathlib.Path("/proc/uptime").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 0.0
    return max(uptime - started, 0.0)


# perf_counter() reading of the process start (python's own start-up included).
PROCESS_START = _IMPORT_TIME - _process_age_s()


def since_start() -> float:
    return time.perf_counter() - PROCESS_START


def log(message: str) -> None:
    print(f"[{since_start():8.1f} s] {message}", flush=True)


@dataclasses.dataclass(frozen=True)
class Timing:
    """One timed function: `first_call_s` (compile + one call), then `calls` calls in `seconds`."""

    first_call_s: float
    calls: int
    seconds: float


def _strongly_typed(tree: Any) -> Any:
    """Drops weak types, so that a function's outputs have its inputs' types (no retrace)."""
    return jax.tree.map(lambda x: jax.lax.convert_element_type(x, jnp.asarray(x).dtype), tree)


def time_calls(step: Callable[[Any], Any], carry: Any, calls: int) -> Timing:
    """Compiles `step` (carry -> carry, donated) with a first call on `carry`, then times `calls`
    chained calls on the carry it returns.

    Raises:
      RuntimeError: `step` was traced more than once (the carry's types changed).
    """
    traces = 0

    def counted(carry: Any) -> Any:
        nonlocal traces
        traces += 1
        return step(carry)

    jitted = jax.jit(counted, donate_argnums=0)
    start = time.perf_counter()
    carry = jax.block_until_ready(jitted(carry))
    first_call_s = time.perf_counter() - start
    start = time.perf_counter()
    for _ in range(calls):
        carry = jitted(carry)
    jax.block_until_ready(carry)
    seconds = time.perf_counter() - start
    if traces != 1:
        raise RuntimeError(f"the timed function was traced {traces} times; its carry changes type")
    return Timing(first_call_s=first_call_s, calls=calls, seconds=seconds)
