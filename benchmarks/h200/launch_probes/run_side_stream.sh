#!/usr/bin/env bash
# MJX-Warp's graphs on a stream of their own (bench_side_stream.py) against quadcos.bench as it is,
# each row its own bench process with its own raw physics rate (one GPU; after `source
# experiments/gpu_setup.sh`, warp-lang installed; Warp, 4096 envs, 1 update an env step).
# Writes $OUT/bench_*_{ahead2,side}.{json,log}.
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu_side.txt
args() { echo --impl=warp --terrain=$1 --only=physics,train --env_counts=4096 \
  --train_rows=4096x8192x1 --train_seconds=8 --steps=20; }
for terrain in flat slope5; do
  python3 -m quadcos.bench $(args $terrain) --out=$O/bench_${terrain}_ahead2.json \
    > $O/bench_${terrain}_ahead2.log 2>&1
  python3 benchmarks/h200/launch_probes/bench_side_stream.py $(args $terrain) \
    --out=$O/bench_${terrain}_side.json > $O/bench_${terrain}_side.log 2>&1
  for row in ahead2 side; do
    echo "$terrain $row $(grep -o 'physics 4096 envs: [^(]*' $O/bench_${terrain}_$row.log)" \
      "$(grep -o 'train 4096x8192x1: [^,]*' $O/bench_${terrain}_$row.log)"
    grep -m1 -i "error\|Traceback" $O/bench_${terrain}_$row.log
  done
done
