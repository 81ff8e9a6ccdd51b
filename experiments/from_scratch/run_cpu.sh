#!/usr/bin/env bash
# Learning from nothing at `make train` scale (2 CPU cores, 32 envs): the zero action stands
# still (midpoint action centre), Brax's SAC exploration, and Eq. 9's r_s paid only for steps of
# movement (low-passed forward speed >= 0.1 m/s). Usage: run_cpu.sh NAME [more train flags]
set -uo pipefail
name=$1; shift
out=experiments/from_scratch/$name
run=${RUNS:-/tmp/quadcos_runs}/$name
rm -rf "$run"; mkdir -p "$out"
start=$(date +%s)
python -m quadcos.train --preset=cpu --terrain=flat --output_dir="$run" --no_progress \
  --config.env.action_centre=midpoint --config.env.survival_min_speed=0.1 \
  --config.sac.policy_output_scale=1.0 --config.sac.init_std=None --config.sac.init_alpha=1.0 \
  --config.sac.prefill_actions=uniform --config.sac.actor_warmup_steps=0 "$@" > "$out/train.log" 2>&1
echo "exit $? wall_time_s $(( $(date +%s) - start ))" >> "$out/train.log"
cp "$run/config.json" "$run/metrics.jsonl" "$out/"
