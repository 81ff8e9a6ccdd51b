#!/usr/bin/env bash
# One GPU lease's campaign (issues 13 and 12), started detached so that it outlives the device
# calls that poll it (each call returns within 10 minutes; the machine stays warm between them):
#   setsid nohup bash experiments/gpu_campaign.sh > /tmp/campaign.log 2>&1 < /dev/null &
#   bash experiments/gpu_poll.sh 540      # in each later call: waits, copies finished phases to $OUT
# Phases run one after another, each with the whole GPU; each leaves /tmp/campaign/<phase>.tar.gz.
set -uo pipefail
source experiments/gpu_setup.sh || exit 1
C=/tmp/campaign
mkdir -p $C
note() { echo "$(date +%T) $*" | tee -a $C/status; }
pack() {  # PHASE: its files under $C/<PHASE> as $C/<PHASE>.tar.gz
  tar czf $C/$1.tar.gz -C $C $1 && note "$1 done"
}
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $C/gpu.txt
python3 -c "import jax, mujoco, warp; print(jax.__version__, mujoco.__version__, warp.__version__)" >> $C/gpu.txt 2>&1

# 1. Issue 13: from scratch on flat (gait search, then SAC; Eq. 9's r_s paid for movement),
# 3 seeds, one after another.
note "scratch start"
for s in 0 1 2; do
  OUT=$C/scratch TRAIN_SECONDS=${SCRATCH_SECONDS:-170} bash experiments/train_gpu.sh scratch_s$s \
    --terrain=flat --seed=$s --config.env.action_centre=search --config.env.survival_min_speed=0.1 \
    --config.sac.eval_interval=1000000
  note "scratch_s$s: $(tail -n 1 $C/scratch/runs/scratch_s$s/train.log)"
done
pack scratch

# 2. Issue 12: throughput rows, Warp and JAX physics, ours and stock Brax SAC.
note "bench start"
mkdir -p $C/bench && OUT=$C/bench bash benchmarks/h100/run.sh
pack bench

# 3. Issue 13's ablations, one seed each, in the background: SAC alone from the standing
# midpoint (held noise, r_s for movement); the search in all of §3.3's 5-D box (not symmetric);
# the search with r_s paid for every step alive. Meanwhile (sharing the GPU) issue 12's parity:
# the committed policies with both physics implementations, 1024 episodes each.
note "ablation + parity start"
ablate() {  # NAME FLAGS...
  local name=$1; shift
  OUT=$C/ablation TRAIN_SECONDS=${ABLATION_SECONDS:-120} bash experiments/train_gpu.sh $name \
    --terrain=flat --seed=0 --config.sac.eval_interval=1000000 "$@"
  note "$name: $(tail -n 1 $C/ablation/runs/$name/train.log)"
}
( ablate sac_only_s0 --config.env.action_centre=midpoint --config.env.survival_min_speed=0.1 \
    --config.sac.policy_output_scale=1.0 --config.sac.init_std=None --config.sac.init_alpha=1.0 \
    --config.sac.prefill_actions=uniform --config.sac.actor_warmup_steps=0 \
    --config.sac.noise_hold_steps=20 --num_timesteps=100000000
  ablate scratch_full_box_s0 --config.env.action_centre=search --config.env.survival_min_speed=0.1 \
    --config.sac.gait_search.symmetric=False
  ablate scratch_alive_s0 --config.env.action_centre=search
  pack ablation ) &
mkdir -p $C/warp
python3 experiments/warp/parity.py run --num_envs=1024 2>&1 | grep -v "^Module" | tee $C/warp/parity.log
cp experiments/warp/eval_*.json experiments/warp/trace_*.json $C/warp/
wait

# 4. Issue 12: process start -> end of a 100 k-step gpu-preset run, JAX cache cold, then warm.
note "startup start"
for state in cold warm; do
  [ $state = cold ] && rm -rf /tmp/startup_cache/jax
  rm -rf /tmp/startup_run
  start=$(date +%s.%N)
  QUADCOS_CACHE_DIR=/tmp/startup_cache WARP_CACHE_PATH=/tmp/qcache/warp python3 -m quadcos.train \
    --preset=gpu --num_timesteps=100000 --output_dir=/tmp/startup_run --no_progress \
    > $C/warp/startup_$state.log 2>&1
  echo "$state exit $? wall_s $(python3 -c "import time;print(round(time.time()-$start,1))")" | tee -a $C/warp/startup.txt
  cp /tmp/startup_run/metrics.jsonl $C/warp/startup_metrics_$state.jsonl 2>/dev/null
done
pack warp
note "campaign done"
