#!/usr/bin/env bash
# `--preset=any_slope` on a host of one or more GPUs, one run per GPU, from the repository root
# (after `source experiments/gpu_setup.sh`), for the cold / warm seeds table (README.md):
#   bash experiments/any_slope/run_gpu.sh train MODE SEED...     # start the runs, return
#   bash experiments/any_slope/run_gpu.sh wait MODE SEED...      # until they have ended
#   bash experiments/any_slope/run_gpu.sh evaluate MODE SEED...  # test set 2026, slope5, S-4, flat
#   bash experiments/any_slope/run_gpu.sh summary MODE SEED...   # $OUT/seeds_MODE.json, NAME.tgz
#   bash experiments/any_slope/run_gpu.sh all MODE SEED...       # the four, from the copy in /tmp/qa
#                                                                # (start it detached: setsid)
#   bash experiments/any_slope/run_gpu.sh population MODE SIZE SEED  # --population=SIZE, 300 s
# MODE cold: each run's compilation caches (JAX's and Warp's, QUADCOS_CACHE_DIR) are deleted
# first, as on a fresh machine; warm: the same folder as that seed's cold run left it, as a user's
# second run finds it. Runs are any_slope_MODE_sSEED, 300 s from process start each
# (`--max_seconds`), on GPUs FIRST_GPU, FIRST_GPU + 1, ... They work from a copy of the tree under
# /tmp/qa (a later device call may bring another tree); their folders and evaluations under
# /tmp/qa_out, the layout seeds.py reads; summary copies what to commit to $OUT. ANY_FLAGS: train
# flags on top; EVAL_ENVS, EVAL_SECONDS: every evaluation's episodes and length instead of the
# table's (a dry run on a CPU: tiny sizes in ANY_FLAGS, EVAL_ENVS=4 EVAL_SECONDS=1).
set -uo pipefail
# shellcheck disable=SC2086  # ANY_FLAGS: several flags
verb=${1:?usage: run_gpu.sh train|wait|evaluate|summary|population cold|warm SEED...}
mode=${2:?MODE: cold or warm}; shift 2
[[ $mode =~ ^(cold|warm)$ ]] || { echo "MODE is cold or warm, not '$mode'" >&2; exit 2; }
for seed in "$@"; do
  [[ $seed =~ ^[0-9]+$ ]] || { echo "bad SEED '$seed': a non-negative integer" >&2; exit 2; }
done
dir=/tmp/qa_out; mkdir -p "$dir/runs"
gpus=$(nvidia-smi -L 2>/dev/null | wc -l); [ "$gpus" -gt 0 ] || gpus=1
first=${FIRST_GPU:-0}
gpu() { echo $(( (first + $1) % gpus )); }

case $verb in
train)
  [ -d /tmp/qa ] || { mkdir -p /tmp/qa && cp -r quadcos models experiments pyproject.toml /tmp/qa/; }
  i=0
  for seed in "$@"; do
    name=any_slope_${mode}_s$seed cache=/tmp/qa_cache/s$seed
    [ "$mode" = cold ] && rm -rf "$cache"
    rm -rf "${dir:?}/runs/$name"
    (cd /tmp/qa && CUDA_VISIBLE_DEVICES=$(gpu $i) QUADCOS_CACHE_DIR=$cache \
      setsid nohup python3 -m quadcos.train --preset=any_slope --seed="$seed" --max_seconds=300 \
      --output_dir="$dir/runs/$name" --no_progress ${ANY_FLAGS:-} > "$dir/$name.log" 2>&1 \
      < /dev/null &)
    echo "$(date +%T) $name on GPU $(gpu $i), caches $cache"
    i=$((i + 1))
  done ;;
wait)
  for seed in "$@"; do
    name=any_slope_${mode}_s$seed
    while [ ! -s "$dir/$name.log" ] || pgrep -f "output_dir=$dir/runs/$name " > /dev/null; do
      sleep 5
    done
    echo "$(date +%T) $name ended: $(tail -n 1 "$dir/$name.log")"
  done ;;
