#!/usr/bin/env bash
# The MJX-Warp model behind an optimization barrier (the default; model_barrier.patch: its constant
# fields not sunk by XLA into the substep loop, where each splat one is a broadcast kernel every
# substep) against the tree without it (trees.sh: the patch reversed); each row its own bench
# process with its own raw physics rate (one GPU; after `source experiments/gpu_setup.sh`,
# warp-lang installed). Writes $OUT/bench_*.
# The loop's broadcasts on a CPU (warp-lang installed), in this tree and in the reversed one:
# `python benchmarks/h200/model_barrier/hlo_broadcasts.py` (hlo_broadcasts_*.txt).
source benchmarks/h200/model_barrier/trees.sh
b() { local tree=$1 name=$2 terrain=$3; shift 3
  (cd $tree && PYTHONPATH=/tmp/site:$tree python3 -m quadcos.bench --impl=warp --terrain=$terrain \
    --only=physics,train --env_counts=4096 --train_rows=4096x8192x1 --train_seconds=8 --steps=20 \
    --out=$O/bench_$name.json "$@" > $O/bench_$name.log 2>&1)
  echo "$name exit $? $(grep -o 'physics 4096 envs: [^(]*' $O/bench_$name.log)" \
    "$(grep -o 'train 4096x8192x1: [^,]*' $O/bench_$name.log)"; }
b $sunk flat_sunk flat
b $PWD flat_barrier flat
b $PWD flat_barrier_unroll10 flat --env substep_unroll=10
b $sunk slope5_sunk slope5
b $PWD slope5_barrier slope5
