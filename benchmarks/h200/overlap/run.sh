#!/usr/bin/env bash
# SAC updates beside the physics (`--sac overlap_updates=true`: each env step's updates drawn
# before its transitions are stored, so neither waits for the other), with the physics recorded
# by XLA (warp.graph_mode=jax), loops in command buffers and XLA's concurrent command-buffer
# scheduling, against the default: each row its own bench process with its own raw physics rate.
# One GPU, after `source experiments/gpu_setup.sh` with warp-lang installed. ROWS picks rows by
# name (default: all, in the order below); writes $OUT/bench_*.{json,log}.
# Table: python benchmarks/h200/overlap/table.py FOLDER...
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
b() { local name=$1 terrain=$2 rows=$3 xla=$4; shift 4
  case " ${ROWS:-$name} " in *" $name "*) ;; *) return ;; esac
  XLA_FLAGS="--xla_gpu_triton_gemm_any=true $xla" timeout 300 python3 -m quadcos.bench \
    --impl=warp --terrain=$terrain --only=physics,train --env_counts=4096 \
    --train_rows=$rows --train_seconds=8 --steps=20 \
    --out=$O/bench_$name.json "$@" > $O/bench_$name.log 2>&1
  echo "$(date +%T) $name exit $? $(grep -o 'physics 4096 envs: [^(]*' $O/bench_$name.log)" \
    "$(grep -o 'train 4096x8192x[18]: [^,]*' $O/bench_$name.log | tr '\n' ' ')"; }
GRAPHS="--xla_gpu_enable_command_buffer=+WHILE,+CONDITIONAL"
CONC="$GRAPHS --xla_gpu_command_buffer_scheduling_mode=CONCURRENT"
JAX="--env warp.graph_mode=jax --env warp.graph_conditional=false"
OV="--sac overlap_updates=true"
ONE=4096x8192x1
for t in flat slope5; do
  b default_$t $t $ONE ""
  b jax_conc_overlap_$t $t $ONE "$CONC" $JAX $OV
  b jax_overlap_$t $t $ONE "$GRAPHS" $JAX $OV
  b jax_conc_$t $t $ONE "$CONC" $JAX
  b overlap_$t $t $ONE "" $OV
  b jax_$t $t $ONE "$GRAPHS" $JAX
  b default8_$t $t 4096x8192x8 ""
  b jax_conc_overlap8_$t $t 4096x8192x8 "$CONC" $JAX $OV
done
echo CAMPAIGN DONE
