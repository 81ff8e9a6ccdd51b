#!/usr/bin/env bash
# --preset=any_slope on the jax path (`warp.graph_mode=jax`, `graph_conditional=false`), 120 s
# each (seed 99, an evaluation every 2 M env steps), killed at 170 s: as the code ships, with
# branches back in XLA's command buffers (COND=1), and with those and serial scheduling (SERIAL=1).
# One GPU, after `source experiments/gpu_setup.sh` with warp-lang installed; run from the project
# root; writes $OUT/probe_*.log. Warp's kernels must be in its cache already (any earlier Warp run
# on the machine), or compiling them takes the first run's budget.
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
FAST="--config.env.warp.graph_mode=jax --config.env.warp.graph_conditional=false"
v() { local name=$1; shift
  env "$@" DUMP_EVERY=50 timeout -s KILL 170 python3 benchmarks/h100/gait/any_slope/probe.py \
    --preset=any_slope --seed=99 --max_seconds=120 --output_dir=/tmp/probe_runs/$name \
    --config.sac.eval_interval=2000000 $FAST 2>&1 | grep -v "^Module" > $O/probe_$name.log
  cp /tmp/probe_runs/$name/startup.json $O/probe_$name.startup.json
  echo "$(date +%T) $name: $(grep -c '^step' $O/probe_$name.log) evaluations;" \
    "$(grep '^step' $O/probe_$name.log | tail -n 1)"; }
v shipped X=1
v conditional COND=1
v conditional_serial COND=1 SERIAL=1
