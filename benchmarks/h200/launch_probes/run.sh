#!/usr/bin/env bash
# Probes of how the host's launches meet the GPU's graphs in training: quadcos.bench as it is, then
# each probe, every row its own bench process with its own raw physics rate (one GPU; after
# `source experiments/gpu_setup.sh`, warp-lang installed; Warp, 4096 envs, 1 update an env step;
# flat then slope5).
#   bash benchmarks/h200/launch_probes/run.sh NAME PROBE...
# NAME names the plain rows (bench_TERRAIN_NAME.*); PROBE is synced (bench_synced.py: the host
# waits for the GPU before every Warp graph launch) or side (bench_side.py: Warp's graphs on a
# stream of their own). The committed rows: `run.sh ahead synced`, then `run.sh ahead2 side`.
# Writes $OUT/bench_*.{json,log}.
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
name=$1; shift
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
args() { echo --impl=warp --terrain=$1 --only=physics,train --env_counts=4096 \
  --train_rows=4096x8192x1 --train_seconds=8 --steps=20; }
for terrain in flat slope5; do
  python3 -m quadcos.bench $(args $terrain) --out=$O/bench_${terrain}_$name.json \
    > $O/bench_${terrain}_$name.log 2>&1
  for probe in "$@"; do
    python3 benchmarks/h200/launch_probes/bench_$probe.py $(args $terrain) \
      --out=$O/bench_${terrain}_$probe.json > $O/bench_${terrain}_$probe.log 2>&1
  done
  for row in $name "$@"; do
    echo "$terrain $row $(grep -o 'physics 4096 envs: [^(]*' $O/bench_${terrain}_$row.log)" \
      "$(grep -o 'train 4096x8192x1: [^,]*' $O/bench_${terrain}_$row.log)"
  done
done
