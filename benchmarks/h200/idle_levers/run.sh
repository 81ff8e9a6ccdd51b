#!/usr/bin/env bash
# Two levers on the GPU's idle time in training, each row its own bench process with its own raw
# physics rate (one GPU; after `source experiments/gpu_setup.sh`, warp-lang installed; flat and
# slope5, Warp, 4096 envs), on the tree and a patched copy:
#   the env option `warp.graph_conditional` (default True, MuJoCo Warp's; False runs the solver's
#     4 iterations as plain kernels, no conditional graph node);
#   select_reset.patch: the trainer's NaN reset as a select from restart states drawn once a
#     chunk, not a `lax.cond` (whose predicate the host copies back and waits for every env step).
# Rows: "cond" = the tree, "select" = the patched copy, "gc0" = `--env
# warp.graph_conditional=false`. Writes $OUT/bench_*.{json,log}.
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
P=$PWD/benchmarks/h200/idle_levers cond=$PWD select=/tmp/quadcos_select
rm -rf $select && cp -r . $select && (cd $select && patch -p1 < $P/select_reset.patch) || exit 1
b() { local tree=$1 name=$2 terrain=$3 rows=$4; shift 4
  (cd $tree && PYTHONPATH=/tmp/site:$tree python3 -m quadcos.bench --impl=warp --terrain=$terrain \
    --only=physics,train --env_counts=4096 --train_rows=$rows --train_seconds=8 --steps=20 \
    --out=$O/bench_$name.json "$@" > $O/bench_$name.log 2>&1)
  echo "$name exit $? $(date +%T) $(grep -o 'physics 4096 envs: [^(]*' $O/bench_$name.log)" \
    "$(grep -o 'train 4096x8192x[18]: [^,]*' $O/bench_$name.log | tr '\n' ' ')"; }
b $cond flat_cond flat 4096x8192x1,4096x8192x8
b $select flat_select flat 4096x8192x1,4096x8192x8
b $select flat_select_gc0 flat 4096x8192x1,4096x8192x8 --env warp.graph_conditional=false
b $cond flat_cond_gc0 flat 4096x8192x1 --env warp.graph_conditional=false
b $cond slope5_cond slope5 4096x8192x1
b $select slope5_select slope5 4096x8192x1
b $select slope5_select_gc0 slope5 4096x8192x1 --env warp.graph_conditional=false
