#!/usr/bin/env bash
# Experiments for a machine of 2 GPUs, from the repository root (MENAGERIE_ROOT set):
#   bash experiments/two_gpus.sh
# First the data-parallel bench on both GPUs with MJX-Warp (scaling: 1 GPU vs 2 at equal per-GPU
# work, flat and slope5; SCALING_ROWS, default 1 update per env step) and BOTH; then two
# queues of one-GPU experiments side by side, each on its own GPU: QUEUE0 and QUEUE1, shell
# commands (run_gpu.sh cases; the defaults below). SCALING=0 skips the bench. Files as run_gpu.sh writes them, under $OUT
# (default /tmp/quadcos_out).
set -uo pipefail
export OUT=${OUT:-/tmp/quadcos_out}
if [ "${SCALING:-1}" = 1 ]; then
  SCALING_CROSS=0 SCALING_ROWS=${SCALING_ROWS:-4096x8192x1} IMPL=warp bash experiments/run_gpu.sh scaling
fi
# BOTH: experiments that take both GPUs, after the bench (default: the any-slope recipe on both,
# one curriculum lane a success as committed in experiments/scaling).
eval "${BOTH:-ANY_FLAGS='--config.sac.curriculum.promote_lanes=1 --config.env.start_ramp_s=0' bash experiments/run_gpu.sh any_slope_gpus}"
QUEUE0=${QUEUE0:-"ANYMAL_S=300 ANYMAL_SLOPES=0 bash experiments/run_gpu.sh anymal
  bash experiments/run_gpu.sh robust_scratch"}
# A lever of the any-slope recipe on one GPU, 4x the envs (and replay) at about the same updates a
# second (16 of 8192 a step), then the recipe itself on the same machine (its baseline); both with
# one curriculum lane a success, as committed in experiments/any_slope/levers.
QUEUE1=${QUEUE1:-"export LEVER_FLAGS='--num_envs=16384 --config.sac.replay_size=16000000 --config.sac.eval_interval=20000000 --config.sac.updates_per_step=16 --config.sac.curriculum.promote_lanes=1 --config.env.start_ramp_s=0'
  LEVER=envs16k_updates16 bash experiments/run_gpu.sh any_slope_lever
  LEVER=preset LEVER_FLAGS='--config.sac.curriculum.promote_lanes=1 --config.env.start_ramp_s=0' bash experiments/run_gpu.sh any_slope_lever"}
(export CUDA_VISIBLE_DEVICES=0; eval "$QUEUE0") &
(export CUDA_VISIBLE_DEVICES=1; eval "$QUEUE1") &
wait
