#!/usr/bin/env bash
# One GPU lease's campaign (session 7: issue 15, scale-out on nvidia-h200-x2), started detached so
# that it outlives the device calls that poll it (each call returns within 10 minutes):
#   setsid nohup bash experiments/gpu_campaign.sh > /tmp/campaign.log 2>&1 < /dev/null &
#   bash experiments/gpu_poll.sh 540      # in each later call: waits, copies finished phases to $OUT
# Each phase leaves /tmp/campaign/<phase>.tar.gz. (Earlier sessions' campaigns are this file's
# previous versions in git.)
#
# The bench (python -m quadcos.bench) on 1 and 2 H200s at equal per-device envs (4096 a GPU, batch
# 8192 a GPU, 8 updates a step), flat and slope5, and the walk section (the default learner:
# --preset=scratch, 4096 envs in all) on 1 GPU and on 2; quadcos.benchmarking.scaling combines.
set -uo pipefail
source experiments/gpu_setup.sh || exit 1
export NCCL_NVLS_ENABLE=0  # NVLink multicast stays off (KINDS.md)
C=/tmp/campaign
S=$C/scaling
mkdir -p $S
note() { echo "$(date +%T) $*" | tee -a $C/status; }
pack() { tar czf $C/$1.tar.gz -C $C $1 && note "$1 done"; }
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $C/gpu.txt
python3 -c "import jax, mujoco, warp; print(jax.__version__, mujoco.__version__, warp.__version__, jax.devices())" >> $C/gpu.txt 2>&1
bench() {  # NAME ARGS...: one bench process, its JSON and log under $S
  local name=$1; shift
  python3 -m quadcos.bench --walk_timeout_s 300 --out $S/$name.json "$@" > $S/$name.log 2>&1
  note "$name: exit $? $(grep -c FAILED $S/$name.log) failed"
}

# The first tries (experiments/scaling/README.md) ran the trainer as a jax.shard_map: XLA's GPU
# compiler crashed (segmentation fault) on the shard_map of the MJX step, JAX physics or Warp;
# the trainer is now the one-device program jitted on a sharded state (GSPMD). Every row here
# uses the JAX physics, on 1 GPU as on 2 (Warp's FFI module is loaded on cuda:0 only).
IMPL=jax
# 1. One GPU each, side by side (separate GPUs, 32 cores): flat train + walk; slope5 train.
CUDA_VISIBLE_DEVICES=0 bench flat_1dev --num_devices 1 --only train,walk --terrain flat \
  --train_rows 4096x8192x8 --impl $IMPL &
CUDA_VISIBLE_DEVICES=1 bench slope5_1dev --num_devices 1 --only train --terrain slope5 \
  --train_rows 4096x8192x8 --impl $IMPL
wait
# 2. Two GPUs: flat train + time to walk, then slope5 train.
bench flat_2dev --num_devices 2 --only train,walk --terrain flat --train_rows 8192x16384x8 --impl $IMPL
bench slope5_2dev --num_devices 2 --only train --terrain slope5 --train_rows 8192x16384x8 --impl $IMPL
python3 -m quadcos.benchmarking.scaling --out $S/h200x2.json \
  $S/flat_1dev.json $S/flat_2dev.json $S/slope5_1dev.json $S/slope5_2dev.json > $S/table.md 2>&1
pack scaling
note "campaign done"
