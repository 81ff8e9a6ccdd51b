#!/usr/bin/env bash
# The paper's flat experiment on one GPU: `--preset=gpu` (4096 envs) for at most TRAIN_SECONDS of
# wall time (SIGTERM then makes the trainer checkpoint, save its policy and stop), then the run's
# files are copied into $OUT (or experiments/flat_gpu/out) for committing.
# Usage: RUN_NAME=flat_gpu TRAIN_SECONDS=360 experiments/flat_gpu/run.sh [extra train flags]
set -uo pipefail
name=${RUN_NAME:-flat_gpu}
out=${OUT:-experiments/flat_gpu/out}/$name
mkdir -p "$out"
run=/tmp/quadcos_runs/$name
rm -rf "$run"
nvidia-smi --query-gpu=name,memory.total --format=csv,noheader >> "$out/train.log" 2>&1
start=$(date +%s)
timeout -s TERM "${TRAIN_SECONDS:-3600}" python3 -m quadcos.train --preset=gpu --terrain=flat \
  --output_dir="$run" --no_progress "$@" >> "$out/train.log" 2>&1
echo "exit $? wall_time_s $(( $(date +%s) - start ))" >> "$out/train.log"
cp "$run/config.json" "$run/metrics.jsonl" "$out/"
[ -n "${SKIP_POLICY:-}" ] || { mkdir -p "$out/policy" && cp "$run"/policy/* "$out/policy/"; }
tail -n 4 "$out/train.log"
