#!/usr/bin/env bash
# Learning from nothing on one GPU (Warp physics where warp-lang is installed), 3 seeds sharing
# the GPU, while the machine's CPU cores run `make train`-sized runs (2 cores each) of the
# trot start with both readings of Eq. 9's r_s. Outputs: $OUT/scratch.tar.gz, $OUT/cpu.tar.gz.
#   bash experiments/from_scratch/run_gpu.sh   (after `source experiments/gpu_setup.sh`)
set -uo pipefail
export OUT=${OUT:-/tmp/quadcos_out}
SCRATCH=(--terrain=flat --config.env.action_centre=midpoint --config.env.survival_min_speed=0.1
  --config.sac.policy_output_scale=1.0 --config.sac.init_std=None --config.sac.init_alpha=1.0
  --config.sac.prefill_actions=uniform --config.sac.actor_warmup_steps=0 --config.sac.noise_hold_steps=20
  --config.sac.eval_interval=1000000 --num_timesteps=60000000)
cpu_run() {  # NAME CORES FLAGS...
  local name=$1 cores=$2; shift 2
  mkdir -p /tmp/cpu_out/$name
  ( start=$(date +%s.%N)
    JAX_PLATFORMS=cpu timeout -s TERM 490 taskset -c "$cores" python3 -m quadcos.train --preset=cpu \
      --terrain=flat --output_dir=/tmp/cpu_runs/$name --no_progress "$@" > /tmp/cpu_out/$name/train.log 2>&1
    echo "exit $? wall_time_s $(python3 -c "import time;print(round(time.time()-$start,1))")" >> /tmp/cpu_out/$name/train.log
    cp /tmp/cpu_runs/$name/config.json /tmp/cpu_runs/$name/metrics.jsonl /tmp/cpu_out/$name/ 2>/dev/null ) &
}
c=8
for s in 0 1; do
  cpu_run trot_s$s $c,$((c+1)) --seed=$s; c=$((c+2))
  cpu_run trot_moving_s$s $c,$((c+1)) --seed=$s --config.env.survival_min_speed=0.1; c=$((c+2))
done
# The three seeds share the GPU (and cores 0-7): wall times are shared-GPU times.
for s in 0 1 2; do
  XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 TRAIN_SECONDS=${TRAIN_SECONDS:-490} taskset -c 0-7 \
    bash experiments/train_gpu.sh scratch_s$s --seed=$s "${SCRATCH[@]}" &
done
wait
nvidia-smi --query-gpu=name --format=csv,noheader > $OUT/runs/gpu.txt
tar czf $OUT/scratch.tar.gz -C $OUT runs && rm -rf $OUT/runs
wait
tar czf $OUT/cpu.tar.gz -C /tmp cpu_out
ls -la $OUT
