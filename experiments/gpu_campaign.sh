#!/usr/bin/env bash
# One GPU lease's campaign, started detached so that it outlives the device calls that poll it
# (each call returns within 10 minutes):
#   setsid nohup bash experiments/gpu_campaign.sh > /tmp/campaign.log 2>&1 < /dev/null &
#   bash experiments/gpu_poll.sh 540      # in each later call: waits, copies finished phases to $OUT
# (Here, before the lease: `bash experiments/gpu_tree.sh slim`, and `restore` after it.)
# Each phase leaves /tmp/campaign/<phase>.tar.gz. (Earlier sessions' campaigns are this file's
# previous versions in git.)
#
# Session 14 (PHASES=posture, then PHASES=posture_cap; POSTURE_SEEDS="0"; issue 14): the best_obs
# learner with env.posture_bound=0.6 (front and hind hip offsets in the action), 870 s from process
# start, alone on the GPU; posture_cap also with env.forward_speed_cap=0.8 (r_y pays up to 0.8 m/s);
# policy_best on the test set, slope5, S-4, flat and the 11° descent. Then (PHASES=more_testsets,
# GENERALIST_POLICY=a copy of experiments/policies/any_slope outside experiments/, which
# gpu_tree.sh slim keeps home) the generalist on two more held-out test sets, seeds 2027 and 4242.
# Session 13, third lease (PHASES=joint20; issue 13 §5): the DRL-only joint controller with the
# same learner for the scratch preset's new budget, 20 M env steps, seeds 0-2 side by side.
# Session 13, second lease (PHASES="scratch_best best_obs_s1"): --preset=scratch as it now is
# (20 M env steps, the best evaluation's policy kept) for seeds 0-2, alone, each policy and
# policy_best on flat; then issue 14's best_obs learner with seed 1 (its first lease's seed 0
# reached 0.854 on the test set).
# Session 13, one H100 (PHASES="scratch20 best_obs"; issues 13, 14), Warp physics: the from-scratch
# learner (--preset=scratch) on flat for 20 M env steps, seeds 0-2, each run alone on the GPU one
# after another (times from process start), each final policy on 1024 deterministic 20-s episodes
# (the phase was scratch_best's loop before the preset kept its best policy: its command is in
# experiments/from_scratch/README.md); then best_obs (seed 0, no flat evaluation). Does
# the pitch error reach the trot-start policies' (0.057-0.062 rad) once SAC has more steps than
# session 11's GPU-sharing runs got? (The orientation term of their evaluations was still falling
# at 10 M env steps.)
#
# Session 12, one H100 (PHASES=screen14; issue 14), Warp physics: why does the generalist stall on
# downhills? Four generalists side by side on one GPU (a quarter of it each, 900 s from process
# start), the session-9 command (GENERALIST + SCRATCH) and three changes to the learner:
#   base   as session 9 (r_s for steps moving >= 0.1 m/s, 1-s low-pass)
#   move03 r_s only for steps moving >= 0.3 m/s (a creep earns no survival reward)
#   obs    the slope estimate and the oscillator's phase observed (env.observe_slope/observe_phase)
#   both   move03 and obs
# then each policy on the test set, slope5, S-4 and flat (four evaluations at a time).
# Third lease (PHASES=best_obs): the same with sac.keep_best_policy (the policy of the best
# training-time evaluation kept in policy_best/), 600 s (BEST_SECONDS; lost: the machine went back
# before the evaluations returned); policy_best on the test set, slope5, S-4.
# Second lease (PHASES=obs_alone): the obs variant alone on the H100, 870 s from process start (the
# issue's 15-minute training budget), then the test set, slope5, S-4 and flat.
#
# Session 11, one H100 (PHASES=scratch_long; issue 13): the from-scratch learner (--preset=scratch)
# on flat for 20 M env steps, seeds 0-2 side by side on one GPU, JAX physics; each final policy on
# 1024 deterministic 20-s episodes. Do speed and pitch error reach the trot-start policies'
# (experiments/flat, 10 M env steps) with more steps?
#
# Session 10, nvidia-h200-x2 (PHASES=scaling; issue 15): the bench on 1 and 2 H200s, JAX physics
# (MJX-Warp's FFI module loads on cuda:0 only), NVLink multicast off.
#   1. Side by side: GPU 0 the slope5 section (time to cross from process start, the default
#      learner: gait search then SAC, 4096 envs) on one GPU; GPU 1 the train rows on one GPU at
#      4096 and 8192 envs (batch 8192, 8 updates a step), flat then slope5.
#   2. Both GPUs: the same rows at equal per-device work (8192 and 16384 envs in all, batch 16384),
#      flat; the slope5 section on two GPUs (4096 envs in all); the slope5 rows.
#   quadcos.benchmarking.scaling combines the JSONs into benchmarks/h200x2.json.
#
# Session 9, one H100 (PHASES="probe scratch_any scratch_slope5_s1", then
# "scratch_slope5_s2 joint_scratch_s2 scratch_any_long", then bench_slope5, then testset67):
# 1. probe: the from-scratch slope5 policy (experiments/from_scratch/gpu/scratch_slope5_s0, which
#    crossed the unseen S-4) on the held-out test set and on flat.
# 2. scratch_any: the generalist trained with the from-scratch learner (issue 13's --preset=scratch:
#    gait search, then SAC from the gait found; r_s for movement) on the random course family with
#    the course curriculum and spawns along each course; the search scores every candidate on the
#    same four lanes, the gentlest to the steepest. 9 minutes capped, then the test set etc.
# 3. scratch_slope5_s1: issue 13's slope5 from scratch, a second seed (5 minutes capped).
# Second lease (PHASES="scratch_slope5_s2 joint_scratch_s2 scratch_any_long"): slope5 from
# scratch seed 2; §5's DRL-only from scratch seed 2; the generalist of 2. trained for 12 minutes.
# Third lease (PHASES=bench_slope5): the bench's slope5 section from scratch (the default learner)
# and from the trot start, each from process start (benchmarks/h100/).
# Fourth (PHASES=testset67): the generalist and the slope5 policy on the test set with 67-s
# episodes, the time a 20-m course (the longest) takes at 0.3 m/s: slow or stuck?
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

