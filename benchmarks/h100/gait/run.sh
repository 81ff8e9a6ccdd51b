#!/usr/bin/env bash
# One H100: the trainer against the raw physics of standing robots and of robots walking the trot,
# flat and slope5, 4096 envs, 1 and 8 updates an env step: MJX's default as benchmarks/h100/run.sh
# measures it (-> $OUT/default/), then the path with MJX-Warp's calls in XLA's graphs (-> $OUT/jax/).
# After `source experiments/gpu_setup.sh` with warp-lang installed. Table:
# python benchmarks/h200/gait/table.py benchmarks/h100/gait/default benchmarks/h100/gait/jax
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O/default $O/jax
nvidia-smi --query-gpu=name --format=csv,noheader | tee $O/default/gpu.txt > $O/jax/gpu.txt
OUT=$O/default IMPLS=warp bash benchmarks/h100/run.sh > $O/default/run.log 2>&1
OUT=$O/jax SETS=jax bash benchmarks/h200/gait/run.sh | tee $O/jax/campaign.log
