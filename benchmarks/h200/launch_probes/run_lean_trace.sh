#!/usr/bin/env bash
# The 1-update training row (flat, Warp, 4096 envs) traced without the Python tracer, and its idle
# gaps (one GPU; after `source experiments/gpu_setup.sh`, warp-lang installed). Writes
# $OUT/train_lean_flat.log and $OUT/gaps_flat_train_1_lean.md.
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu_lean.txt
python3 benchmarks/h200/launch_probes/train_lean_trace.py /tmp/lean/flat flat > $O/train_lean_flat.log 2>&1
python3 -m quadcos.benchmarking.profile /tmp/lean/flat --gaps --top 25 > $O/gaps_flat_train_1_lean.md 2>&1
