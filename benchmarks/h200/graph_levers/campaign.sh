#!/usr/bin/env bash
# Issue 33 item 3: MJX-Warp's calls recorded by XLA's command buffers (graph_mode=jax, solver without conditional nodes) against Warp's own per-call graphs.
set -u
echo "start $(date +%T)"
O=$OUT/graph_levers; mkdir -p $O
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $O/gpu.txt
bench() {  # NAME TERRAIN XLA_FLAGS [bench flags]
  local name=$1 terrain=$2 xla=$3; shift 3
  XLA_FLAGS="--xla_gpu_triton_gemm_any=true $xla" timeout 300 python3 -m quadcos.bench --impl=warp --terrain=$terrain \
    --only=physics,train --env_counts=4096 --train_rows=4096x8192x1,4096x8192x8 --train_seconds=8 --steps=20 \
    "$@" --out=$O/bench_$name.json > $O/bench_$name.log 2>&1
  echo "$(date +%T) $name exit $? $(grep -E 'physics 4096|train 4096' $O/bench_$name.log | tr '\n' ' ')"
}
bench jax_flat flat "" --env warp.graph_mode=jax
bench default_flat flat ""
bench jax_while_flat flat "--xla_gpu_enable_command_buffer=+WHILE,+CONDITIONAL" --env warp.graph_mode=jax
bench jax_slope5 slope5 "" --env warp.graph_mode=jax
bench default_slope5 slope5 ""
for mode in auto jax; do
  timeout 200 python3 -m quadcos.evaluate --no_progress --num_envs=1024 --policy=experiments/policies/flat --terrain=flat \
    --seconds=20 --env.warp.graph_mode=$mode --out=$O/eval_flat_$mode.json > $O/eval_flat_$mode.log 2>&1
  echo "$(date +%T) eval $mode exit $? $(tail -n 3 $O/eval_flat_$mode.log | tr '\n' ' ')"
done
echo CAMPAIGN DONE
