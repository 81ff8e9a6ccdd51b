#!/usr/bin/env bash
# The trainer against the physics of the same robots on one H200 each (MJX-Warp, 4096 robots, a
# batch of 8192, 1 update per env step, a 30-s train row), flat on GPU 0 and slope5 on GPU 1 at
# once, caches warm: raw physics standing, walking the fixed trot, the env, the trainer.
#   source experiments/gpu_setup.sh && bash benchmarks/h200/trainer_physics/run.sh
# -> $OUT/flat.json, $OUT/slope5.json (benchmarks/h200/trainer_physics/, record trainer_physics_h200)
set -uo pipefail
OUT=${OUT:-/tmp/qc_trainer_physics}; mkdir -p "$OUT"
gpu=0
for terrain in flat slope5; do
  CUDA_VISIBLE_DEVICES=$gpu python3 -m quadcos.bench --impl warp --terrain "$terrain" \
    --env_counts 4096 --train_rows 4096x8192x1 --train_seconds 30 --only physics,gait,env,train \
    --out "$OUT/$terrain.json" > "$OUT/$terrain.log" 2>&1 &
  gpu=$((gpu + 1))
done
wait
tail -n 2 "$OUT"/*.log
