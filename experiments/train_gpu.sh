#!/usr/bin/env bash
# One `python -m quadcos.train --preset=gpu` run on the GPU machine, its files gathered for committing.
# Usage: experiments/train_gpu.sh NAME [train flags...]
#   NAME: the run's name; its files go to $OUT/runs/NAME (config.json, metrics.jsonl, train.log,
#   startup.json, policy/). Several runs may share one GPU: start them with `&`, set
#   XLA_PYTHON_CLIENT_MEM_FRACTION (e.g. 0.2 for four) and `wait`. TRAIN_SECONDS caps the wall
#   time (SIGTERM: the trainer checkpoints, saves its policy and stops).
set -uo pipefail
name=$1
shift
out=${OUT:-/tmp/quadcos_out}/runs/$name
run=/tmp/quadcos_runs/$name
rm -rf "$run" "$out"
mkdir -p "$out"
start=$(date +%s)
timeout -s TERM "${TRAIN_SECONDS:-3600}" python3 -m quadcos.train --preset=gpu --output_dir="$run" --no_progress "$@" > "$out/train.log" 2>&1
echo "exit $? wall_time_s $(( $(date +%s) - start ))" >> "$out/train.log"
cp "$run/config.json" "$run/metrics.jsonl" "$out/"
for f in gait_search.json startup.json; do [ -f "$run/$f" ] && cp "$run/$f" "$out/"; done
[ -d "$run/policy" ] && cp -r "$run/policy" "$out/"
tail -n 1 "$out/train.log"
