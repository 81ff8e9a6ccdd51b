#!/usr/bin/env bash
# `make train`'s learner, variants side by side on a many-core machine: each run is
# `python -m quadcos.train --preset=cpu --terrain=flat` on its own two cores (taskset, JAX on the
# CPU), as `make train` runs on a 2-core machine. Usage:
#   bash experiments/make_train/sweep.sh OUT_DIR [VARIANT[:SEED] ...]
# (default: every variant below; a variant without a seed runs seeds $SEEDS, default 0 1 2)
# Each run leaves OUT_DIR/<variant>_s<seed>/{config.json,metrics.jsonl,train.log}; OUT_DIR/summary.txt
# has one line per run: its exit status, wall time and every evaluation's speed and fall rate.
set -uo pipefail
out=$1; shift
declare -A VARIANTS=(
  [base]=""
  [actor_lr1e-4]="--config.sac.learning_rate.actor=1e-4"
  [entropy-10]="--config.sac.target_entropy=-10.0"
  [warmup8k]="--config.sac.actor_warmup_steps=8000"
  [calm]="--config.sac.learning_rate.actor=1e-4 --config.sac.target_entropy=-10.0 --config.sac.actor_warmup_steps=8000"
  [updates8]="--config.sac.updates_per_step=8"
  [updates8_warmup4k]="--config.sac.updates_per_step=8 --config.sac.actor_warmup_steps=4000"
  [updates12]="--config.sac.updates_per_step=12"
  [updates8_envs16]="--config.sac.updates_per_step=8 --config.sac.num_envs=16"
  [scratch]="--config.env.action_centre=search --config.env.survival_min_speed=0.1
    --config.sac.gait_search.num_candidates=256 --config.sac.gait_search.robots_per_candidate=1
    --config.sac.gait_search.rounds=4"
)
# EXTRA="flags" are added to every run.
SEEDS=${SEEDS:-0 1 2}
names=("$@")
[ ${#names[@]} -gt 0 ] || names=("${!VARIANTS[@]}")
cores=$(nproc)
slots=$(( cores / 2 ))
mkdir -p "$out"
run() {  # VARIANT SEED SLOT
  local name=$1_s$2 first=$(( $3 * 2 )) start=$(date +%s)
  mkdir -p "$out/$name"
  JAX_PLATFORMS=cpu taskset -c $first,$(( first + 1 )) python3 -m quadcos.train --preset=cpu \
    --terrain=flat --seed="$2" --no_progress --output_dir="/tmp/sweep_runs/$name" \
    ${VARIANTS[$1]} ${EXTRA:-} > "$out/$name/train.log" 2>&1
  local rc=$?
  cp /tmp/sweep_runs/$name/{config.json,metrics.jsonl} "$out/$name/" 2>/dev/null
  echo "$name exit $rc wall_s $(( $(date +%s) - start )) $(python3 -c "
import json, sys
evals = [json.loads(l) for l in open(sys.argv[1]) if 'eval/forward_speed' in l]
print(' '.join(f\"{e['step']}:{e['eval/forward_speed']:.3f}/{e['eval/fall_rate']:.2f}\" for e in evals))
" "$out/$name/metrics.jsonl" 2>/dev/null)" >> "$out/summary.txt"
}
queue=()
for entry in "${names[@]}"; do
  v=${entry%%:*}
  [ -n "${VARIANTS[$v]+x}" ] || { echo "sweep.sh: unknown variant '$v' (known: ${!VARIANTS[*]})" >&2; exit 2; }
  if [[ $entry == *:* ]]; then queue+=("$v ${entry#*:}"); else for s in $SEEDS; do queue+=("$v $s"); done; fi
done
for job in "${queue[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$slots" ]; do sleep 2; done
  # The slot: the lowest one no running job holds.
  for ((slot = 0; slot < slots; slot++)); do [ -e "$out/.slot$slot" ] || break; done
  touch "$out/.slot$slot"
  (run $job $slot; rm -f "$out/.slot$slot") &
  sleep 1
done
wait
echo "sweep done: ${#queue[@]} runs" >> "$out/summary.txt"
