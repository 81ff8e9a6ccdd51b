#!/usr/bin/env bash
# Experiments for a machine of 2 GPUs, from the repository root (MENAGERIE_ROOT set):
#   bash experiments/two_gpus.sh
# First the data-parallel bench on both GPUs with MJX-Warp (scaling: 1 GPU vs 2 at equal per-GPU
# work, 1 and 8 updates per env step, flat and slope5); then two queues of one-GPU experiments
# side by side, each on its own GPU: QUEUE0 and QUEUE1, shell commands (run_gpu.sh cases; the
# defaults below). SCALING=0 skips the bench. Files as run_gpu.sh writes them, under $OUT
# (default /tmp/quadcos_out).
set -uo pipefail
export OUT=${OUT:-/tmp/quadcos_out}
if [ "${SCALING:-1}" = 1 ]; then
  SCALING_CROSS=0 SCALING_ROWS=4096x8192x1,4096x8192x8 IMPL=warp bash experiments/run_gpu.sh scaling
fi
QUEUE0=${QUEUE0:-"ANYMAL_S=300 bash experiments/run_gpu.sh anymal; bash experiments/run_gpu.sh profile"}
QUEUE1=${QUEUE1:-"SEEDS='0 1 2' ANY_S=300 bash experiments/run_gpu.sh any_slope_seeds"}
(export CUDA_VISIBLE_DEVICES=0; eval "$QUEUE0") &
(export CUDA_VISIBLE_DEVICES=1; eval "$QUEUE1") &
wait
