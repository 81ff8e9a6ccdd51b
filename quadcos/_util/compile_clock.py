"""Where a process's compile seconds go, from JAX's own monitoring events: tracing to a jaxpr,
lowering to StableHLO, and the backend's compile (a persistent-cache hit counts there as the
executable's load), with the programs each took and how many came from the cache."""

import threading

from jax import monitoring

# JAX's event names (jax._src.dispatch, jax._src.compiler, jax._src.compilation_cache).
_DURATIONS = {
    "/jax/core/compile/jaxpr_trace_duration": "trace_s",
    "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower_s",
    "/jax/core/compile/backend_compile_duration": "compile_s",
}
_COUNTS = {
    "/jax/compilation_cache/cache_hits": "cache_hits",
    "/jax/compilation_cache/cache_misses": "cache_misses",
}
_lock = threading.Lock()
_totals: dict[str, float] = dict.fromkeys([*_DURATIONS.values(), *_COUNTS.values()], 0.0)
_registered = False


def _on_duration(event: str, duration_secs: float, **kwargs) -> None:
    del kwargs
    if (name := _DURATIONS.get(event)) is not None:
        with _lock:
            _totals[name] += duration_secs


def _on_event(event: str, **kwargs) -> None:
    del kwargs
    if (name := _COUNTS.get(event)) is not None:
        with _lock:
            _totals[name] += 1


def start() -> None:
    """Starts counting (once per process; later calls do nothing)."""
    global _registered
    with _lock:
        if _registered:
            return
        _registered = True
    monitoring.register_event_duration_secs_listener(_on_duration)
    monitoring.register_event_listener(_on_event)


def totals() -> dict[str, float]:
    """The process's sums since `start`: trace_s, lower_s, compile_s (seconds), cache_hits,
    cache_misses (programs)."""
    with _lock:
        return dict(_totals)


def since(before: dict[str, float]) -> dict[str, float]:
    """What `totals()` gained since `before` (an earlier `totals()`), seconds rounded to ms."""
    now = totals()
    return {
        name: round(now[name] - before.get(name, 0.0), 3) if name.endswith("_s") else
        int(now[name] - before.get(name, 0.0))
        for name in now
    }
