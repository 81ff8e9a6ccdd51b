#!/usr/bin/env bash
# Issue 12 on one GPU (after `source experiments/gpu_setup.sh`, warp-lang installed):
# the parity evaluations, then process start -> end of `python -m quadcos.train --preset=gpu
# --num_timesteps=100000` with an empty JAX cache (cold) and again (warm), Warp kernels cached.
set -uo pipefail
export OUT=${OUT:-/tmp/quadcos_out}
python3 experiments/warp/parity.py run --num_envs=1024 2>&1 | grep -v "^Module" | tail -20
cp experiments/warp/eval_*.json experiments/warp/trace_*.json /tmp/ 2>/dev/null
for state in cold warm; do
  [ $state = cold ] && rm -rf /tmp/startup_cache/jax
  rm -rf /tmp/startup_run
  start=$(date +%s.%N)
  QUADCOS_CACHE_DIR=/tmp/startup_cache WARP_CACHE_PATH=/tmp/qcache/warp python3 -m quadcos.train \
    --preset=gpu --num_timesteps=100000 --output_dir=/tmp/startup_run --no_progress > /tmp/startup_$state.log 2>&1
  echo "$state exit $? wall_s $(python3 -c "import time;print(round(time.time()-$start,1))")" | tee -a $OUT/startup.txt
  cp /tmp/startup_run/metrics.jsonl $OUT/startup_metrics_$state.jsonl 2>/dev/null
done
tail -3 /tmp/startup_cold.log >> $OUT/startup.txt
tar czf $OUT/parity.tar.gz experiments/warp/eval_*.json experiments/warp/trace_*.json
