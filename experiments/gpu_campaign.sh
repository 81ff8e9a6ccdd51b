#!/usr/bin/env bash
# One GPU lease's campaign (session 8: issue 14, one policy for any slope, on one H100), started
# detached so that it outlives the device calls that poll it (each call returns within 10 minutes):
#   setsid nohup bash experiments/gpu_campaign.sh > /tmp/campaign.log 2>&1 < /dev/null &
#   bash experiments/gpu_poll.sh 540      # in each later call: waits, copies finished phases to $OUT
# Each phase leaves /tmp/campaign/<phase>.tar.gz. (Earlier sessions' campaigns are this file's
# previous versions in git.)
#
# 1. any_slope: the generalist, trained on the random course family (64 lanes, slopes up to 12°,
#    3–5 sections of 1–3 m) with the course curriculum and spawns along each course, 12 minutes
#    capped (compilation included); then evaluated on the held-out test set testset:2026 (64
#    courses + flat, slope5, s4; 64 episodes a course) and on slope5, s4 and flat (1024 each).
# 2. slope5: experiments/policies/slope5 retrained with spawns along the course (the command of
#    experiments/slope5/README.md plus --config.env.spawn_x_max=10), evaluated the same way.
set -uo pipefail
source experiments/gpu_setup.sh || exit 1
C=/tmp/campaign
mkdir -p $C
note() { echo "$(date +%T) $*" | tee -a $C/status; }
pack() { tar czf $C/$1.tar.gz -C $C $1 && note "$1 done"; }
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $C/gpu.txt
python3 -c "import jax, mujoco, warp; print(jax.__version__, mujoco.__version__, warp.__version__, jax.devices())" >> $C/gpu.txt 2>&1
evaluate() {  # DIR POLICY NAME TERRAIN NUM_ENVS SECONDS [more flags]: one evaluation, JSON + log
  local dir=$1 policy=$2 name=$3 terrain=$4 n=$5 secs=$6; shift 6
  python3 -m quadcos.evaluate --no_progress --num_envs="$n" --policy="$policy" \
    --terrain="$terrain" --seconds="$secs" --out="$dir/eval_$name.json" "$@" > "$dir/eval_$name.log" 2>&1
  note "eval $name: exit $? $(tail -n 1 "$dir/eval_$name.log")"
}
evaluate_all() {  # DIR POLICY PREFIX: the test set, slope5, s4 (traced) and flat
  local dir=$1 policy=$2 prefix=$3
  evaluate "$dir" "$policy" "${prefix}_testset" testset:2026 4288 40
  evaluate "$dir" "$policy" "${prefix}_slope5" slope5 1024 40 --trace="$dir/trace_${prefix}_slope5.json"
  evaluate "$dir" "$policy" "${prefix}_s4" s4 1024 30 --trace="$dir/trace_${prefix}_s4.json"
  evaluate "$dir" "$policy" "${prefix}_flat" flat 1024 10
}

PHASES=${PHASES:-generalist slope5}  # PHASES=alive: only the ablation 3 (a second lease)
if [[ " $PHASES " == *" alive "* ]]; then
  # 3. Ablation: the generalist with r_s for every step alive (the other reading of §3.3), 600 s.
  V=$C/any_slope_alive
  mkdir -p $V
  OUT=$V TRAIN_SECONDS=600 bash experiments/train_gpu.sh any_slope_alive_s0 \
    "--terrain=random:max_deg=12,sections=3-5,len=1-3,seed=0" --config.sac.episode_length=400 \
    --config.env.spawn_x_max=20 --seed=0 \
    --config.sac.eval_interval=10000000 --config.sac.num_timesteps=400000000
  note "any_slope_alive_s0 trained: $(tail -n 1 $V/runs/any_slope_alive_s0/train.log)"
  evaluate_all $V $V/runs/any_slope_alive_s0/policy any_slope_alive
  pack any_slope_alive
  note "campaign done"
  exit 0
fi

# 1. The generalist.
A=$C/any_slope
mkdir -p $A
OUT=$A TRAIN_SECONDS=720 bash experiments/train_gpu.sh any_slope_s0 \
  "--terrain=random:max_deg=12,sections=3-5,len=1-3,seed=0" --config.sac.episode_length=400 \
  --config.env.spawn_x_max=20 --config.env.survival_min_speed=0.1 --seed=0 \
  --config.sac.eval_interval=10000000 --config.sac.num_timesteps=400000000
note "any_slope_s0 trained: $(tail -n 1 $A/runs/any_slope_s0/train.log)"
evaluate_all $A $A/runs/any_slope_s0/policy any_slope
evaluate $A experiments/policies/slope5 committed_slope5_testset testset:2026 4288 40
pack any_slope

# 2. slope5 retrained with spawns along the course.
S=$C/slope5
mkdir -p $S
OUT=$S TRAIN_SECONDS=240 bash experiments/train_gpu.sh slope5_spawn_s0 \
  "--terrain=sections:5@3,0@3,-5@3;run_out=10" --config.sac.episode_length=400 --seed=0 \
  --config.env.spawn_x_max=10
note "slope5_spawn_s0 trained: $(tail -n 1 $S/runs/slope5_spawn_s0/train.log)"
evaluate_all $S $S/runs/slope5_spawn_s0/policy slope5_spawn
pack slope5
note "campaign done"
