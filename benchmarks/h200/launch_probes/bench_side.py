"""`python -m quadcos.bench` with MJX-Warp's CUDA graphs launched on a stream of their own.

    python benchmarks/h200/launch_probes/bench_side.py BENCH_ARGS...

A probe, not a feature: Warp's CUDA graph launch (`wp_cuda_graph_launch`, which MJX-Warp's FFI
callback calls once a physics step on XLA's stream) is wrapped so that the graph runs on a second
stream, ordered by events: the side stream waits for XLA's work so far, runs the graph, and XLA's
stream waits for the graph. The order of all work is as before; only the physics' kernels (and
its solver's conditional nodes) sit on another hardware queue than the graphs the host launches
for XLA meanwhile.
"""

import sys

import warp as wp
from warp._src import context

from quadcos import bench


def launch_graphs_on_a_side_stream() -> None:
    wp.init()
    core = context.runtime.core
    launch = core.wp_cuda_graph_launch
    device = wp.get_cuda_device(0)
    side, before, after = wp.Stream(device), wp.Event(device), wp.Event(device)

    def side_launch(graph_exec, stream):
        core.wp_cuda_event_record(before.cuda_event, stream, False)
        core.wp_cuda_stream_wait_event(side.cuda_stream, before.cuda_event, False)
        launched = launch(graph_exec, side.cuda_stream)
        core.wp_cuda_event_record(after.cuda_event, side.cuda_stream, False)
        core.wp_cuda_stream_wait_event(stream, after.cuda_event, False)
        return launched

    core.wp_cuda_graph_launch = side_launch


if __name__ == "__main__":
    launch_graphs_on_a_side_stream()
    sys.exit(bench.main(sys.argv[1:]))
