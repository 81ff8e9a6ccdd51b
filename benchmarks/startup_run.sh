#!/usr/bin/env bash
# Start-up of `python -m quadcos.train` on one GPU (after `source experiments/gpu_setup.sh`,
# warp-lang installed), process start -> the first training chunk, as each run's startup.json
# records it: this tree (/tmp/new: `git archive HEAD quadcos models pyproject.toml`) and
# BASE (/tmp/base: the same of a revision to compare with, e.g. the one before a start-up change).
#   cold: the run's whole cache folder (JAX's and Warp's kernels) emptied (three of each tree,
#   the last two alternating); jaxcold: JAX's cache emptied, Warp's kept (a machine that has run
#   quadcos before, under another JAX); warm: a run after them; BASE's rows only where /tmp/base
#   exists. any_cold, base_any_cold (ANY_COLD=0 skips them): `--preset=any_slope` from empty
#   caches (its gait search included).
# $O/NAME.startup.json, NAME.log (with --verbose: Warp's module loads and their seconds), status.
# Then: python -m quadcos.results record --name startup_h100 ... $O/*.startup.json (its device)
set -u
O=${OUT:-/tmp/su}; mkdir -p "$O"
run() {  # TREE NAME CACHE FLAGS...
  local tree=$1 name=$2 cache=$3; shift 3
  local t0; t0=$(date +%s.%N)
  (cd "$tree" && PYTHONPATH=/tmp/site:$tree QUADCOS_CACHE_DIR=$cache timeout 280 \
    python3 -m quadcos.train "$@" --no_progress --verbose --output_dir="/tmp/sr/$name" \
    > "$O/$name.log" 2>&1)
  echo "$(date +%T) $name rc=$? wall $(python3 -c "print(round($(date +%s.%N) - $t0, 2))") s" \
    >> "$O/status"
  cp "/tmp/sr/$name/startup.json" "$O/$name.startup.json" 2>/dev/null
}
F="--preset=gpu --terrain=flat --num_timesteps=100000"
rm -rf /tmp/cn; run /tmp/new new_cold /tmp/cn $F; run /tmp/new new_warm1 /tmp/cn $F
run /tmp/new new_warm2 /tmp/cn $F
rm -rf /tmp/cn/jax; run /tmp/new new_jaxcold /tmp/cn $F
if [ -d /tmp/base ]; then  # BASE's rows only where its tree was unpacked
  rm -rf /tmp/cb; run /tmp/base base_cold /tmp/cb $F; run /tmp/base base_warm1 /tmp/cb $F
  for i in 2 3; do  # two more cold starts of each, alternating (a cold start varies by seconds)
    rm -rf /tmp/cb; run /tmp/base "base_cold$i" /tmp/cb $F
    rm -rf /tmp/cn; run /tmp/new "new_cold$i" /tmp/cn $F
  done
fi
if [ "${ANY_COLD:-1}" = 1 ]; then  # a searching run from empty caches, this tree then BASE
  A="--preset=any_slope --num_timesteps=100000"
  rm -rf /tmp/ca; run /tmp/new any_cold /tmp/ca $A
  [ -d /tmp/base ] && { rm -rf /tmp/ca; run /tmp/base base_any_cold /tmp/ca $A; }
fi
echo "$(date +%T) done" >> "$O/status"
