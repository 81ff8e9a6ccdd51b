#!/usr/bin/env bash
# Does the host running ahead of the GPU cause the physics' conditional-node stall? Each row its
# own bench process with its own raw physics rate (one GPU; after `source
# experiments/gpu_setup.sh`, warp-lang installed; Warp, 4096 envs, 1 update an env step):
# "ahead" = quadcos.bench as it is, "synced" = bench_synced.py (the host waits for the GPU before
# every Warp graph launch). Writes $OUT/bench_*.{json,log}.
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
args() { echo --impl=warp --terrain=$1 --only=physics,train --env_counts=4096 \
  --train_rows=4096x8192x1 --train_seconds=8 --steps=20; }
for terrain in flat slope5; do
  python3 -m quadcos.bench $(args $terrain) --out=$O/bench_${terrain}_ahead.json \
    > $O/bench_${terrain}_ahead.log 2>&1
  python3 benchmarks/h200/launch_probes/bench_synced.py $(args $terrain) \
    --out=$O/bench_${terrain}_synced.json > $O/bench_${terrain}_synced.log 2>&1
  for row in ahead synced; do
    echo "$terrain $row $(grep -o 'physics 4096 envs: [^(]*' $O/bench_${terrain}_$row.log)" \
      "$(grep -o 'train 4096x8192x1: [^,]*' $O/bench_${terrain}_$row.log)"
  done
done
