#!/usr/bin/env bash
# The from-scratch learner at `make train` scale (2 CPU cores, --preset=cpu's 32 envs and 200 k
# env steps): --preset=scratch's two settings (gait search for the action centre, Eq. 9's r_s only
# for steps of movement) with a search of 256 candidates instead of the GPU's 2048, capped at the
# 15 minutes the issue allows on 2 cores. Does it walk? Usage, from the repo root with .venv:
#   bash experiments/from_scratch/run_cpu_search.sh NAME [more train flags]
set -uo pipefail
name=$1; shift
out=experiments/from_scratch/$name
run=${RUNS:-/tmp/quadcos_runs}/$name
rm -rf "$run"; mkdir -p "$out"
start=$(date +%s)
timeout -s TERM 900 .venv/bin/python -m quadcos.train --preset=cpu --terrain=flat --output_dir="$run" \
  --no_progress --config.env.action_centre=search --config.env.survival_min_speed=0.1 \
  --config.sac.gait_search.num_candidates=256 "$@" > "$out/train.log" 2>&1
echo "exit $? wall_time_s $(( $(date +%s) - start ))" >> "$out/train.log"
cp "$run/config.json" "$run/metrics.jsonl" "$run/gait_search.json" "$out/"
