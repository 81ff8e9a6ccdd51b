#!/usr/bin/env bash
# The trainer against the raw physics of standing robots (the physics section) and of robots
# walking the fixed trot (the gait section: the motion the env and the trainer step), flat and
# slope5, 4096 envs, 1 and 8 updates an env step, each row its own bench process: MJX's default, the
# solver's early exit off alone, and the path with MJX-Warp's calls in XLA's graphs (with and
# without `overlap_updates`). One GPU, after `source experiments/gpu_setup.sh` with warp-lang
# installed; writes $OUT/bench_*.{json,log}. Table: `python benchmarks/h200/gait/table.py DIR`
# (its rows on one H100: benchmarks/h100/gait/).
# A repeat of some rows: `TERRAINS=flat SETS="default jax" ROWS=4096x8192x1 bash ...run.sh`.
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
GC0="--env warp.graph_conditional=false"
JAX="--env warp.graph_mode=jax $GC0"
b() { local name=$1 terrain=$2; shift 2
  timeout 300 python3 -m quadcos.bench --impl=warp --terrain=$terrain --only=physics,gait,train \
    --env_counts=4096 --train_rows=${ROWS-4096x8192x1,4096x8192x8} --train_seconds=8 --steps=20 \
    --out=$O/bench_${name}_$terrain.json "$@" > $O/bench_${name}_$terrain.log 2>&1
  echo "$(date +%T) ${name}_$terrain exit $?" \
    "$(grep -o '\(physics\|gait\) 4096 envs: [^(]*\|train 4096x8192x[18]: [^,]*' \
      $O/bench_${name}_$terrain.log | tr '\n' ' ')"; }
for t in ${TERRAINS-flat slope5}; do
  for name in ${SETS-default gc0 jax jax_overlap}; do
    case $name in
      default) b default $t ;;
      gc0) b gc0 $t $GC0 ;;
      jax) b jax $t $JAX ;;
      jax_overlap) b jax_overlap $t $JAX --sac overlap_updates=true ;;
    esac
  done
done
echo CAMPAIGN DONE
