#!/usr/bin/env bash
# The physics recorded by XLA (warp.graph_mode=jax, loops in concurrent command buffers) with
# MJX-Warp's model behind an optimization barrier (the default; ../model_barrier/model_barrier.patch:
# its constant fields built once a control step instead of a broadcast kernel each every substep),
# against the tree without it (../model_barrier/trees.sh), which also runs the default and the
# solver's early exit off in Warp's own graphs (gc0); each row its own bench process with its own
# raw physics rate. One GPU, after `source experiments/gpu_setup.sh` with warp-lang installed;
# writes $OUT/bench_*.
source benchmarks/h200/model_barrier/trees.sh
b() { local tree=$1 name=$2 terrain=$3 rows=$4 xla=$5; shift 5
  (cd $tree && XLA_FLAGS="--xla_gpu_triton_gemm_any=true $xla" PYTHONPATH=/tmp/site:$tree \
    timeout 300 python3 -m quadcos.bench --impl=warp --terrain=$terrain --only=physics,train \
    --env_counts=4096 --train_rows=$rows --train_seconds=8 --steps=20 \
    --out=$O/bench_$name.json "$@" > $O/bench_$name.log 2>&1)
  echo "$(date +%T) $name exit $? $(grep -o 'physics 4096 envs: [^(]*' $O/bench_$name.log)" \
    "$(grep -o 'train 4096x8192x[18]: [^,]*' $O/bench_$name.log | tr '\n' ' ')"; }
CONC="--xla_gpu_enable_command_buffer=+WHILE,+CONDITIONAL"
CONC="$CONC --xla_gpu_command_buffer_scheduling_mode=CONCURRENT"
JAX="--env warp.graph_mode=jax --env warp.graph_conditional=false"
OV="--sac overlap_updates=true"
for t in flat slope5; do
  b $sunk default_$t $t 4096x8192x1 ""
  b $PWD jax_conc_barrier_$t $t 4096x8192x1 "$CONC" $JAX
  b $sunk jax_conc_$t $t 4096x8192x1 "$CONC" $JAX
  b $sunk gc0_$t $t 4096x8192x1 "" --env warp.graph_conditional=false
  b $PWD jax_conc_overlap8_barrier_$t $t 4096x8192x8 "$CONC" $JAX $OV
done
echo CAMPAIGN DONE
