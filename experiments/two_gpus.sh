#!/usr/bin/env bash
# Experiments for a machine of 2 GPUs, from the repository root (MENAGERIE_ROOT set):
#   bash experiments/two_gpus.sh
# First the data-parallel bench on both GPUs with MJX-Warp (scaling: 1 GPU vs 2 at equal per-GPU
# work, 1 and 8 updates per env step, flat and slope5); then two queues of one-GPU experiments
# (run_gpu.sh cases) side by side, each on its own GPU. Files as run_gpu.sh writes them, under
# $OUT (default /tmp/quadcos_out).
set -uo pipefail
export OUT=${OUT:-/tmp/quadcos_out}
SCALING_CROSS=0 SCALING_ROWS=4096x8192x1,4096x8192x8 IMPL=warp bash experiments/run_gpu.sh scaling
(
  export CUDA_VISIBLE_DEVICES=0
  ANYMAL_S=300 bash experiments/run_gpu.sh anymal
  bash experiments/run_gpu.sh startup_and_randomized
  SEEDS=2 ANY_S=300 bash experiments/run_gpu.sh any_slope_seeds
) &
(
  export CUDA_VISIBLE_DEVICES=1
  SEEDS="0 1" ANY_S=300 bash experiments/run_gpu.sh any_slope_seeds
) &
wait
