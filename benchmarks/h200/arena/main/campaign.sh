# One H200 (gpu.txt): the rows and the flat parity of the table in docs/benchmarks.md, run from the repo root after
# `source experiments/gpu_setup.sh` with warp-lang installed, OUT=this folder.
ROWS="default_flat jax_gc0_flat jax_gc0_unroll_flat jax_gc0_while_flat default_slope5 jax_gc0_slope5 jax_gc0_unroll_slope5" PARITY_TERRAINS=flat bash benchmarks/h200/arena/run.sh
