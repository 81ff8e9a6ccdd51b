#!/usr/bin/env bash
# Runs one experiment on a GPU machine, from the repository root:
#   bash experiments/run_gpu.sh EXPERIMENT
# EXPERIMENT: flat | reward_xy | drl_only | from_scratch | slope5 | any_slope | any_slope_seeds |
#   robustness | robust_scratch | fixed_params | warp | scaling | bench_slope5 | robots |
#   robots_alone | anymal | anymal_slope5 | anymal_any_slope | profile | imports | startup |
#   randomized (scaling needs 2 GPUs, or 4 with SCALING_DEVICES="2 4"; robots*, anymal* need
#   MENAGERIE_ROOT, a folder of MuJoCo Menagerie's robot XMLs).
# Its files go to $OUT/EXPERIMENT (default /tmp/quadcos_out): runs/NAME/ (config.json,
# metrics.jsonl, train.log, gait_search.json, policy/, policy_best/), eval_*.json with their logs
# and traces, status (one line per step). Copy the summaries into experiments/EXPERIMENT.
# SEEDS overrides the seeds (default "0 1 2"; any_slope: "0"). Each training run is capped by the
# wall time given below (SIGTERM: the trainer checkpoints, saves its policy and stops).
set -uo pipefail
experiment=${1:?usage: run_gpu.sh EXPERIMENT}
source experiments/gpu_setup.sh || exit 1
export OUT=${OUT:-/tmp/quadcos_out}/$experiment
mkdir -p "$OUT"
note() { echo "$(date +%T) $*" | tee -a "$OUT/status"; }
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$OUT/gpu.txt"
python3 -c "import jax, mujoco; print(jax.__version__, mujoco.__version__, jax.devices())" >> "$OUT/gpu.txt" 2>&1

train() {  # SECONDS NAME [train flags]: one training run (experiments/train_gpu.sh)
  local seconds=$1 name=$2; shift 2
  TRAIN_SECONDS=$seconds bash experiments/train_gpu.sh "$name" "$@"
  note "$name trained: $(tail -n 1 "$OUT/runs/$name/train.log")"
  [ -d "/tmp/quadcos_runs/$name/policy_best" ] && cp -r "/tmp/quadcos_runs/$name/policy_best" "$OUT/runs/$name/"
}
evaluate() {  # POLICY NAME TERRAIN NUM_ENVS SECONDS [more flags]: eval_NAME.json and .log
  local policy=$1 name=$2 terrain=$3 n=$4 secs=$5; shift 5
  python3 -m quadcos.evaluate --no_progress --num_envs="$n" --policy="$policy" --terrain="$terrain" \
    --seconds="$secs" --out="$OUT/eval_$name.json" "$@" > "$OUT/eval_$name.log" 2>&1
  note "eval $name: exit $? $(tail -n 1 "$OUT/eval_$name.log")"
}
SCRATCH=(--config.env.action_centre=search --config.env.survival_min_speed=0.1)  # = --preset=scratch
SLOPE5_COURSE=("--terrain=sections:5@3,0@3,-5@3;run_out=10" --config.sac.episode_length=400)

case $experiment in
flat)  # Figs. 7-8: the trot start, --preset=gpu, 10 M env steps
  for s in ${SEEDS:-0 1 2}; do
    train 200 flat_s$s --terrain=flat --seed=$s
    evaluate "$OUT/runs/flat_s$s/policy" flat_s$s flat 1024 20 --trace="$OUT/trace_flat_s$s.json"
  done ;;
reward_xy)  # Fig. 9: r_xy = r_x + r_y only
  train 200 xy_s0 --terrain=flat --reward=xy --seed=0
  evaluate "$OUT/runs/xy_s0/policy" xy_s0 flat 1024 20 --trace="$OUT/trace_xy_s0.json" ;;
drl_only)  # §5: SAC on the 8 joint targets; trot-start settings, then the from-scratch learner at 20 M
  train 230 joint_s0 --terrain=flat --controller=joint --seed=0
  evaluate "$OUT/runs/joint_s0/policy" joint_s0 flat 1024 20
  for s in ${SEEDS:-0 1 2}; do  # the three runs share the GPU
    XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 train 420 joint20_s$s --terrain=flat --seed=$s --controller=joint \
      --config.env.survival_min_speed=0.1 --config.sac.eval_interval=1000000 --num_timesteps=20000000 &
  done
  wait
  for s in ${SEEDS:-0 1 2}; do evaluate "$OUT/runs/joint20_s$s/policy" joint20_s$s flat 256 20; done ;;
