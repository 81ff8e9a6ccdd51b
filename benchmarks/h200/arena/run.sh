#!/usr/bin/env bash
# MJX-Warp's scratch arrays from an arena (quadcos.env.warp_arena) and its calls recorded by XLA
# (warp.graph_mode=jax): each row its own bench process with its own raw physics rate, then the
# physics' parity and rate (parity.py, over $PARITY_TERRAINS; empty: none). One GPU, after
# `source experiments/gpu_setup.sh` with warp-lang installed. ROWS picks rows by name (default:
# all), TRAIN_ROWS the bench's train rows; writes $OUT/bench_*.{json,log}, $OUT/parity.log.
# Table: python benchmarks/h200/arena/table.py FOLDER...
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
A=benchmarks/h200/arena
b() { local name=$1 terrain=$2 xla=$3; shift 3
  case " ${ROWS:-$name} " in *" $name "*) ;; *) return ;; esac
  XLA_FLAGS="--xla_gpu_triton_gemm_any=true $xla" timeout 300 python3 -m quadcos.bench \
    --impl=warp --terrain=$terrain --only=physics,train --env_counts=4096 \
    --train_rows=${TRAIN_ROWS:-4096x8192x1} --train_seconds=8 --steps=20 \
    --out=$O/bench_$name.json "$@" > $O/bench_$name.log 2>&1
  echo "$(date +%T) $name exit $? $(grep -o 'physics 4096 envs: [^(]*' $O/bench_$name.log)" \
    "$(grep -o 'train 4096x8192x[18]: [^,]*' $O/bench_$name.log | tr '\n' ' ')"; }
WHILE=--xla_gpu_enable_command_buffer=+WHILE,+CONDITIONAL
for t in flat slope5; do
  b default_$t $t ""
  b arena_$t $t "" --env warp.arena=true
  b jax_gc0_$t $t "" --env warp.graph_mode=jax --env warp.graph_conditional=false
  b jax_gc0_while_$t $t "$WHILE" --env warp.graph_mode=jax --env warp.graph_conditional=false
  b jax_gc0_unroll_$t $t "" --env warp.graph_mode=jax --env warp.graph_conditional=false \
    --env substep_unroll=10
done
[ -n "${PARITY_TERRAINS-flat slope5}" ] && TERRAINS=${PARITY_TERRAINS-flat slope5} \
  timeout 300 python3 $A/parity.py > $O/parity.log 2>&1
echo "$(date +%T) parity exit $? $(grep -E '^(flat|slope5) ' $O/parity.log | tr '\n' ' ')"
echo CAMPAIGN DONE
