#!/usr/bin/env bash
# One GPU lease's campaign (session 6: issues 16 and 13), started detached so that it outlives the
# device calls that poll it (each call returns within 10 minutes; the machine stays warm between):
#   setsid nohup bash experiments/gpu_campaign.sh > /tmp/campaign.log 2>&1 < /dev/null &
#   bash experiments/gpu_poll.sh 540      # in each later call: waits, copies finished phases to $OUT
# Each phase leaves /tmp/campaign/<phase>.tar.gz. (Session 5's campaign — from-scratch flat runs,
# the bench, parity, start-up — is this file's previous version in git.)
set -uo pipefail
source experiments/gpu_setup.sh || exit 1
C=/tmp/campaign
mkdir -p $C
note() { echo "$(date +%T) $*" | tee -a $C/status; }
pack() {  # PHASE: its files under $C/<PHASE> as $C/<PHASE>.tar.gz
  tar czf $C/$1.tar.gz -C $C $1 && note "$1 done"
}
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $C/gpu.txt
python3 -c "import jax, mujoco, warp; print(jax.__version__, mujoco.__version__, warp.__version__)" >> $C/gpu.txt 2>&1

# 1. Two streams sharing the GPU (neither is timed against a target).
#    a. Issue 16: the flat gpu preset (trot start) trained with domain randomisation (JAX physics:
#       per-robot model fields), then the robustness table's conditions, 1024 episodes each, for
#       it and for the committed flat policy trained without (two processes side by side).
#    b. Issue 13, deliverable 5: DRL-only (joint targets) with the from-scratch learner's settings
#       (--preset=scratch less the gait search, which has no rhythm to search for joints: r_s paid
#       for movement), 10 M env steps as the scratch runs, seeds 0 and 1.
if [ -z "${ONLY_SLOPE5:-}" ]; then  # ONLY_SLOPE5=1: phase 2 alone (the second lease of session 6)
export XLA_PYTHON_CLIENT_MEM_FRACTION=0.22
note "phase 1 start"
mkdir -p $C/robust/runs $C/drl
(
  OUT=$C/robust TRAIN_SECONDS=330 bash experiments/train_gpu.sh flat_randomized_s0 --terrain=flat \
    --seed=0 --config.env.impl=jax --config.env.randomization.enabled=True
  note "flat_randomized_s0: $(tail -n 1 $C/robust/runs/flat_randomized_s0/train.log)"
  python3 experiments/robustness/measure.py --policy=$C/robust/runs/flat_randomized_s0/policy \
    --num_envs=1024 --out=$C/robust/flat_trained_with.json > $C/robust/flat_trained_with.log 2>&1 &
  python3 experiments/robustness/measure.py --policy=experiments/policies/flat \
    --num_envs=1024 --out=$C/robust/flat_trained_without.json > $C/robust/flat_trained_without.log 2>&1
  wait
  note "robustness measured"
  pack robust
) &
for s in 0 1; do
  OUT=$C/drl TRAIN_SECONDS=300 bash experiments/train_gpu.sh joint_scratch_s$s --terrain=flat \
    --seed=$s --controller=joint --config.env.survival_min_speed=0.1 \
    --config.sac.eval_interval=1000000
  note "joint_scratch_s$s: $(tail -n 1 $C/drl/runs/joint_scratch_s$s/train.log)"
done
pack drl
wait
unset XLA_PYTHON_CLIENT_MEM_FRACTION
fi

# 2. Issue 13, alone on the GPU (timed: >= 99 % cross slope5 within 10 minutes): slope5 from
#    scratch (gait search on the training course, then SAC), random spawns along the course, the
#    training course of experiments/slope5; then its final policy on slope5 and S-4.
note "slope5 start"
mkdir -p $C/slope5
OUT=$C/slope5 TRAIN_SECONDS=${SLOPE5_SECONDS:-420} bash experiments/train_gpu.sh scratch_slope5_s0 \
  "--terrain=sections:5@3,0@3,-5@3;run_out=10" --config.sac.episode_length=400 \
  --config.env.spawn_x_max=10 --seed=0 --config.env.action_centre=search \
  --config.env.survival_min_speed=0.1 --config.sac.eval_interval=1000000
note "scratch_slope5_s0: $(tail -n 1 $C/slope5/runs/scratch_slope5_s0/train.log)"
for course in slope5:40 s4:30; do
  python3 -m quadcos.evaluate --no_progress --num_envs=1024 \
    --policy=$C/slope5/runs/scratch_slope5_s0/policy --terrain=${course%:*} \
    --seconds=${course#*:} --out=$C/slope5/eval_${course%:*}.json 2>&1 | tail -n 30 > $C/slope5/eval_${course%:*}.log
done
pack slope5
note "campaign done"
