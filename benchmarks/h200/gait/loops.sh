#!/usr/bin/env bash
# loops.py per physics setting and terrain, each its own process (one GPU, after `source
# experiments/gpu_setup.sh` with warp-lang installed); writes $OUT/loops_*.{json,log}.
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
l() { local name=$1 terrain=$2; shift 2
  timeout 240 python3 benchmarks/h200/gait/loops.py $O/loops_${name}_$terrain.json $terrain "$@" \
    > $O/loops_${name}_$terrain.log 2>&1
  echo "$(date +%T) loops_${name}_$terrain exit $? $(grep -o '[a-z0-9_]*: [0-9,]* env-steps/s' \
    $O/loops_${name}_$terrain.log | tr '\n' ' ')"; }
for t in ${TERRAINS-flat slope5}; do
  l default $t
  l gc0 $t --env warp.graph_conditional=false
  l jax $t --env warp.graph_mode=jax --env warp.graph_conditional=false
done
echo CAMPAIGN DONE