evaluate)
  i=0
  for seed in "$@"; do
    name=any_slope_${mode}_s$seed
    best=$dir/runs/$name/policy_best
    (
      export CUDA_VISIBLE_DEVICES=$(gpu $i) QUADCOS_CACHE_DIR=/tmp/qa_cache/s$seed
      cd /tmp/qa || exit 1
      for course in "testset2026 testset:2026 4288 40" "slope5 slope5 1024 40" "s4 s4 1024 30" \
        "flat flat 1024 20"; do
        read -r key terrain n secs <<< "$course"
        [ -s "$dir/eval_${name}_$key.json" ] && continue  # done by an earlier call
        python3 -m quadcos.evaluate --no_progress --policy="$best" --terrain="$terrain" \
          --num_envs="${EVAL_ENVS:-$n}" --seconds="${EVAL_SECONDS:-$secs}" \
          --out="$dir/eval_${name}_$key.json" \
          > "$dir/eval_${name}_$key.log" 2>&1
        echo "$(date +%T) $name $key: exit $? $(tail -n 1 "$dir/eval_${name}_$key.log")"
      done
    ) &
    i=$((i + 1))
  done
  wait ;;
summary)
  out=${OUT:-/tmp/qa_summary}; mkdir -p "$out"
  python3 experiments/any_slope/seeds.py "$dir" --runs "any_slope_${mode}_s[0-9]+" \
    --out "$out/seeds_$mode.json"
  for seed in "$@"; do
    name=any_slope_${mode}_s$seed
    tar -C "$dir" -czf "$out/$name.tgz" --exclude='*/checkpoints' "runs/$name" "$name.log" \
      $(cd "$dir" && ls eval_"${name}"_*) 2>/dev/null
  done ;;
population)  # MODE SIZE SEED: `--population=SIZE` from seed SEED (cold: caches deleted first) on
  # GPUs 0..SIZE-1, each member's policy_best on test set 2026 and flat, then $OUT/popSIZE_sSEED.json
  # (population.json) and popSIZE_sSEED_members.json (seeds.py's rows of the members)
  size=${1:?SIZE} seed=${2:?SEED} out=${OUT:-/tmp/qa_summary}; mkdir -p "$out"
  name=pop${size}_s$seed run=$dir/pop/pop${size}_s$seed cache=/tmp/qa_cache/$name
  [ "$mode" = cold ] && rm -rf "$cache"
  rm -rf "$run" "$dir/pop/runs"; mkdir -p "$dir/pop/runs"
  QUADCOS_CACHE_DIR=$cache CUDA_VISIBLE_DEVICES=$(seq -s, 0 $((size - 1))) python3 -m quadcos.train \
    --preset=any_slope --population="$size" --seed="$seed" \
    --max_seconds=300 --output_dir="$run" --no_progress ${ANY_FLAGS:-} > "$dir/pop/$name.log" 2>&1
  echo "$(date +%T) $name: exit $? $(tail -n 1 "$dir/pop/$name.log")"
  for ((i = 0; i < size; i++)); do
    member=${name}_m$i
    cp -r "$run/member_$i" "$dir/pop/runs/$member"
    (
      export CUDA_VISIBLE_DEVICES=$i QUADCOS_CACHE_DIR=$cache
      for course in "testset2026 testset:2026 4288 40" "flat flat 1024 20"; do
        read -r key terrain n secs <<< "$course"
        python3 -m quadcos.evaluate --no_progress --policy="$run/member_$i/policy_best" \
          --terrain="$terrain" --num_envs="${EVAL_ENVS:-$n}" --seconds="${EVAL_SECONDS:-$secs}" \
          --out="$dir/pop/eval_${member}_$key.json" > "$dir/pop/eval_${member}_$key.log" 2>&1
      done
    ) &
  done
  wait
  cp "$run/population.json" "$out/$name.json"
  python3 experiments/any_slope/seeds.py "$dir/pop" --runs "${name}_m[0-9]+" \
    --out "$out/${name}_members.json" ;;
all)
  bash "$0" train "$mode" "$@" || exit
  [ -d /tmp/qa ] && cd /tmp/qa && export PYTHONPATH=/tmp/site:/tmp/qa
  script=/tmp/qa/experiments/any_slope/run_gpu.sh
  for step in wait evaluate summary; do OUT=/tmp/qa_summary bash "$script" $step "$mode" "$@"; done
  echo "$(date +%T) all done" ;;
*) echo "unknown verb $verb" >&2; exit 2 ;;
esac