from_scratch)  # Fig. 7 from scratch: --preset=scratch (gait search, then SAC, 20 M env steps)
  for s in ${SEEDS:-0 1 2}; do
    train 330 scratch_best_s$s --preset=scratch --terrain=flat --seed=$s
    evaluate "$OUT/runs/scratch_best_s$s/policy" scratch_best_s${s}_last flat 1024 20
    evaluate "$OUT/runs/scratch_best_s$s/policy_best" scratch_best_s${s}_best flat 1024 20
  done ;;
slope5)  # Figs. 11-19: slope5 from scratch, robots spawned along the course
  for s in ${SEEDS:-0 1 2}; do
    name=scratch_slope5_s$s
    train 480 $name "${SLOPE5_COURSE[@]}" --config.env.spawn_x_max=10 --seed=$s "${SCRATCH[@]}" \
      --config.sac.eval_interval=1000000
    evaluate "$OUT/runs/$name/policy" ${name}_slope5 slope5 1024 40 --trace="$OUT/trace_${name}_slope5.json"
    evaluate "$OUT/runs/$name/policy" ${name}_s4 s4 1024 30 --trace="$OUT/trace_${name}_s4.json"
    evaluate "$OUT/runs/$name/policy" ${name}_testset testset:2026 4288 40
    evaluate "$OUT/runs/$name/policy" ${name}_flat flat 1024 10
  done ;;
any_slope)  # one policy for any slope: hip offsets, with and without the r_y cap, 870 s each, one
  # lane of the curriculum a success (policies/any_slope)
  for s in ${SEEDS:-0}; do
    for variant in posture_cap posture; do
      name=${variant}_s$s extra=()
      [ $variant = posture ] && extra=(--config.env.forward_speed_cap=0)  # r_y uncapped
      train 930 $name --preset=any_slope "${extra[@]}" --seed=$s --max_seconds=870 \
        --config.sac.curriculum.promote_lanes=1 --config.env.start_ramp_s=0
      best=$OUT/runs/$name/policy_best
      evaluate "$best" ${name}_testset testset:2026 4288 40
      evaluate "$best" ${name}_slope5 slope5 1024 40 --trace="$OUT/trace_${name}_slope5.json"
      evaluate "$best" ${name}_s4 s4 1024 30 --trace="$OUT/trace_${name}_s4.json"
      evaluate "$best" ${name}_flat flat 1024 10
      evaluate "$best" ${name}_down11 "sections:0@1,-11@4,0@2" 1024 20
      evaluate "$OUT/runs/$name/policy" ${name}_last_testset testset:2026 4288 40
    done
  done
  for seed in 2027 4242; do
    evaluate experiments/policies/any_slope any_slope_testset$seed testset:$seed 4288 40
  done ;;
any_slope_seeds)  # --preset=any_slope as it ships, one run per seed with a time budget (ANY_S);
  # ANY_FLAGS: train flags on top (runs named any_slope${ANY_NAME}_sSEED). First a 120-s run
  # (seed 99, not reported; ANY_WARM=0 skips it) fills the compilation caches, so that every seed
  # starts with warm caches, as a user's second run does.
  # shellcheck disable=SC2086  # ANY_FLAGS: several flags
  [ "${ANY_WARM:-1}" = 1 ] && train 180 any_slope_warmup --preset=any_slope --seed=99 \
    --max_seconds=120 ${ANY_FLAGS:-}
  for s in ${SEEDS:-0 1 2}; do
    name=any_slope${ANY_NAME:-}_s$s
    # shellcheck disable=SC2086  # ANY_FLAGS: several flags
    train $((${ANY_S:-300} + 60)) $name --preset=any_slope --seed=$s --max_seconds=${ANY_S:-300} \
      ${ANY_FLAGS:-}
    best=$OUT/runs/$name/policy_best
    evaluate "$best" ${name}_testset2026 testset:2026 4288 40
    evaluate "$best" ${name}_slope5 slope5 1024 40
    evaluate "$best" ${name}_s4 s4 1024 30
    evaluate "$best" ${name}_flat flat 1024 20 --trace="$OUT/trace_${name}_flat.json"
  done
  for s in ${SEEDS:-0 1 2}; do  # the other held-out test sets last (ANY_EXTRA=0 skips them)
    for set in $([ "${ANY_EXTRA:-1}" = 1 ] && echo 2027 4242); do
      name=any_slope${ANY_NAME:-}_s$s
      evaluate "$OUT/runs/$name/policy_best" ${name}_testset$set testset:$set 4288 40
    done
  done
  python3 experiments/any_slope/seeds.py "$OUT" --runs "any_slope${ANY_NAME:-}_s[0-9]+" --out "$OUT/seeds.json"
  python3 experiments/any_slope/falls.py "$OUT"/eval_any_slope${ANY_NAME:-}_s*_testset2026.json \
    --keep "$OUT" > "$OUT/falls.md" ;;  # where they fall; the kept episodes: *.episodes.json.gz
