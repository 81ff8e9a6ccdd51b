# One H200 (gpu.txt): the 8-update rows (eight/) and the slope5 rows (slope5/) with loops and branches in
# command buffers; run as main/campaign.sh is, OUT=benchmarks/h200/arena.
R=$OUT
OUT=$R/eight PARITY_TERRAINS= TRAIN_ROWS=4096x8192x1,4096x8192x8 ROWS="default_flat jax_gc0_while_flat" bash benchmarks/h200/arena/run.sh | grep -v DONE
OUT=$R/slope5 PARITY_TERRAINS= ROWS="default_slope5 jax_gc0_while_slope5" bash benchmarks/h200/arena/run.sh