PHASES=${PHASES:-scaling}
GENERALIST=("--terrain=random:max_deg=12,sections=3-5,len=1-3,seed=0" --config.sac.episode_length=400
  --config.env.spawn_x_max=20 --config.sac.gait_search.num_candidates=1024
  --config.sac.gait_search.robots_per_candidate=4 --seed=0
  --config.sac.eval_interval=10000000 --config.sac.num_timesteps=400000000)
SCRATCH="--config.env.action_centre=search --config.env.survival_min_speed=0.1"  # = --preset=scratch

if [[ " $PHASES " == *" scaling "* ]]; then
  export NCCL_NVLS_ENABLE=0  # NVLink multicast stays off (KINDS.md)
  S=$C/scaling
  mkdir -p $S
  bench() {  # NAME ARGS...: one bench process, its JSON and log under $S
    local name=$1; shift
    python3 -m quadcos.bench --train_seconds 10 --walk_timeout_s 480 --impl jax \
      --out $S/$name.json "$@" > $S/$name.log 2>&1
    note "$name: exit $? $(grep -c FAILED $S/$name.log) failed; $(grep -E 'train |slope5: [0-9.]+ s' $S/$name.log | tr '\n' ' ')"
  }
  ROWS1=4096x8192x8,8192x8192x8
  ROWS2=8192x16384x8,16384x16384x8
  CUDA_VISIBLE_DEVICES=0 bench slope5cross_1dev --num_devices 1 --only slope5 &
  CUDA_VISIBLE_DEVICES=1 bench flat_1dev --num_devices 1 --only train --terrain flat --train_rows $ROWS1
  CUDA_VISIBLE_DEVICES=1 bench slope5_1dev --num_devices 1 --only train --terrain slope5 --train_rows $ROWS1
  wait
  bench flat_2dev --num_devices 2 --only train --terrain flat --train_rows $ROWS2
  bench slope5cross_2dev --num_devices 2 --only slope5
  bench slope5_2dev --num_devices 2 --only train --terrain slope5 --train_rows $ROWS2
  python3 -m quadcos.benchmarking.scaling --out $S/h200x2.json $S/*_?dev.json > $S/table.md 2>&1
  pack scaling
fi

if [[ " $PHASES " == *" scratch_best "* ]]; then  # issue 13: --preset=scratch (20 M, best kept), alone
  B=$C/scratch_best
  mkdir -p $B
  for seed in 0 1 2; do
    name=scratch_best_s$seed
    OUT=$B TRAIN_SECONDS=330 bash experiments/train_gpu.sh $name --preset=scratch --terrain=flat --seed=$seed
    note "$name trained: $(tail -n 1 $B/runs/$name/train.log)"
    cp -r /tmp/quadcos_runs/$name/policy_best $B/runs/$name/
    evaluate $B $B/runs/$name/policy ${name}_last flat 1024 20
    evaluate $B $B/runs/$name/policy_best ${name}_best flat 1024 20
  done
  pack scratch_best
fi

if [[ " $PHASES " == *" joint20 "* ]]; then  # issue 13, §5: DRL-only at the preset's 20 M env steps
  J=$C/joint20
  mkdir -p $J
  for seed in 0 1 2; do  # three runs share the GPU
    OUT=$J XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 TRAIN_SECONDS=${JOINT20_SECONDS:-420} bash experiments/train_gpu.sh \
      joint20_s$seed --terrain=flat --seed=$seed --controller=joint --config.env.survival_min_speed=0.1 \
      --config.sac.eval_interval=1000000 --num_timesteps=20000000 &
  done
  wait
  for seed in 0 1 2; do note "joint20_s$seed trained: $(tail -n 1 $J/runs/joint20_s$seed/train.log)"; done
  pack joint20
fi

if [[ " $PHASES " == *" scratch_long "* ]]; then  # issue 13: flat from scratch for 20 M env steps
  L=$C/scratch_long
  mkdir -p $L
  for seed in 0 1 2; do  # three runs share the GPU
    OUT=$L XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 TRAIN_SECONDS=660 bash experiments/train_gpu.sh \
      scratch_long_s$seed --preset=scratch --terrain=flat --seed=$seed --num_timesteps=20000000 &
  done
  wait
  for seed in 0 1 2; do
    note "scratch_long_s$seed trained: $(tail -n 1 $L/runs/scratch_long_s$seed/train.log)"
    evaluate $L $L/runs/scratch_long_s$seed/policy scratch_long_s$seed flat 1024 20
  done
  pack scratch_long
fi

if [[ " $PHASES " == *" screen14 "* ]]; then  # issue 14: four generalists side by side
  W=$C/screen14
  mkdir -p $W
  declare -A VARIANT=(
    [base]=""
    [move03]="--config.env.survival_min_speed=0.3"
    [obs]="--config.env.observe_slope=True --config.env.observe_phase=True"
    [both]="--config.env.survival_min_speed=0.3 --config.env.observe_slope=True --config.env.observe_phase=True")
  for v in base move03 obs both; do
    # SCRATCH first: a variant's own survival_min_speed overrides it
    OUT=$W XLA_PYTHON_CLIENT_MEM_FRACTION=0.22 TRAIN_SECONDS=${SCREEN_SECONDS:-900} bash experiments/train_gpu.sh \
      any_$v "${GENERALIST[@]}" $SCRATCH ${VARIANT[$v]} &
  done
  wait
  for v in base move03 obs both; do
    note "any_$v trained: $(tail -n 1 $W/runs/any_$v/train.log)"
    XLA_PYTHON_CLIENT_MEM_FRACTION=0.22 evaluate_all $W $W/runs/any_$v/policy any_$v &
  done
  wait
  pack screen14
fi

if [[ " $PHASES " == *" obs_alone "* ]]; then  # issue 14: the screen's obs variant alone, 15 min
  O=$C/obs_alone
  mkdir -p $O
  OUT=$O TRAIN_SECONDS=870 bash experiments/train_gpu.sh any_obs_s0 "${GENERALIST[@]}" $SCRATCH \
    --config.env.observe_slope=True --config.env.observe_phase=True
  note "any_obs_s0 trained: $(tail -n 1 $O/runs/any_obs_s0/train.log)"
  evaluate_all $O $O/runs/any_obs_s0/policy any_obs_s0
  pack obs_alone
fi

for phase_seed in best_obs:0 best_obs_s1:1; do  # issue 14: obs variant, the best policy kept
  phase=${phase_seed%:*} seed=${phase_seed#*:}
  [[ " $PHASES " == *" $phase "* ]] || continue
  K=$C/$phase
  mkdir -p $K
  name=any_obs_best_s$seed
  prefix=any_obs_best${phase#best_obs}  # seed 0's files are eval_any_obs_best_*
  OUT=$K TRAIN_SECONDS=${BEST_SECONDS:-600} bash experiments/train_gpu.sh $name "${GENERALIST[@]}" $SCRATCH \
    --config.env.observe_slope=True --config.env.observe_phase=True --config.sac.keep_best_policy=True \
    --seed=$seed
  note "$name trained: $(tail -n 1 $K/runs/$name/train.log)"
  cp -r /tmp/quadcos_runs/$name/policy_best $K/runs/$name/
  best=$K/runs/$name/policy_best
  evaluate $K $best ${prefix}_testset testset:2026 4288 40
  evaluate $K $best ${prefix}_slope5 slope5 1024 40
  evaluate $K $best ${prefix}_s4 s4 1024 30
  evaluate $K $best ${prefix}_flat flat 1024 10  # not in session 13's seed-0 lease (flat: CPU)
  pack $phase
done

declare -A POSTURE_EXTRA=([posture]="" [posture_cap]="--config.env.forward_speed_cap=0.8")
for phase_seed in $(for p in posture posture_cap; do for s in ${POSTURE_SEEDS:-0}; do echo $p:$s; done; done); do
  # issue 14: best_obs plus the front/hind hip offsets (and, posture_cap, r_y paid up to 0.8 m/s)
  kind=${phase_seed%:*} seed=${phase_seed#*:}
  [[ " $PHASES " == *" $kind "* ]] || continue
  phase=${kind}_s$seed
  P=$C/$phase
  mkdir -p $P
  OUT=$P TRAIN_SECONDS=${POSTURE_SECONDS:-870} bash experiments/train_gpu.sh $phase "${GENERALIST[@]}" \
    $SCRATCH --config.env.observe_slope=True --config.env.observe_phase=True \
    --config.sac.keep_best_policy=True --config.env.posture_bound=0.6 ${POSTURE_EXTRA[$kind]} --seed=$seed
  note "$phase trained: $(tail -n 1 $P/runs/$phase/train.log)"
  cp -r /tmp/quadcos_runs/$phase/policy_best $P/runs/$phase/
  evaluate_all $P $P/runs/$phase/policy_best $phase
  evaluate $P $P/runs/$phase/policy_best ${phase}_down11 "sections:0@1,-11@4,0@2" 1024 20
  evaluate $P $P/runs/$phase/policy ${phase}_last_testset testset:2026 4288 40
  pack $phase
done

if [[ " $PHASES " == *" more_testsets "* ]]; then  # issue 14: the generalist on two more test sets
  M=$C/more_testsets
  mkdir -p $M
  policy=${GENERALIST_POLICY:-experiments/policies/any_slope}
  for seed in 2027 4242; do
    evaluate $M $policy any_slope_testset$seed testset:$seed 4288 40
  done
  pack more_testsets
fi

if [[ " $PHASES " == *" probe "* ]]; then
  P=$C/probe
  mkdir -p $P
  policy=experiments/from_scratch/gpu/scratch_slope5_s0/policy
  evaluate $P $policy scratch_slope5_testset testset:2026 4288 40
  evaluate $P $policy scratch_slope5_flat flat 1024 10
  pack probe
fi

for phase_seconds in scratch_any:540 scratch_any_long:720; do  # the generalist, 9 and 12 minutes
  phase=${phase_seconds%:*}
  [[ " $PHASES " == *" $phase "* ]] || continue
  A=$C/$phase
  mkdir -p $A
  OUT=$A TRAIN_SECONDS=${phase_seconds#*:} bash experiments/train_gpu.sh ${phase}_s0 "${GENERALIST[@]}" $SCRATCH
  note "${phase}_s0 trained: $(tail -n 1 $A/runs/${phase}_s0/train.log)"
  evaluate_all $A $A/runs/${phase}_s0/policy $phase
  pack $phase
done

for seed in 1 2; do
  name=scratch_slope5_s$seed
  [[ " $PHASES " == *" $name "* ]] || continue
  S=$C/$name
  mkdir -p $S
  OUT=$S TRAIN_SECONDS=300 bash experiments/train_gpu.sh $name \
    "--terrain=sections:5@3,0@3,-5@3;run_out=10" --config.sac.episode_length=400 \
    --config.env.spawn_x_max=10 --seed=$seed $SCRATCH --config.sac.eval_interval=1000000
  note "$name trained: $(tail -n 1 $S/runs/$name/train.log)"
  policy=$S/runs/$name/policy
  evaluate $S $policy ${name}_slope5 slope5 1024 40
  evaluate $S $policy ${name}_s4 s4 1024 30
  evaluate $S $policy ${name}_testset testset:2026 4288 40
  pack $name
done

if [[ " $PHASES " == *" joint_scratch_s2 "* ]]; then  # §5: experiments/from_scratch, DRL-only
  J=$C/joint_scratch_s2
  mkdir -p $J
  OUT=$J TRAIN_SECONDS=240 bash experiments/train_gpu.sh joint_scratch_s2 --terrain=flat --seed=2 \
    --controller=joint --config.env.survival_min_speed=0.1 --config.sac.eval_interval=1000000
  note "joint_scratch_s2 trained: $(tail -n 1 $J/runs/joint_scratch_s2/train.log)"
  pack joint_scratch_s2
fi

if [[ " $PHASES " == *" bench_slope5 "* ]]; then
  B=$C/bench_slope5
  mkdir -p $B
  python3 -m quadcos.bench --preset=gpu --only=slope5 --walk_timeout_s=420 \
    --out=$B/bench_warp_slope5_scratch.json > $B/bench_warp_slope5_scratch.log 2>&1
  note "bench slope5 scratch: exit $? $(tail -n 1 $B/bench_warp_slope5_scratch.log)"
  python3 -m quadcos.bench --preset=gpu --only=slope5 --walk_training_preset=gpu --walk_timeout_s=240 \
    --out=$B/bench_warp_slope5_trot.json > $B/bench_warp_slope5_trot.log 2>&1
  note "bench slope5 trot: exit $? $(tail -n 1 $B/bench_warp_slope5_trot.log)"
  pack bench_slope5
fi

if [[ " $PHASES " == *" testset67 "* ]]; then
  T=$C/testset67
  mkdir -p $T
  evaluate $T experiments/policies/any_slope any_slope_testset67 testset:2026 4288 67
  evaluate $T experiments/policies/slope5 slope5_testset67 testset:2026 4288 67
  pack testset67
fi

note "campaign done"
