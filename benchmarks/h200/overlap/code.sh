#!/usr/bin/env bash
# The fast path as a user runs it, its XLA options set by the code (no XLA_FLAGS beyond the
# default): `warp.graph_mode=jax`, `warp.graph_conditional=false`, `overlap_updates=true`
# against the default, in the bench (flat and slope5, 1 and 8 updates) and in a run from nothing
# (`--preset=scratch --seed=${SEED:-11}`, 20 M env steps). One GPU, after `source
# experiments/gpu_setup.sh` with warp-lang installed; writes $OUT/bench_*, $OUT/scratch_*. Seed 12:
# `RUN_TIMEOUT=195 SEED=12 TERRAINS= bash benchmarks/h200/overlap/code.sh` (each run capped at 195 s).
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
FAST_ENV="--env warp.graph_mode=jax --env warp.graph_conditional=false"
FAST="$FAST_ENV --sac overlap_updates=true"
b() { local name=$1 terrain=$2; shift 2
  timeout 300 python3 -m quadcos.bench --impl=warp --terrain=$terrain --only=physics,train \
    --env_counts=4096 --train_rows=4096x8192x1,4096x8192x8 --train_seconds=8 --steps=20 \
    --out=$O/bench_$name.json "$@" > $O/bench_$name.log 2>&1
  echo "$(date +%T) $name exit $? $(grep -o 'physics 4096 envs: [^(]*' $O/bench_$name.log)" \
    "$(grep -o 'train 4096x8192x[18]: [^,]*' $O/bench_$name.log | tr '\n' ' ')"; }
for t in ${TERRAINS-flat slope5}; do
  b default_$t $t
  b fast_$t $t $FAST
done
r() { local name=$1; shift
  /usr/bin/time -f "%e s" timeout ${RUN_TIMEOUT:-420} python3 -m quadcos.train --preset=scratch --seed=${SEED:-11} \
    --output_dir=$O/scratch_${name}_s${SEED:-11} --no_progress "$@" > $O/scratch_${name}_s${SEED:-11}.log 2>&1
  echo "$(date +%T) scratch_${name}_s${SEED:-11} exit $? $(tail -n 1 $O/scratch_${name}_s${SEED:-11}.log)"; }
r default
r fast --config.env.warp.graph_mode=jax --config.env.warp.graph_conditional=false \
  --config.sac.overlap_updates=true
echo CAMPAIGN DONE
