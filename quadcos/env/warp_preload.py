"""MuJoCo Warp's kernels compiled side by side, before the first step launches them.

A cold MJX-Warp step compiles each Warp module at its first launch, one after the other: MuJoCo
Warp's own modules (passive, smooth, sensor, forward, ...) and the kernels it builds for one model
(its collision pairs, the solver's tiles for its degrees of freedom). `preload` steps the model
once on MuJoCo Warp with every kernel launch recorded instead of run, then compiles (or loads from
Warp's kernel cache) each recorded module in a thread of its own: a cold start waits for the
slowest module, not for their sum. A module the recording missed still compiles at its launch.
Within `deferred()` it returns while they compile, for a caller with other work meanwhile (the
trainer compiles its programs: `quadcos.training.loop.train`), who calls `wait()` before its
first Warp launch.
"""

import concurrent.futures
import contextlib
import contextvars
import functools
import logging
import math
import time
from collections.abc import Iterator
from typing import Any

logger = logging.getLogger(__name__)

# Warp's default threads per block on a CUDA device (a launch without `block_dim`)
_CUDA_BLOCK_DIM = 256
# modules of MJX's own (its FFI's kernels), which a MuJoCo Warp step does not launch
_MJX_MODULES = ("mujoco.mjx.warp.ffi",)
_THREADS = 32  # modules compiled at once

_deferred = contextvars.ContextVar("warp_preload_deferred", default=False)
# (module name, block dim) -> its compilation (True: loaded), of the modules not yet waited for
_started: dict[tuple[str, int | None], concurrent.futures.Future[bool]] = {}


@contextlib.contextmanager
def launches_recorded(warp: Any) -> Iterator[dict[tuple[str, int], Any]]:
    """Within: `warp`'s kernel launches record {(module name, block dim): module} of each launch
    with work (a launch of size 0 loads nothing) instead of running; a graph's loop
    (`capture_while`) runs its body once, a graph's branch (`capture_if`) both its sides. Warp's
    functions are restored on leaving. Kernels only: copies and fills still run."""
    launched: dict[tuple[str, int], Any] = {}

    def record(kernel=None, dim=0, *args, block_dim=None, **kwargs):
        size = math.prod(dim) if isinstance(dim, list | tuple) else dim
        if size:
            block = block_dim if block_dim and block_dim > 0 else _CUDA_BLOCK_DIM
            launched.setdefault((kernel.module.name, block), kernel.module)

    def loop_once(condition, while_body, *args, **kwargs):
        while_body(**kwargs)

    def both_sides(condition, on_true=None, on_false=None, *args, **kwargs):
        for side in (on_true, on_false):
            if side is not None:
                side(**kwargs)

    names = {
        "launch": record,
        "launch_tiled": record,
        "capture_while": loop_once,
        "capture_if": both_sides,
    }
    saved = {name: getattr(warp, name) for name in names}
    try:
        for name, function in names.items():
            setattr(warp, name, function)
        yield launched
    finally:
        for name, function in saved.items():
            setattr(warp, name, function)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Within: `preload` waits only for MJX's own module (tracing an MJX-Warp call loads it) and
    returns while the step's modules compile; `wait()` waits for them."""
    token = _deferred.set(True)
    try:
        yield
    finally:
        _deferred.reset(token)


def wait() -> int:
    """Waits for the modules `preload` compiles in threads; returns how many of them loaded (0
    where none was compiling)."""
    start = time.monotonic()
    futures = list(_started.values())
    _started.clear()
    loaded = sum(future.result() for future in futures)
    if futures:
        logger.debug(
            "Warp preload: %d of %d modules; waited %.1f s", loaded, len(futures),
            time.monotonic() - start,
        )  # fmt: skip
    return loaded


def preload(mj_model, option: dict[str, Any], sizes: dict[str, int]) -> int:
    """Compiles, a thread each, the Warp modules one MuJoCo Warp step of `mj_model` launches on
    the first CUDA device (its options set to `option`, e.g. MJX's `graph_conditional` and
    `warn_overflow`, which change the kernels built; its buffers `sizes`, `naconmax` and `njmax`),
    and MJX's own. Returns how many modules it compiled or loaded (within `deferred()`: MJX's
    loaded and the step's started); 0 without a CUDA device. A module still compiling from an
    earlier call is not started again. An optimisation only: a step that cannot be recorded is
    warned of, a module that fails here is skipped, and the run goes on (what is left compiles
    at its launch, as without the preload)."""
    import warp  # noqa: PLC0415 — installed wherever impl is warp

    if not warp.is_cuda_available():
        return 0
    device = warp.get_cuda_device(0)
    launched = _record(warp, device, mj_model, option, sizes)
    own = [_start(warp, device, name, None) for name in _MJX_MODULES]
    step = [_start(warp, device, module, block) for (_, block), module in launched.items()]
    if _deferred.get():
        return sum(future.result() for future in own) + len(step)
    return wait()


def _record(warp, device, mj_model, option: dict[str, Any], sizes: dict[str, int]) -> dict:
    """`launches_recorded`'s record of one MuJoCo Warp step of `mj_model` on `device` ({} where
    the step cannot be recorded, warned of)."""
    from mujoco.mjx.third_party import mujoco_warp  # noqa: PLC0415

    try:
        with warp.ScopedDevice(device):
            model = mujoco_warp.put_model(mj_model)
            for key, value in option.items():
                setattr(model.opt, key, value)
            data = mujoco_warp.make_data(mj_model, nworld=1, **sizes)
            with launches_recorded(warp) as launched:
                mujoco_warp.step(model, data)
    except Exception as error:  # noqa: BLE001 — MuJoCo Warp's step changed: compile at launch
        logger.warning(
            "Warp preload: the step was not recorded (%r); its kernels compile at"
            " their first launch",
            error,
        )
        return {}
    return launched


def _start(warp, device, module: Any, block: int | None) -> concurrent.futures.Future[bool]:
    """`module` (a Warp module, or a module's name) compiling or loading in a thread, or its
    compilation that is still under way."""
    key = (getattr(module, "name", module), block)
    future = _started.get(key)
    if future is None or future.done():
        future = _started[key] = _pool().submit(_load, warp, device, module, block)
    return future


def _load(warp, device, module: Any, block: int | None) -> bool:
    """Loads `module` (compiled first where Warp's kernel cache lacks it); False where it fails
    (it then loads at its launch, or is not in this MJX)."""
    try:
        if isinstance(module, str):
            warp.load_module(module, device=device)
        else:
            module.load(device, block)
    except Exception as error:  # noqa: BLE001 — e.g. not in this MJX: it loads at its launch
        logger.debug("Warp preload: %s skipped (%r)", getattr(module, "name", module), error)
        return False
    return True


@functools.cache
def _pool() -> concurrent.futures.ThreadPoolExecutor:
    return concurrent.futures.ThreadPoolExecutor(_THREADS, "quadcos-warp-preload")
