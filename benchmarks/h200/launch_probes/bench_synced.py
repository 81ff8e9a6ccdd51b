"""`python -m quadcos.bench` with the host waiting for the GPU before every Warp graph launch.

    python benchmarks/h200/launch_probes/bench_synced.py BENCH_ARGS...

A probe, not a feature: Warp's CUDA graph launch (`wp_cuda_graph_launch`, which MJX-Warp's FFI
callback calls once a physics step) is wrapped so that it first synchronises the stream it
launches on. The host then never launches a step's graph while the previous one runs on the
GPU — the state in which traces show the GPU stalled after the solver's conditional node.
"""

import sys

import warp as wp
from warp._src import context

from quadcos import bench


def synchronise_before_graph_launches() -> None:
    wp.init()
    core = context.runtime.core
    launch, synchronise = core.wp_cuda_graph_launch, core.wp_cuda_stream_synchronize

    def synchronised_launch(graph_exec, stream):
        synchronise(stream)
        return launch(graph_exec, stream)

    core.wp_cuda_graph_launch = synchronised_launch


if __name__ == "__main__":
    synchronise_before_graph_launches()
    sys.exit(bench.main(sys.argv[1:]))
