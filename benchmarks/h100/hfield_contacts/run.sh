#!/usr/bin/env bash
# What rows for 24 heightfield contacts cost against 14: MJX-Warp physics and env steps of 4096
# robots on slope5, Go1 and ANYmal C, each setting in its own bench process, one GPU.
#   MENAGERIE_ROOT=DIR bash benchmarks/h100/hfield_contacts/run.sh   (writes $OUT/*.json, *.log)
set -uo pipefail
out=${OUT:-/tmp/quadcos_out}/hfield_contacts
mkdir -p "$out"
for robot in ${ROBOTS:-unitree_go1 anybotics_anymal_c}; do
  for contacts in 14 24; do
    python3 -m quadcos.bench --robot=menagerie:$robot --terrain=slope5 --impl=warp \
      --only=physics,env --env_counts=4096 --steps=20 --env warp.hfield_contacts=$contacts \
      --out="$out/${robot}_$contacts.json" > "$out/${robot}_$contacts.log" 2>&1
    echo "$robot $contacts: exit $? $(grep -E 'physics 4096|env 4096' "$out/${robot}_$contacts.log" | tr '\n' ' ')"
  done
done
