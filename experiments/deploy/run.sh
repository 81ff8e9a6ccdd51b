#!/usr/bin/env bash
# The deploy path on a CPU: export the pretrained flat, flat_robust and slope5 policies to ONNX, then run each
# file with ONNX Runtime in C MuJoCo (python -m quadcos.sim2sim) on its terrain, nominal, under 20
# and 40 ms of control latency and with observation noise. Two runs at a time (2 cores).
#   bash experiments/deploy/run.sh OUT        # OUT: a folder for the .onnx files and the JSONs
#   python experiments/deploy/table.py OUT    # the table of experiments/deploy/README.md
set -euo pipefail
out=${1:?usage: run.sh OUT}
mkdir -p "$out"
for policy in flat flat_robust slope5; do
  python -m quadcos.export --policy="experiments/policies/$policy" --out="$out/$policy.onnx"
done
run() {  # POLICY TERRAIN SECONDS NAME FLAGS...
  local policy=$1 terrain=$2 seconds=$3 name=$4; shift 4
  python -m quadcos.sim2sim --no_progress --policy="$out/$policy.onnx" --terrain="$terrain" \
    --episodes=64 --seconds="$seconds" --out="$out/${policy}_${terrain}_$name.json" "$@" \
    > "$out/${policy}_${terrain}_$name.log" 2>&1
  tail -n 1 "$out/${policy}_${terrain}_$name.log"
}
for case in "flat flat 20" "flat_robust flat 20" "slope5 slope5 30"; do
  set -- $case
  run "$1" "$2" "$3" nominal &
  run "$1" "$2" "$3" latency20 --latency_ms=20
  wait
  run "$1" "$2" "$3" latency40 --latency_ms=40 &
  run "$1" "$2" "$3" noise --obs_noise=0.02
  wait
done