robust_scratch)  # a flat policy from nothing (--preset=scratch) trained with randomisation and
  # observation noise, then measured under the robustness conditions
  name=robust_scratch${ROBUST_NAME:-}_s${SEEDS:-0}
  train $((${ROBUST_S:-300} + 60)) $name --preset=scratch --terrain=flat --seed=${SEEDS:-0} \
    --max_seconds=${ROBUST_S:-300} --config.env.randomization.enabled=True \
    --config.env.randomization.obs_noise=0.02 ${ROBUST_FLAGS:-}
  for kept in policy_best policy; do  # the kept policy, then the last one (file name _last)
    label=$name; [ $kept = policy ] && label=${name}_last
    python3 experiments/robustness/measure.py --policy="$OUT/runs/$name/$kept" --num_envs=1024 \
      --conditions nominal "latency 40 ms" "pushes 50 N, 0.1 s" "friction 0.4" \
      --out="$OUT/$label.json" > "$OUT/$label.log" 2>&1
    note "measured $label: exit $? $(tail -n 6 "$OUT/$label.log" | tr '\n' ' ')"
  done ;;
robustness)  # trained with domain randomisation vs without, under fixed perturbations
  train 330 flat_randomized_s0 --terrain=flat --seed=0 --config.env.impl=jax \
    --config.env.randomization.enabled=True
  python3 experiments/robustness/measure.py --policy="$OUT/runs/flat_randomized_s0/policy" \
    --num_envs=1024 --out="$OUT/flat_trained_with.json" > "$OUT/flat_trained_with.log" 2>&1
  python3 experiments/robustness/measure.py --policy=experiments/policies/flat --num_envs=1024 \
    --out="$OUT/flat_trained_without.json" > "$OUT/flat_trained_without.log" 2>&1
  python3 experiments/robustness/measure.py --table "$OUT/flat_trained_without.json" "$OUT/flat_trained_with.json" ;;
fixed_params)  # Fig. 15: the search for the best fixed parameters, and FIXED_TROT
  python3 -m quadcos.evaluate --no_progress --search_fixed --terrain=flat --num_candidates=512 \
    --robots_per_candidate=8 --rounds=3 --seconds=25 --out="$OUT/fixed_search_flat.json"
  best=fixed:0.415688,0.13653,0.539947,1.63701,-1.50056
  evaluate $best flat flat 1024 20 --trace="$OUT/trace_flat.json"
  evaluate $best slope5 slope5 1024 40 --trace="$OUT/trace_slope5.json"
  evaluate fixed:trot trot_flat flat 1024 20
  evaluate fixed:trot trot_slope5 slope5 1024 40 --trace="$OUT/trace_trot_slope5.json" ;;
warp)  # MJX-JAX vs MJX-Warp parity, start-up (warp-lang installed)
  bash experiments/warp/run_gpu.sh ;;
