# One H100 (gpu.txt), the first campaign: run.sh as it was then ran parity.py first and without its
# default_again variant; otherwise the rows as in benchmarks/h200/arena/run.sh.
PARITY_TERRAINS=flat ROWS="default_flat arena_flat jax_flat jax_gc0_flat jax_while_flat" bash benchmarks/h200/arena/run.sh
