#!/usr/bin/env bash
# Start-up seconds of whole `python -m quadcos.train --preset=gpu --terrain=flat
# --num_timesteps=100000` processes on one GPU machine, the tree against BASE_TREE (another
# revision's `git archive REV quadcos models pyproject.toml`, run from its own tree; or this tree
# again, with NEW_FLAGS, train flags for this tree's runs only), with experiments/gpu_setup.sh sourced:
#   BASE_TREE=DIR [NEW_FLAGS=...] OUT=DIR bash benchmarks/h100/startup/before_after.sh
# A first run fills Warp's kernel cache; "cold": JAX's cache emptied (Warp's kept); "warm": the
# runs after it. $OUT/NAME.startup.json, NAME.log (stderr stamped with seconds since the process
# started), status (each process's wall time, start to exit).
set -u
O=$OUT
case $(realpath -m "$O") in /tmp/qc_startup|/tmp/qc_startup/*)  # the caches, emptied below
  echo "OUT=$O is the start-up runs' cache folder (/tmp/qc_startup): choose another" >&2; exit 2 ;;
esac
mkdir -p $O
note() { echo "$(date +%T) $*" >> $O/status; }
ARGS="--preset=gpu --terrain=flat --num_timesteps=100000 --no_progress"
run() {  # TREE NAME [train flags]
  local tree=$1 name=$2; shift 2
  local t0=$(date +%s.%N)
  (cd $tree && PYTHONPATH=/tmp/site:$tree python3 -m quadcos.train $ARGS "$@" \
    --output_dir=/tmp/quadcos_runs/$name 2>&1 | python3 -u -c "
import sys, time
t0 = $t0
for line in sys.stdin:
    if not line.startswith('Module '):
        print(f'{time.time() - t0:7.2f} {line}', end='')" > $O/$name.log)
  local t1=$(date +%s.%N)
  cp /tmp/quadcos_runs/$name/startup.json $O/$name.startup.json
  note "$name process wall $(python3 -c "print(round($t1 - $t0, 2))") s"
}
NEW=$PWD BASE=${BASE_TREE:?a tree of the revision to compare with}
export QUADCOS_CACHE_DIR=/tmp/qc_startup
rm -rf /tmp/qc_startup
run $BASE fill
rm -rf /tmp/qc_startup/jax; run $BASE cold_base
run $BASE warm_base1; run $BASE warm_base2
read -ra NEW_ARGS <<< "${NEW_FLAGS:-}"
rm -rf /tmp/qc_startup/jax; run $NEW cold_new "${NEW_ARGS[@]}"
run $NEW warm_new1 "${NEW_ARGS[@]}"; run $NEW warm_new2 "${NEW_ARGS[@]}"; run $NEW warm_new3 "${NEW_ARGS[@]}"
rm -rf /tmp/qc_startup/jax; run $NEW cold_new2 "${NEW_ARGS[@]}"; run $NEW warm_new4 "${NEW_ARGS[@]}"