scaling)  # data-parallel training over N GPUs vs 1 (quadcos.bench); IMPL=warp for MJX-Warp.
  # SCALING_ROWS: the one-GPU train rows (ENVSxBATCHxUPDATES); N GPUs (SCALING_DEVICES, default
  # "2"; "2 4" on a host of four) run each with N times the envs and batch (equal per-GPU work),
  # every row SCALING_SECONDS long (default 30). SCALING_CROSS=0 leaves out the
  # time-to-cross-slope5 runs. SCALING_PROCESSES=1: the N-GPU rows as N processes of a GPU each.
  export NCCL_NVLS_ENABLE=0 PYTHONFAULTHANDLER=1
  rows1=${SCALING_ROWS:-4096x8192x8,8192x8192x8}
  rows() {  # N: the one-GPU rows scaled N times
    local row envs batch updates out=""
    IFS=, read -ra one <<< "$rows1"
    for row in "${one[@]}"; do
      IFS=x read -r envs batch updates <<< "$row"
      out+="${out:+,}$(($1 * envs))x$(($1 * batch))x$updates"
    done
    echo "$out"
  }
  bench() {  # NAME ARGS...
    local name=$1; shift
    python3 -m quadcos.bench --train_seconds "${SCALING_SECONDS:-30}" --walk_timeout_s 480 \
      --impl "${IMPL:-jax}" --out "$OUT/$name.json" "$@" > "$OUT/$name.log" 2>&1
    note "$name: exit $?"
  }
  if [ "${SCALING_CROSS:-1}" = 1 ]; then
    CUDA_VISIBLE_DEVICES=0 bench slope5cross_1dev --num_devices 1 --only slope5 &
    CUDA_VISIBLE_DEVICES=1 bench flat_1dev --num_devices 1 --only train --terrain flat --train_rows "$rows1"
  else
    CUDA_VISIBLE_DEVICES=0 bench flat_1dev --num_devices 1 --only train --terrain flat --train_rows "$rows1" &
  fi
  CUDA_VISIBLE_DEVICES=1 bench slope5_1dev --num_devices 1 --only train --terrain slope5 --train_rows "$rows1"
  wait
  processes() {  # N TERRAIN: the N-GPU rows as N processes of one GPU each (jax.distributed)
    local n=$1 terrain=$2 port=$((20000 + RANDOM % 20000)) i
    for ((i = 0; i < n; i++)); do
      CUDA_VISIBLE_DEVICES=$i bench ${terrain}_${n}proc$i --num_devices "$n" --only train \
        --terrain "$terrain" --train_rows "$(rows "$n")" --coordinator "localhost:$port" \
        --num_processes "$n" --process_id "$i" &
    done
    wait
    mv "$OUT/${terrain}_${n}proc0.json" "$OUT/${terrain}_${n}proc.json"  # process 0's: the record
  }
  if [ "${SCALING_PROCESSES:-0}" = 1 ]; then  # a process per GPU instead of one for all
    for n in ${SCALING_DEVICES:-2}; do processes "$n" flat; processes "$n" slope5; done
    python3 -m quadcos.benchmarking.scaling --out "$OUT/scaling.json" "$OUT"/*_1dev.json \
      "$OUT"/*_?proc.json > "$OUT/table.md" 2>&1
  else
    for n in ${SCALING_DEVICES:-2}; do
      export CUDA_VISIBLE_DEVICES=$(seq -s, 0 $((n - 1)))
      bench flat_${n}dev --num_devices "$n" --only train --terrain flat --train_rows "$(rows "$n")"
      [ "${SCALING_CROSS:-1}" = 1 ] && bench slope5cross_${n}dev --num_devices "$n" --only slope5
      bench slope5_${n}dev --num_devices "$n" --only train --terrain slope5 --train_rows "$(rows "$n")"
    done
    unset CUDA_VISIBLE_DEVICES
    python3 -m quadcos.benchmarking.scaling --out "$OUT/scaling.json" "$OUT"/*_?dev.json \
      > "$OUT/table.md" 2>&1
  fi ;;
bench_slope5)  # docs/benchmarks.md's slope5 rows: time until >= 99 % of 1024 episodes cross
  python3 -m quadcos.bench --preset=gpu --only=slope5 --walk_timeout_s=420 \
    --out="$OUT/bench_warp_slope5_scratch.json" > "$OUT/bench_warp_slope5_scratch.log" 2>&1
  python3 -m quadcos.bench --preset=gpu --only=slope5 --walk_training_preset=gpu --walk_timeout_s=240 \
    --out="$OUT/bench_warp_slope5_trot.json" > "$OUT/bench_warp_slope5_trot.log" 2>&1 ;;
robots)  # any quadruped from nothing: --preset=scratch with only --robot changed
  : "${MENAGERIE_ROOT:?set MENAGERIE_ROOT to a folder of MuJoCo Menagerie robots}"
  export MENAGERIE_ROOT
  # Raw physics of 4096 robots standing, both physics (this also fills Warp's kernel cache).
  for robot in unitree_go1 anybotics_anymal_c; do
    for impl in warp jax; do
      python3 -m quadcos.bench --robot=menagerie:$robot --impl=$impl --only=physics \
        --env_counts=4096 --steps=20 --out="$OUT/bench_${robot}_$impl.json" \
        > "$OUT/bench_${robot}_$impl.log" 2>&1
      note "bench $robot $impl: exit $? $(grep -o '4096 envs: .*' "$OUT/bench_${robot}_$impl.log")"
    done
  done
  # Go1's first seed alone on the GPU; then the other robots and Go1's other seeds, four runs
  # sharing it (their times to walk are upper bounds on a run alone).
  train ${ALONE_S:-240} unitree_go1_s0 --preset=scratch --robot=menagerie:unitree_go1 --seed=0
  for run in anybotics_anymal_c:0 unitree_go2:0 unitree_go1:1 unitree_go1:2; do
    robot=${run%:*} seed=${run#*:}
    XLA_PYTHON_CLIENT_MEM_FRACTION=0.22 train ${SHARED_S:-360} ${robot}_s$seed --preset=scratch \
      --robot=menagerie:$robot --seed=$seed &
  done
  wait
  for run in "$OUT"/runs/*; do  # C MuJoCo on the host's CPUs while the GPU evaluates
    name=$(basename "$run")
    python3 -m quadcos.sim2sim --no_progress --policy="$run/policy_best" --terrain=flat \
      --episodes=64 --out="$OUT/sim2sim_${name}_flat.json" > "$OUT/sim2sim_${name}_flat.log" 2>&1 &
  done
  for run in "$OUT"/runs/*_s0; do
    name=$(basename "$run")
    evals=()
    XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 evaluate "$run/policy_best" ${name}_flat flat 1024 20 \
      --trace="$OUT/trace_${name}_flat.json" & evals+=($!)
    XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 evaluate "$run/policy_best" ${name}_slope5 slope5 1024 40 &
    evals+=($!)
    XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 evaluate "$run/policy_best" ${name}_s4 s4 1024 30 & evals+=($!)
    wait "${evals[@]}"
  done
  wait ;;
robots_alone)  # each run alone on the GPU: ANYmal C and Go1 / Go2 from nothing, Go1 on any slope
  : "${MENAGERIE_ROOT:?set MENAGERIE_ROOT to a folder of MuJoCo Menagerie robots}"
  export MENAGERIE_ROOT
  train $((${ANYMAL_S:-300} + 60)) anybotics_anymal_c_s0 --preset=scratch --robot=menagerie:anybotics_anymal_c \
    --seed=0 --max_seconds=${ANYMAL_S:-300}
  for run in unitree_go1:1 unitree_go1:2 unitree_go2:0; do
    robot=${run%:*} seed=${run#*:}
    train $((${SHORT_S:-90} + 60)) ${robot}_s$seed --preset=scratch --robot=menagerie:$robot --seed=$seed \
      --max_seconds=${SHORT_S:-90}
  done
  # Go1 on any slope trains while the GPU evaluates the runs above and the host's CPUs run them
  # in C MuJoCo (its time is not a target).
  XLA_PYTHON_CLIENT_MEM_FRACTION=0.6 train $((${ANY_S:-300} + 60)) unitree_go1_any_slope_s0 --preset=any_slope --robot=menagerie:unitree_go1 \
    --seed=0 --max_seconds=${ANY_S:-300} --config.sac.curriculum.promote_lanes=1 \
    --config.env.start_ramp_s=0 &  # as committed
  trainer=$!
  for name in anybotics_anymal_c_s0 unitree_go1_s1 unitree_go1_s2 unitree_go2_s0; do
    run=$OUT/runs/$name
    JAX_PLATFORMS=cpu python3 -m quadcos.sim2sim --no_progress --policy="$run/policy_best" --terrain=flat \
      --episodes=64 --out="$OUT/sim2sim_${name}_flat.json" > "$OUT/sim2sim_${name}_flat.log" 2>&1 &
  done
  export XLA_PYTHON_CLIENT_MEM_FRACTION=0.15
  evaluate "$OUT/runs/anybotics_anymal_c_s0/policy_best" anybotics_anymal_c_s0_flat flat 1024 20 \
    --trace="$OUT/trace_anybotics_anymal_c_s0_flat.json"
  evaluate "$OUT/runs/anybotics_anymal_c_s0/policy_best" anybotics_anymal_c_s0_slope5 slope5 1024 40
  evaluate "$OUT/runs/anybotics_anymal_c_s0/policy_best" anybotics_anymal_c_s0_s4 s4 1024 30
  wait $trainer
  best=$OUT/runs/unitree_go1_any_slope_s0/policy_best
  evaluate "$best" unitree_go1_any_slope_s0_slope5 slope5 1024 40
  evaluate "$best" unitree_go1_any_slope_s0_s4 s4 1024 30
  evaluate "$best" unitree_go1_any_slope_s0_flat flat 1024 20
  evaluate "$best" unitree_go1_any_slope_s0_testset testset:2026 4288 40
  JAX_PLATFORMS=cpu python3 -m quadcos.sim2sim --no_progress --policy="$best" --terrain=slope5 --episodes=64 \
    --seconds=40 --out="$OUT/sim2sim_unitree_go1_any_slope_s0_slope5.json" \
    > "$OUT/sim2sim_unitree_go1_any_slope_s0_slope5.log" 2>&1
  wait ;;
anymal_slope5)  # ANYmal C from nothing on slope5's sections (10-m run-out, spawns along them), as
  # unitree_go1_slope5_s0; then slope5, S-4 and flat, and slope5 in C MuJoCo. ANYMAL_FLAGS: train
  # flags on top (run anybotics_anymal_c_slope5${ANYMAL_NAME}_s0), e.g. the flat run's gait as the
  # action centre instead of a search on the slopes:
  # ANYMAL_NAME=_flatgait ANYMAL_FLAGS=--config.env.action_centre=-0.497199,0.419977,0.2018,3.41153,0.269936
  : "${MENAGERIE_ROOT:?set MENAGERIE_ROOT to a folder of MuJoCo Menagerie robots}"
  export MENAGERIE_ROOT
  name=anybotics_anymal_c_slope5${ANYMAL_NAME:-}_s0
  # shellcheck disable=SC2086  # ANYMAL_FLAGS: several flags
  train $((${ANYMAL_S:-420} + 60)) $name --preset=scratch --robot=menagerie:anybotics_anymal_c --seed=0 \
    "${SLOPE5_COURSE[@]}" --config.env.spawn_x_max=10 --max_seconds=${ANYMAL_S:-420} ${ANYMAL_FLAGS:-}
  best=$OUT/runs/$name/policy_best
  JAX_PLATFORMS=cpu python3 -m quadcos.sim2sim --no_progress --policy="$best" --terrain=slope5 \
    --episodes=64 --seconds=40 --out="$OUT/sim2sim_${name}_slope5.json" > "$OUT/sim2sim_${name}_slope5.log" 2>&1 &
  evaluate "$best" ${name}_slope5 slope5 1024 40 --trace="$OUT/trace_${name}_slope5.json"
  evaluate "$best" ${name}_s4 s4 1024 30
  evaluate "$best" ${name}_flat flat 1024 20
  wait ;;
anymal_any_slope)  # ANYmal C with --preset=any_slope (hip offsets, slope and phase observed,
  # the course curriculum) and a longer budget (ANYMAL_S, default 1200 s: ANYmal trains at a
  # quarter of Go1's rate); slope5, S-4, flat, the held-out test set, slope5 in C MuJoCo;
  # ANYMAL_NAME / ANYMAL_FLAGS as anymal_slope's
  : "${MENAGERIE_ROOT:?set MENAGERIE_ROOT to a folder of MuJoCo Menagerie robots}"
  export MENAGERIE_ROOT
  name=anybotics_anymal_c_any_slope${ANYMAL_NAME:-}_s0
  # shellcheck disable=SC2086  # ANYMAL_FLAGS: several flags
  train $((${ANYMAL_S:-1200} + 60)) $name --preset=any_slope --robot=menagerie:anybotics_anymal_c \
    --seed=0 --max_seconds=${ANYMAL_S:-1200} ${ANYMAL_FLAGS:-}
  best=$OUT/runs/$name/policy_best
  JAX_PLATFORMS=cpu python3 -m quadcos.sim2sim --no_progress --policy="$best" --terrain=slope5 \
    --episodes=64 --seconds=40 --out="$OUT/sim2sim_${name}_slope5.json" > "$OUT/sim2sim_${name}_slope5.log" 2>&1 &
  evaluate "$best" ${name}_slope5 slope5 1024 40
  evaluate "$best" ${name}_s4 s4 1024 30
  evaluate "$best" ${name}_flat flat 1024 20
  evaluate "$best" ${name}_testset testset:2026 4288 40
  wait ;;
anymal)  # ANYmal C from nothing alone, with the current preset and gait search
  : "${MENAGERIE_ROOT:?set MENAGERIE_ROOT to a folder of MuJoCo Menagerie robots}"
  export MENAGERIE_ROOT
  name=anybotics_anymal_c_s0
  train $((${ANYMAL_S:-300} + 60)) $name --preset=scratch --robot=menagerie:anybotics_anymal_c \
    --seed=0 --max_seconds=${ANYMAL_S:-300}
  JAX_PLATFORMS=cpu python3 -m quadcos.sim2sim --no_progress --policy="$OUT/runs/$name/policy_best" \
    --terrain=flat --episodes=64 --out="$OUT/sim2sim_${name}_flat.json" \
    > "$OUT/sim2sim_${name}_flat.log" 2>&1 &
  evaluate "$OUT/runs/$name/policy_best" ${name}_flat flat 1024 20 --trace="$OUT/trace_${name}_flat.json"
  if [ "${ANYMAL_SLOPES:-1}" = 1 ]; then  # the flat policy on the slope courses
    evaluate "$OUT/runs/$name/policy_best" ${name}_slope5 slope5 1024 40
    evaluate "$OUT/runs/$name/policy_best" ${name}_s4 s4 1024 30
  fi
  wait ;;
profile)  # where the 1- and 8-update training rows' time goes (flat and slope5, Warp, 4096 envs)
  for terrain in flat slope5; do
    python3 -m quadcos.bench --impl=warp --terrain=$terrain --only=physics,train --env_counts=4096 \
      --train_rows=4096x8192x1,4096x8192x8 --train_seconds=8 --steps=20 \
      --profile_dir="/tmp/quadcos_profile/$terrain" --profile_python --out="$OUT/bench_warp_${terrain}_profiled.json" \
      > "$OUT/bench_warp_${terrain}_profiled.log" 2>&1
    note "bench $terrain profiled: exit $?"
    for row in 4096x8192x1 4096x8192x8; do
      python3 -m quadcos.benchmarking.profile "/tmp/quadcos_profile/$terrain/$row" --top 25 \
        > "$OUT/profile_${terrain}_$row.md" 2>&1
    done
  done ;;
imports)  # where the import seconds go: `python3 -X importtime` of quadcos.train (twice: the second
  # with a warm file cache), then the first calls that start JAX's and Warp's GPU back ends
  for k in 1 2; do
    python3 -X importtime -c "import quadcos.train" 2> "$OUT/importtime_$k.txt"
  done
  python3 - > "$OUT/init_times.txt" 2>&1 <<'PY'
import time
t = time.time()
import jax; t1 = time.time(); print("import jax", round(t1 - t, 2))
jax.devices(); t2 = time.time(); print("jax.devices()", round(t2 - t1, 2))
import mujoco; t3 = time.time(); print("import mujoco", round(t3 - t2, 2))
from mujoco import mjx; t4 = time.time(); print("import mujoco.mjx", round(t4 - t3, 2))
import warp; t5 = time.time(); print("import warp", round(t5 - t4, 2))
warp.init(); t6 = time.time(); print("warp.init()", round(t6 - t5, 2))
PY
  python3 benchmarks/import_table.py "$OUT/importtime_2.txt" > "$OUT/imports.md" ;;
startup)  # start-up seconds, whole processes, the tree against BASE_TREE (another revision's
  # `git archive REV quadcos models pyproject.toml`): benchmarks/h100/startup/before_after.sh
  bash benchmarks/h100/startup/before_after.sh ;;
randomized)  # the Warp rows with and without domain randomisation, flat, 4096 envs, 1 update a step
  for randomize in "" --randomize; do
    python3 -m quadcos.bench --impl=warp --terrain=flat --only=physics,train --env_counts=4096 \
      --train_rows=4096x8192x1 --train_seconds=8 --steps=20 $randomize \
      --out="$OUT/bench_warp_flat${randomize:+_randomized}.json" \
      > "$OUT/bench_warp_flat${randomize:+_randomized}.log" 2>&1
    note "bench warp flat ${randomize:-nominal}: exit $?"
  done ;;
*) echo "unknown experiment '$experiment'" >&2; exit 2 ;;
esac
note "$experiment done"
