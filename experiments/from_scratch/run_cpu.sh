#!/usr/bin/env bash
# Learning from nothing at `make train` scale (2 CPU cores, --preset=cpu's 32 envs), Eq. 9's r_s
# paid only for steps of movement (low-passed forward speed >= 0.1 m/s), with one of two learners:
#   LEARNER=midpoint (default): the zero action stands still (midpoint action centre), Brax's SAC
#     exploration (every such run stood);
#   LEARNER=search: --preset=scratch's gait search for the action centre (256 candidates instead
#     of the GPU's 2048), then SAC from it as the trot start does (cpu_search_s0).
# TRAIN_SECONDS caps the wall time (SIGTERM: checkpoint and policy saved; the issue allows 15 min).
# Usage, from the repo root with .venv: [LEARNER=...] [TRAIN_SECONDS=...] run_cpu.sh NAME [more train flags]
set -uo pipefail
name=$1; shift
case ${LEARNER:-midpoint} in
  midpoint) learner=(--config.env.action_centre=midpoint --config.sac.policy_output_scale=1.0
              --config.sac.init_std=None --config.sac.init_alpha=1.0
              --config.sac.prefill_actions=uniform --config.sac.actor_warmup_steps=0) ;;
  search) learner=(--config.env.action_centre=search --config.sac.gait_search.num_candidates=256) ;;
  *) echo "LEARNER: midpoint or search, not '$LEARNER'" >&2; exit 2 ;;
esac
out=experiments/from_scratch/$name
run=${RUNS:-/tmp/quadcos_runs}/$name
rm -rf "$run"; mkdir -p "$out"
start=$(date +%s)
timeout -s TERM "${TRAIN_SECONDS:-86400}" .venv/bin/python -m quadcos.train --preset=cpu --terrain=flat \
  --output_dir="$run" --no_progress --config.env.survival_min_speed=0.1 "${learner[@]}" "$@" > "$out/train.log" 2>&1
echo "exit $? wall_time_s $(( $(date +%s) - start ))" >> "$out/train.log"
cp "$run/config.json" "$run/metrics.jsonl" "$out/"
[ -f "$run/gait_search.json" ] && cp "$run/gait_search.json" "$out/"
true
