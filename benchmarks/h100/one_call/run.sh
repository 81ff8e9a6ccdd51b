#!/usr/bin/env bash
# A control step's 10 physics substeps in one MuJoCo Warp call against MJX-Warp's call a substep
# (one H100; after `source experiments/gpu_setup.sh`, warp-lang installed), on a tree with
# one_call_substeps.patch applied (`git apply benchmarks/h100/one_call/one_call_substeps.patch`:
# quadcos/env/warp_substeps.py and the env option `warp.one_call_substeps`). Writes $OUT: the
# states of both paths (parity.txt), then each (terrain, path) in its own bench process with its
# own raw physics rate (ab_*.json, ab_*.log).
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
note() { echo "$(date +%T) $*" | tee -a $O/status; }
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
python3 benchmarks/h100/one_call/parity.py > $O/parity.txt 2>&1; note "parity exit $?"
b() { local name=$1; shift; python3 -m quadcos.bench --impl=warp --only=physics,train --env_counts=4096 \
  --train_rows=4096x8192x1,4096x8192x8 --train_seconds=8 --steps=20 --out=$O/$name.json "$@" > $O/$name.log 2>&1
  note "$name exit $? $(grep -o 'train 4096x8192x1: [^,]*' $O/$name.log)"; }
b ab_flat_per_substep --terrain=flat --env warp.one_call_substeps=false
b ab_flat_one_call --terrain=flat
b ab_slope5_per_substep --terrain=slope5 --env warp.one_call_substeps=false
b ab_slope5_one_call --terrain=slope5
