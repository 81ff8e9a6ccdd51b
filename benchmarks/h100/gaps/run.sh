#!/usr/bin/env bash
# Where the GPU idles (one H100; after `source experiments/gpu_setup.sh`, warp-lang installed):
# raw physics and env steps of 4096 robots on flat, a call an env step against 64 in a scan
# (loops.py), and the 1-update training row, each traced with jax.profiler and summarised with
# the idle gaps blamed on the host's state (`python -m quadcos.benchmarking.profile DIR --gaps`).
# Writes $OUT: loops_flat.{json,log}, gaps_flat_*.md, bench_flat_profiled.{json,log}.
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
python3 benchmarks/h100/gaps/loops.py /tmp/gaps/flat flat > $O/loops_flat.log 2>&1
echo "loops exit $? $(date +%T)"
cp /tmp/gaps/flat/loops.json $O/loops_flat.json
for n in physics_call physics_scan64 env_call env_scan64; do
  python3 -m quadcos.benchmarking.profile /tmp/gaps/flat/trace/$n --gaps --top 20 > $O/gaps_flat_$n.md 2>&1
done
python3 -m quadcos.bench --impl=warp --terrain=flat --only=physics,train --env_counts=4096 \
  --train_rows=4096x8192x1 --train_seconds=8 --steps=20 --profile_dir=/tmp/gaps/train_flat --profile_python \
  --out=$O/bench_flat_profiled.json > $O/bench_flat_profiled.log 2>&1
echo "bench exit $? $(date +%T)"
python3 -m quadcos.benchmarking.profile /tmp/gaps/train_flat/4096x8192x1 --gaps --top 25 \
  > $O/gaps_flat_train_1.md 2>&1
