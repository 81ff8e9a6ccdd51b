#!/usr/bin/env bash
# `make train` three times on a fresh clone (seeds 0, 1, 2, one after another, nothing else
# running), as the README's "Learning to walk" measures it. Usage, from a clone's root:
#   bash experiments/make_train/run_three.sh OUT_DIR
# OUT_DIR gets times.txt (the install's and each run's wall seconds) and seed<S>.log (make's output).
set -uo pipefail
out=$1
mkdir -p "$out"
start=$(date +%s); make install > "$out/install.log" 2>&1
echo "install exit $? wall_s $(( $(date +%s) - start ))" >> "$out/times.txt"
for s in 0 1 2; do
  start=$(date +%s)
  make train TRAIN_ARGS="--seed=$s --no_progress" > "$out/seed$s.log" 2>&1
  echo "seed $s exit $? wall_s $(( $(date +%s) - start ))" >> "$out/times.txt"
done
