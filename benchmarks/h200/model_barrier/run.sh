#!/usr/bin/env bash
# The MJX-Warp model behind an optimization barrier (model_barrier.patch: its constant fields not
# sunk by XLA into the substep loop, where each splat one is a broadcast kernel every substep)
# against the tree as it is; each row its own bench process with its own raw physics rate (one
# GPU; after `source experiments/gpu_setup.sh`, warp-lang installed). Writes $OUT/bench_*.
# The loop's broadcasts on a CPU (warp-lang installed), before and after the patch:
# `python benchmarks/h200/model_barrier/hlo_broadcasts.py` (hlo_broadcasts_*.txt).
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
barrier=/tmp/quadcos_barrier
rm -rf $barrier && cp -r . $barrier &&
  (cd $barrier && patch -p1 < benchmarks/h200/model_barrier/model_barrier.patch) || exit 1
b() { local tree=$1 name=$2 terrain=$3; shift 3
  (cd $tree && PYTHONPATH=/tmp/site:$tree python3 -m quadcos.bench --impl=warp --terrain=$terrain \
    --only=physics,train --env_counts=4096 --train_rows=4096x8192x1 --train_seconds=8 --steps=20 \
    --out=$O/bench_$name.json "$@" > $O/bench_$name.log 2>&1)
  echo "$name exit $? $(grep -o 'physics 4096 envs: [^(]*' $O/bench_$name.log)" \
    "$(grep -o 'train 4096x8192x1: [^,]*' $O/bench_$name.log)"; }
b $PWD flat_sunk flat
b $barrier flat_barrier flat
b $barrier flat_barrier_unroll10 flat --env substep_unroll=10
b $PWD slope5_sunk slope5
b $barrier slope5_barrier slope5
