"""MuJoCo Warp's scratch arrays from memory that stays put, so that XLA can record its calls.

Every MJX-Warp physics call allocates some 35 scratch arrays (the solver's and the collision
pass's contexts, a few zeroed buffers) and frees them when it returns. Captured into a CUDA graph,
those allocations become memory-allocation nodes, which a graph may hold but a child graph may
not: XLA records a custom call into its command buffers as a child graph, so with
`warp.graph_mode=jax` the capture fails (`CUDA_ERROR_NOT_SUPPORTED`, "Failed to create a child
graph node"). An `Arena` hands a call the same addresses every time instead, from blocks that are
never freed: the i-th allocation of a call gets the i-th block. Nothing is allocated inside a
graph, so XLA can record the whole physics call, and a graph recorded once stays valid.
"""

from __future__ import annotations

import ctypes
import functools
from collections.abc import Callable

_RELAXED = 2  # CU_STREAM_CAPTURE_MODE_RELAXED


class Arena:
    """A Warp allocator (`allocate`, `deallocate`) whose i-th allocation since `rewind` is the
    same block of device memory every time (a larger request replaces the block; the old one is
    kept, since a recorded graph may still point at it). `malloc(size) -> pointer` supplies new
    blocks; freeing is a no-op."""

    deallocate_requires_context_guard = False

    def __init__(self, malloc: Callable[[int], int]):
        self.malloc = malloc
        self.blocks: list[tuple[int, int]] = []  # (pointer, bytes), in allocation order
        self.retired: list[tuple[int, int]] = []  # outgrown blocks, still owned
        self.cursor = 0

    def rewind(self) -> None:
        """The next allocation is a call's first again."""
        self.cursor = 0

    def allocate(self, size_in_bytes: int) -> int:
        index = self.cursor
        self.cursor += 1
        if index < len(self.blocks) and self.blocks[index][1] >= size_in_bytes:
            return self.blocks[index][0]
        block = (self.malloc(size_in_bytes), size_in_bytes)
        if index < len(self.blocks):
            self.retired.append(self.blocks[index])
            self.blocks[index] = block
        else:
            self.blocks.append(block)
        return block[0]

    def deallocate(self, ptr: int, size_in_bytes: int) -> None:
        del ptr, size_in_bytes

    @property
    def nbytes(self) -> int:
        return sum(size for _, size in self.blocks + self.retired)


def _set_capture_mode(mode: int) -> int:
    """This thread's CUDA stream-capture mode set to `mode`; returns the previous one."""
    value = ctypes.c_int(mode)
    status = ctypes.CDLL("libcuda.so.1").cuThreadExchangeStreamCaptureMode(ctypes.byref(value))
    if status != 0:
        raise RuntimeError(f"cuThreadExchangeStreamCaptureMode failed: CUresult {status}")
    return value.value


def device_malloc(device) -> Callable[[int], int]:
    """`malloc(size) -> pointer` of plain device memory on a Warp CUDA `device`, allowed while
    the thread captures a stream (the capture mode relaxed for the call: the allocation is not
    part of the graph)."""
    import warp  # noqa: PLC0415 — only where impl is warp

    core = warp._src.context.runtime.core  # noqa: SLF001 — Warp's own default allocation

    def malloc(size_in_bytes: int) -> int:
        previous = _set_capture_mode(_RELAXED)
        try:
            with device.context_guard:
                ptr = core.wp_alloc_device_default(device.context, size_in_bytes, None)
        finally:
            _set_capture_mode(previous)
        if not ptr:
            raise RuntimeError(f"arena: failed to allocate {size_in_bytes} bytes on {device}")
        return ptr

    return malloc


_ARENAS: dict[tuple, Arena] = {}


def with_arena(step: Callable) -> Callable:
    """MuJoCo Warp's `step(m, d)` (or `forward`) with its scratch arrays from an `Arena` of its
    own for each batch size and device; unchanged on a CPU."""
    if getattr(step, "uses_arena", False):
        return step

    @functools.wraps(step)
    def wrapped(m, d):
        import warp  # noqa: PLC0415

        device = warp.get_device()
        if not device.is_cuda:
            return step(m, d)
        key = (step.__name__, d.nworld, device.ordinal)
        if key not in _ARENAS:
            _ARENAS[key] = Arena(device_malloc(device))
        arena = _ARENAS[key]
        arena.rewind()
        previous = warp.get_device_allocator(device)
        if previous is device.current_allocator:  # Warp's own: restored by unsetting ours
            previous = None
        warp.set_device_allocator(device, arena)
        try:
            return step(m, d)
        finally:
            warp.set_device_allocator(device, previous)

    wrapped.uses_arena = True
    return wrapped


def install() -> None:
    """MJX-Warp's physics calls (`mjx.step`, `mjx.forward`) take their scratch arrays from
    arenas, for the rest of the process."""
    import mujoco.mjx.third_party.mujoco_warp as mjwarp  # noqa: PLC0415

    mjwarp.step = with_arena(mjwarp.step)
    mjwarp.forward = with_arena(mjwarp.forward)
