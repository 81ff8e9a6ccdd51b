#!/usr/bin/env bash
# Issue 12's throughput rows on one H100 (after `source experiments/gpu_setup.sh`, warp-lang
# installed): our trainer with Warp and with JAX physics on flat and slope5, stock Brax SAC on
# the JAX env (as a user runs it today) and on Warp; one JSON per (impl, terrain) process.
set -uo pipefail
export OUT=${OUT:-/tmp/quadcos_out}
bench() {  # NAME FLAGS...
  local name=$1; shift
  python3 -m quadcos.bench --out $OUT/bench_$name.json --train_seconds 8 "$@" \
    2>&1 | grep -v "^Module" | tee -a $OUT/bench.log | tail -4
}
bench warp_flat --impl warp --terrain flat --train_rows 4096x8192x1,4096x8192x8,16384x16384x4 --only train,stock --stock_rows 4096x8192x1
bench warp_slope5 --impl warp --terrain slope5 --train_rows 4096x8192x1,4096x8192x8 --only train
bench jax_flat --impl jax --terrain flat --train_rows 4096x8192x1,4096x8192x8 --only train,stock --stock_rows 4096x8192x1
bench jax_slope5 --impl jax --terrain slope5 --train_rows 4096x8192x1 --only train
