#!/usr/bin/env bash
# The trainer against the physics of the same robots (MJX-Warp, 4096 robots, a batch of 8192,
# 1 update per env step, a 30-s train row), caches warm: raw physics standing, walking the fixed
# trot, the env, the trainer. Each terrain's caches are filled first by a 2-s train row. On a
# host of two GPUs or more flat runs on GPU 0 and slope5 on GPU 1 at once (one H200 each), on
# one GPU one after the other (one H100).
#   source experiments/gpu_setup.sh && bash benchmarks/h200/trainer_physics/run.sh
# -> $OUT/flat.json, $OUT/slope5.json (benchmarks/h200/trainer_physics/, record
# trainer_physics_h200; benchmarks/h100/trainer_physics/, record trainer_physics_h100)
set -uo pipefail
OUT=${OUT:-/tmp/qc_trainer_physics}; mkdir -p "$OUT"
gpus=$(nvidia-smi -L 2>/dev/null | wc -l)
bench() {  # GPU TERRAIN
  CUDA_VISIBLE_DEVICES=$1 python3 -m quadcos.bench --impl warp --terrain "$2" --only train \
    --train_rows 4096x8192x1 --train_seconds 2 --out "$OUT/$2_warmup.json" > "$OUT/$2.log" 2>&1
  CUDA_VISIBLE_DEVICES=$1 python3 -m quadcos.bench --impl warp --terrain "$2" \
    --env_counts 4096 --train_rows 4096x8192x1 --train_seconds 30 --only physics,gait,env,train \
    --out "$OUT/$2.json" >> "$OUT/$2.log" 2>&1
}
if [ "$gpus" -ge 2 ]; then
  bench 0 flat & bench 1 slope5 & wait
else
  bench 0 flat; bench 0 slope5
fi
tail -n 2 "$OUT"/*.log
