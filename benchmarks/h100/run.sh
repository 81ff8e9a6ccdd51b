#!/usr/bin/env bash
# The paper robot's throughput rows on one H100 (after `source experiments/gpu_setup.sh`, warp-lang
# installed): our trainer with Warp and with JAX physics on flat and slope5, each row beside the raw
# physics rates its own process measures at the same envs (robots standing, and robots walking the
# trot), and stock Brax SAC on the JAX env (as a user runs it today) and on Warp; one JSON per
# (impl, terrain) process. IMPLS: the physics to run (default "warp jax"). Then:
# python benchmarks/h100/merge.py $OUT/bench_*.json --into benchmarks/h100.json
set -uo pipefail
export OUT=${OUT:-/tmp/quadcos_out}
mkdir -p "$OUT"
bench() {  # NAME FLAGS...
  local name=$1; shift
  python3 -m quadcos.bench --out $OUT/bench_$name.json --train_seconds 8 --env_counts 4096,16384 "$@" \
    2>&1 | grep -v "^Module" | tee -a $OUT/bench.log | tail -4
}
for impl in ${IMPLS:-warp jax}; do
  rows=4096x8192x1,4096x8192x8
  [ $impl = warp ] && rows=$rows,16384x16384x4
  bench ${impl}_flat --impl $impl --terrain flat --train_rows $rows --only physics,gait,train,stock \
    --stock_rows 4096x8192x1
  bench ${impl}_slope5 --impl $impl --terrain slope5 --train_rows 4096x8192x1,4096x8192x8 \
    --only physics,gait,train
done
