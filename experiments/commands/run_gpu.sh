#!/usr/bin/env bash
# The commanded-gait campaign (experiments/commands/README.md) on a host of one or more GPUs, one
# training run per GPU, from the repository root:
#   bash experiments/commands/run_gpu.sh train RUN...     # start runs in the background, return
#   [MAX_SECONDS=S] bash experiments/commands/run_gpu.sh fork FORK LEVER...  # FORK trains to the
#                                                         # actor's start, each LEVER (a RUN) goes
#                                                         # on from a copy in the background (below)
#   bash experiments/commands/run_gpu.sh wait  RUN...     # until they have ended (their policies;
#                                                         # a run that fails starts once more)
#   bash experiments/commands/run_gpu.sh evaluate RUN...  # random commands + robustness, one per GPU
#   bash experiments/commands/run_gpu.sh pack RUN...      # $OUT/NAME.tgz
#   bash experiments/commands/run_gpu.sh stop             # end every run and evaluation started
#   bash experiments/commands/run_gpu.sh levers LEVER...  # all four for SAC's levers (below)
#   bash experiments/commands/run_gpu.sh anymal LEVER...  # all four for ANYmal C's (below)
#   [MAX_SECONDS=S] bash experiments/commands/run_gpu.sh go1 LEVER...  # all four for Go1's SAC levers
#   [MAX_SECONDS=S] bash experiments/commands/run_gpu.sh go1seeds LEVER SEED...  # all four: a Go1
#                                                         # lever from nothing (S: its budget;
#                                                         # VERBS="train wait pack": some of four)
# RUN is NAME@ROBOT@SEED[@extra train flags, space-separated: quote such a RUN], e.g.
# go1_s0@menagerie:unitree_go1@0. More runs than GPUs share them, each with an equal part of
# the GPU's memory. The runs work from a copy of the tree under
# /tmp/qc (the tree a later call brings may differ), their folders under RUNS/NAME (RUNS default
# /tmp/qc_runs; packs unpacked into a folder given as RUNS evaluate in another call, or on a
# machine where nothing trained: `train wait pack` in one call, `evaluate pack` in the next); the
# summaries go to $OUT (default /tmp/qc_out): NAME_train.log's last lines; evaluate writes
# NAME/eval.json, NAME/last_eval.json (the last policy), NAME/robustness.json (the kept policy's
# four conditions), NAME/gait_robustness.json (its step-0 gait's), NAME/last_robustness.json
# and the policies (LAST=0: not the last policy's two; GAIT=0: not gait_robustness.json;
# KEPT_ONLY=1: none for a run whose training kept its step-0 gait);
# pack tars NAME/ with the run's logs, its gait search's gait_search.json and its policies as
# NAME.tgz. MEM (default 0.9): the share of each GPU's memory the call's processes take
# together, less where another call's runs share the GPUs. IMPL_JAX=1: train without warp-lang
# (`train` refuses to otherwise).
set -uo pipefail
verb=${1:?usage: run_gpu.sh train|wait|evaluate RUN...}; shift
export MENAGERIE_ROOT=${MENAGERIE_ROOT:-$PWD/.menagerie}
OUT=${OUT:-/tmp/qc_out}; mkdir -p "$OUT"
runs=${RUNS:-/tmp/qc_runs}; mkdir -p "$runs"
gpus=$(nvidia-smi -L 2>/dev/null | wc -l); [ "$gpus" -gt 0 ] || gpus=1
envs=${EVAL_ENVS:-1024}  # episodes of each evaluation
share=$(( ($# + gpus - 1) / gpus ))  # runs on one GPU
mem=${MEM:-0.9}

split_run() {  # a RUN's fields (its flags also as the array extra); a word that is not
  # NAME@ROBOT@SEED[@...] stops the script
  IFS=@ read -r NAME ROBOT SEED EXTRA <<< "$1"
  extra=(); [ -n "${EXTRA:-}" ] && read -r -a extra <<< "$EXTRA"
  [[ $NAME =~ ^[A-Za-z0-9_.-]+$ && -n $ROBOT && $SEED =~ ^[0-9]+$ ]] || {
    echo "bad RUN '$1': NAME@ROBOT@SEED[@flags] (quote a RUN with several flags)" >&2; exit 2; }
}
case $verb in levers|anymal|go1|go1seeds|stop) ;; *) for spec in "$@"; do split_run "$spec"; done ;; esac  # each RUN
launch() {  # NAME GPU FLAGS...: quadcos.train in the background from /tmp/qc, its log NAME.log
  local name=$1 gpu=$2; shift 2
  echo "$gpu" > "$runs/$name.gpu"
  (cd /tmp/qc && CUDA_VISIBLE_DEVICES=$gpu \
    XLA_PYTHON_CLIENT_MEM_FRACTION=$(python3 -c "print(round($mem / $share, 2))") \
    setsid nohup python3 -m quadcos.train --output_dir="$runs/$name" --no_progress "$@" \
    >> "$runs/$name.log" 2>&1 < /dev/null &)
}
warp_or_jax() {  # the campaign's robots step on MJX-Warp; without warp-lang they would fall back
  # to MJX-JAX, slower by several times, and a 480-s run may end before its actor learns
  python3 -c "import warp" 2> /dev/null || [ "${IMPL_JAX:-0}" = 1 ] || {
    echo "warp-lang is not importable: install it (quadcos[warp]), or IMPL_JAX=1 to train" \
      "on MJX-JAX" >&2; exit 2; }
  rm -rf /tmp/qc && mkdir -p /tmp/qc && cp -r quadcos models pyproject.toml .menagerie /tmp/qc/ 2>/dev/null
}
# the levers were measured with the drive's loops open (the command preset closes them)
loops_open="--config.env.commands.speed_gain_rate=0 --config.env.commands.heading_gain=0"

case $verb in
train)
  warp_or_jax
  i=0
  for spec in "$@"; do
    split_run "$spec"
    rm -rf "$runs/$NAME" "$runs/$NAME".*  # a stale log would end `wait` at once
    flags=(--preset=command --robot="$ROBOT" --seed="$SEED" "${extra[@]}")
    printf '%s\n' "${flags[@]}" > "$runs/$NAME.flags"  # for `wait`'s relaunch
    launch "$NAME" $((i % gpus)) "${flags[@]}"
    echo "$(date +%T) $NAME on GPU $((i % gpus)): $ROBOT seed $SEED ${extra[*]}"
    i=$((i + 1))
  done ;;
fork)  # FORK (a RUN) trains alone to env step FORK_AT (default 4,161,536: the command preset's
  # 2,000 critic warm-up updates on 4,096 robots, the actor untrained) and checkpoints all its
  # state, the replay too (--save_replay); each LEVER (a RUN of the fork's robot and seed, its
  # flags the lever's) then goes on from a copy of it (--resume with its flags, MAX_SECONDS of its
  # own, default 420), so that every lever spends its budget on the actor from the same critics
  # and replay. A fork trained before (its policy in RUNS) serves again. Then wait, evaluate,
  # pack the LEVERs as trained runs.
  split_run "$1"; fork=$NAME fork_robot=$ROBOT fork_seed=$SEED fork_extra=("${extra[@]}")
  shift; share=$(( ($# + gpus - 1) / gpus ))
  for spec in "$@"; do
    split_run "$spec"
    [ "$ROBOT@$SEED" = "$fork_robot@$fork_seed" ] || {
      echo "lever $NAME: $ROBOT seed $SEED, not the fork's $fork_robot seed $fork_seed" >&2; exit 2; }
  done
  warp_or_jax
  if [ ! -f "$runs/$fork/policy/policy.json" ]; then
    rm -rf "${runs:?}/$fork" "$runs/$fork".*
    (cd /tmp/qc && python3 -m quadcos.train --output_dir="$runs/$fork" --no_progress \
      --preset=command --robot="$fork_robot" --seed="$fork_seed" "${fork_extra[@]}" --save_replay \
      --num_timesteps="${FORK_AT:-4161536}" > "$runs/$fork.log" 2>&1) || {
      echo "$fork failed: $(tail -n 1 "$runs/$fork.log")" >&2; exit 1; }
  fi
  echo "$(date +%T) $fork: $(grep -c '^step ' "$runs/$fork.log") evaluations, forked"
  i=0
  for spec in "$@"; do
    split_run "$spec"
    rm -rf "${runs:?}/$NAME" "$runs/$NAME".*
    # the fork's files but its last policy; its checkpoints (GBs with the replay) hard-linked: a
    # run writes its checkpoints beside them and unlinks old ones, never writes into one
    mkdir -p "$runs/$NAME" && cp -al "$runs/$fork/checkpoints" "$runs/$NAME/"
    for f in "$runs/$fork"/*; do
      case ${f##*/} in checkpoints|policy) ;; *) cp -r "$f" "$runs/$NAME/" ;; esac
    done
    flags=(--preset=command --robot="$ROBOT" --seed="$SEED" "${extra[@]}" --num_timesteps=400000000
           --config.sac.max_seconds="${MAX_SECONDS:-420}" --config.sac.save_replay=false)
    printf '%s\n' "${flags[@]}" > "$runs/$NAME.flags"  # for `wait`'s relaunch
    cp "$runs/$fork.log" "$runs/$NAME.log"  # the fork's evaluations (step 0 on) head the log
    launch "$NAME" $((i % gpus)) --resume "${flags[@]}"
    echo "$(date +%T) $NAME on GPU $((i % gpus)): from $fork ${extra[*]}"
    i=$((i + 1))
  done
  sleep 5 ;;  # (`wait` takes a run whose log has lines and no process for one that failed)
wait)  # until every run has ended; a run that died without its policy (e.g. a fault in Warp's
  # graph capture where runs share a GPU) starts once more at once, on from its run folder where
  # it has one (its config holds the searched gait; its newest checkpoint), else afresh
  pending=("$@")
  while (( ${#pending[@]} )); do
    left=()
    for spec in "${pending[@]}"; do
      split_run "$spec"
      # (a run launched a moment ago may not show in pgrep yet: its log is still empty)
      if [ ! -s "$runs/$NAME.log" ] || pgrep -f "output_dir=$runs/$NAME " > /dev/null; then
        left+=("$spec")
      elif [ ! -d "$runs/$NAME/policy" ] && [ ! -e "$runs/$NAME.failed.log" ]; then
        echo "$(date +%T) $NAME failed, started again: $(tail -n 1 "$runs/$NAME.log")"
        mv "$runs/$NAME.log" "$runs/$NAME.failed.log"
        mapfile -t flags < "$runs/$NAME.flags"  # (with --resume: the same values, recorded)
        if [ -f "$runs/$NAME/config.json" ]; then
          launch "$NAME" "$(cat "$runs/$NAME.gpu")" --resume "${flags[@]}"
        else
          rm -rf "${runs:?}/$NAME" && launch "$NAME" "$(cat "$runs/$NAME.gpu")" "${flags[@]}"
        fi
        left+=("$spec")
      else
        tail -n 5 "$runs/$NAME.log" > "$OUT/${NAME}_train.log"
        echo "$(date +%T) $NAME ended: $(tail -n 1 "$runs/$NAME.log")"
      fi
    done
    pending=("${left[@]}")
    if (( ${#pending[@]} )); then sleep 5; fi
  done ;;
evaluate)
  i=0
  for spec in "$@"; do
    split_run "$spec"
    kept=$runs/$NAME/policy_best; [ -d "$kept" ] || kept=$runs/$NAME/policy
    if [ "${KEPT_ONLY:-0}" = 1 ] && [ "$(python3 -c 'import json, sys
print(json.load(open(sys.argv[1]))["config"]["best_of_run"]["step"])' "$kept/policy.json" \
        2>/dev/null)" = 0 ]; then  # its training kept its step-0 gait: its evaluations say it
      echo "$(date +%T) $NAME kept its step-0 gait: not evaluated (KEPT_ONLY=1)"; continue
    fi
    mkdir -p "$OUT/$NAME"
    for p in policy policy_best; do
      [ -d "$runs/$NAME/$p" ] && cp -r "$runs/$NAME/$p" "$OUT/$NAME/"
    done
    (
      # The kept policy's random-command evaluation and its robustness conditions, the last
      # policy's evaluation, and the conditions of the step-0 gait (gait:DIR) and of the last
      # policy (issue 58, item 4: does SAC beat its gait?), side by side on the run's GPU.
      export CUDA_VISIBLE_DEVICES=$((i % gpus))
      export XLA_PYTHON_CLIENT_MEM_FRACTION=$(python3 -c "print(round($mem * 0.18 / $share, 2))")
      python3 -m quadcos.evaluate --no_progress --policy="$kept" --terrain=flat --num_envs=$envs \
        --seconds=20 --commands=random --out="$OUT/$NAME/eval.json" > "$runs/${NAME}_eval.log" 2>&1 &
      which_ones=("$kept=robustness")
      [ "${GAIT:-1}" = 1 ] && which_ones+=("gait:$kept=gait_robustness")
      if [ "${LAST:-1}" = 1 ]; then
        python3 -m quadcos.evaluate --no_progress --policy="$runs/$NAME/policy" --terrain=flat \
          --num_envs=$envs --seconds=20 --commands=random --out="$OUT/$NAME/last_eval.json" \
          > "$runs/${NAME}_last_eval.log" 2>&1 &
        which_ones+=("$runs/$NAME/policy=last_robustness")
      fi
      for which in "${which_ones[@]}"; do
        python3 experiments/robustness/measure.py --policy="${which%=*}" --num_envs=$envs \
          --commands=random --conditions nominal "latency 40 ms" "pushes 50 N, 0.1 s" \
          "friction 0.4" --out="$OUT/$NAME/${which##*=}.json" > "$runs/${NAME}_${which##*=}.log" 2>&1 &
      done
      wait
      echo "$(date +%T) $NAME evaluated: $(ls "$OUT/$NAME" | tr '\n' ' ')"
    ) &
    i=$((i + 1))
  done
  wait ;;
pack)  # each run's outputs, logs and policies as $OUT/NAME.tgz (a call brings back few files)
  for spec in "$@"; do
    split_run "$spec"
    mkdir -p "$OUT/$NAME"
    # (a run's logs beside its folder; in an unpacked pack (RUNS), inside it)
    cp "$runs/$NAME"*.log "$runs/$NAME/"*.log "$OUT/$NAME/" 2>/dev/null
    cp "$runs/$NAME/config.json" "$runs/$NAME/gait_search.json" "$runs/$NAME/"*.jsonl "$OUT/$NAME/" 2>/dev/null
    for p in policy policy_best; do  # (evaluate has copied them where it ran)
      [ -d "$runs/$NAME/$p" ] && [ ! -d "$OUT/$NAME/$p" ] && cp -r "$runs/$NAME/$p" "$OUT/$NAME/"
    done
    tar -C "$OUT" -czf "$OUT/$NAME.tgz" "$NAME" && rm -rf "$OUT/$NAME"
  done ;;
levers)  # SAC's levers (issue 58, item 4) on one fixed start: Go2 seed 0 from the searched gait
  # of the run go2_map2_s0 (its centre, speed map and drive given, so no search or calibration runs
  # and every run starts from the same policy), the command preset with max_seconds 270 otherwise
  # and the lever's flags; runs share the GPUs. $OUT/go2_LEVER.tgz each (training_summary.py).
  gait="--config.env.action_centre=0.231045,0.298314,0.177211,-5.65389,-2.5123"
  gait+=" --config.env.commands.reference_speed=1.3913 --config.env.commands.half_track=0.5838"
  gait+=" --config.env.commands.speed_map=0.2614,0.5511,0.8493,1.1565"
  gait+=" --config.sac.max_seconds=270 $loops_open"
  rate="--config.env.commands.tracking=yaw_rate" ln="--config.sac.critic_layer_norm=True"
  fw3="--config.env.reward.forward=450" heading="--config.env.commands.tracking=heading"
  declare -A lever=(  # against the preset before these levers: heading tracking, Brax's SAC
    [base]="$heading --config.env.reward.forward=150 --config.sac.critic_layer_norm=False
      --config.sac.policy_delay=1"
    [ln]="$heading --config.env.reward.forward=150 $ln --config.sac.policy_delay=1"
    [rate]="$rate --config.env.reward.forward=150 --config.sac.critic_layer_norm=False
      --config.sac.policy_delay=1"
    [rate_ln]="$rate --config.env.reward.forward=150 $ln --config.sac.policy_delay=1"
    [rate_fw3]="$rate $fw3 --config.sac.critic_layer_norm=False --config.sac.policy_delay=1"
    [rate_fw6]="$rate --config.env.reward.forward=900 --config.sac.critic_layer_norm=False
      --config.sac.policy_delay=1"
    [rate_ln_fw3]="$rate $fw3 $ln --config.sac.policy_delay=1"
    [rate_ln_fw3_d2]="$rate $fw3 $ln --config.sac.policy_delay=2"
  )
  specs=()
  for name in "$@"; do
    [ -n "${lever[$name]+set}" ] || { echo "unknown lever $name (${!lever[*]})" >&2; exit 2; }
    specs+=("go2_${name}@menagerie:unitree_go2@0@$gait $(echo ${lever[$name]})")
  done
  bash "$0" train "${specs[@]}" && bash "$0" wait "${specs[@]}"
  timeout -k 3 $((${DEADLINE:-570} - SECONDS)) bash "$0" evaluate "${specs[@]}"
  bash "$0" pack "${specs[@]}" ;;
anymal)  # ANYmal C's levers (experiments/commands/README.md, "ANYmal C levers"): the command preset
  # with its gait search floored at 0.15 m/s, 16 gaits confirmed on 256 robots each, 20 / 20 solver
  # iterations, and the lever's flags; runs share the GPUs (MJX-Warp where warp-lang is installed).
  base="--config.sac.gait_search.min_speed=0.15 --config.sac.gait_search.confirm_robots=256"
  base+=" --config.env.solver_iterations=20 --config.env.ls_iterations=20 $loops_open"
  ref="--config.env.commands.reference_speed=0.4 --config.env.commands.scale_max=1.0"
  trot="--config.env.action_centre=0.459,-0.246,0.264,-3.14159,0.0"  # anybotics_anymal_c_open_loop
  # that trot's feed-forward, measured as a search's would be (README, "ANYmal C levers")
  trot+=" --config.env.commands.reference_speed=0.0928 --config.env.commands.half_track=0.3201"
  trot+=" --config.env.commands.speed_map=0.0799,0.191,0.3884,0.5223 --config.env.period_min=0.25"
  rhythm="--config.env.action_centre=0.499,0.2196,0.2988,1.3737,2.9919"
  rhythm+=" --config.env.commands.reference_speed=0.9444 --config.env.commands.half_track=4.0207"
  rhythm+=" --config.env.commands.speed_map=0.3098,0.5718,0.9029,0.9378"
  declare -A lever=(  # NAME -> its seconds and flags
    [it20_300]="300" [ref]="540 $ref" [per]="540 --config.env.period_min=0.25"
    [refper]="540 $ref --config.env.period_min=0.25"
    [per25_300]="300 --config.env.period_min=0.25" [per30_300]="300 --config.env.period_min=0.3"
    [trot]="540 $trot" [trot_as10]="540 $trot --config.env.action_scale=0.1"  # no search
    [per30ms30_300]="300 --config.env.period_min=0.3 --config.sac.gait_search.min_speed=0.3"
    [per30as40_300]="300 --config.env.period_min=0.3 --config.env.action_scale=0.4"
    [per30ms30]="540 --config.env.period_min=0.3 --config.sac.gait_search.min_speed=0.3"
    # stiffer position servos than the MJCF's kp 100 (servo_gains.py: the rhythms that walk)
    [servo300]="540 --config.env.servo_kp=300 --config.env.servo_kd=4"
    [servo300per30]="540 --config.env.servo_kp=300 --config.env.servo_kd=4 --config.env.period_min=0.3"
    [servo500]="540 --config.env.servo_kp=500 --config.env.servo_kd=6"
    # servo_gains.py's fastest kp-300 rhythm as the centre (no search), its feed-forward measured
    # on it by the calibration a search runs (README, "ANYmal C levers")
    [servo300rhythm]="540 --config.env.servo_kp=300 --config.env.servo_kd=4 $rhythm"
  )
  specs=()
  for name in "$@"; do
    [ -n "${lever[$name]+set}" ] || { echo "unknown lever $name (${!lever[*]})" >&2; exit 2; }
    read -r seconds flags <<< "${lever[$name]}"
    flags="--config.sac.max_seconds=$seconds $base $flags"
    specs+=("anymal_${name}_s0@menagerie:anybotics_anymal_c@0@$flags")
  done
  for next in train wait; do bash "$0" $next "${specs[@]}"; done
  EVAL_ENVS=${EVAL_ENVS:-512} bash "$0" evaluate "${specs[@]}"
  bash "$0" pack "${specs[@]}" ;;
go1|go1seeds)  # go1: Go1's SAC levers on one fixed start: seed 0 from the searched gait of
  # go1loops540_s0 (its centre, speed map and b given: nothing searched or measured), whose SAC
  # never beat that gait on MJX-JAX; the command preset (the drive's loops closed) for 450 s.
  # go1seeds LEVER SEED...: the lever from nothing (the command preset, its search and 480 s) on
  # each seed, as go1cmd_LEVER_sSEED (MAX_SECONDS: another budget, for go1 too); a SEED go2:N or
  # anymal:N runs that robot instead (go2cmd_LEVER_sN, anymalcmd_LEVER_sN). Runs share GPUs.
  gait="--config.env.action_centre=0.223638,-0.149431,0.15185,-2.06857,-5.21017"
  gait+=" --config.env.commands.reference_speed=1.03 --config.env.commands.half_track=0.442"
  gait+=" --config.env.commands.speed_map=0.2165,0.4605,0.696,0.9307 --config.sac.max_seconds=450"
  # the yaw term against SAC trading turning for speed (item 4): its weight w4 ×3, its yaw rate
  # low-passed over 0.25 s (the tracking metric's windows, not each step's stride sway); tighter
  # action bounds (the preset 0.2); the kept policy chosen every 2 M env steps, not 10 M; the
  # torso's angular velocity observed (a gyro: the yaw rate the term tracks, not its integral);
  # the kept policy ranked by its evaluation's tracking, not its reward; the command's change in
  # a step charged (reward.action_rate W: the policies' actions chatter, docs/env.md); the
  # actor's own change from a state to the next and to a noisy state charged (CAPS W: the
  # deterministic action's chatter); a faster filter between action and rhythm (the policies
  # lose to their gaits most in the first 0.5 s after a command draw: lever_windows.py)
  caps() { echo "--config.sac.smoothness.temporal=$1 --config.sac.smoothness.spatial=$1"; }
  yaw3="--config.env.reward.yaw=120" tau="--config.env.commands.yaw_rate_tau=0.25"
  rate300="--config.env.reward.action_rate=300" rate1000="--config.env.reward.action_rate=1000"
  as10="--config.env.action_scale=0.1" eval2="--config.sac.eval_interval=2000000"
  gyro="--config.env.observe_angular_velocity=True" track="--config.sac.best_policy_by=tracking"
  trackatt8="--config.sac.gait_search.track_gaits=8 --config.sac.gait_search.track_attitude=0.1"
  declare -A lever=(
    [base]=""  # the same start on the same machine, no lever
    # go1seeds: the preset as it is, its training evaluations' groups each in their condition
    [preset]=""
    # a third of the randomisation's draws at its ranges' ends (latency 40 ms, friction 0.4, ...):
    # the preset's SAC trails its gaits at 40 ms, which delays the policy's action alone
    # (latency_cells.py)
    [ends]="--config.env.randomization.range_ends=0.33"
    # ... or the latency always 40 ms in training (the preset draws it from 0-40 ms): SAC's
    # feedback trained under the delay the condition measures, where its gait loses nothing
    [lat40]="--config.env.randomization.latency_s=(0.04,0.04)"
    # the level-gait gate at the attitude target (0.10 rad, the preset 0.085): go1cmd_lat40_s0's
    # gait tracker dropped finalists tracking 0.106 and 0.095 m/s that roll 0.087 and 0.092 rad
    # and kept one tracking 0.150 ("Levers against the 40-ms cell")
    [gate10]="--config.sac.gait_search.max_attitude=0.1"
    # the critics observe what the policy cannot (the robot's draw, the push, the pending action,
    # clean velocities, the drive's state: quadcos.env.privileged), the policy its observation
    [priv]="--config.sac.privileged_critic=True"
    [lr]="--config.sac.learning_rate.critic=3e-4 --config.sac.learning_rate.alpha=3e-4"
    [warm]="--config.sac.actor_warmup_steps=20000"  # the actor waits ~10 M env steps, not 1 M
    [eval2]="$eval2" [yaw3]="$yaw3" [tau]="$tau" [tauyaw3]="$tau $yaw3" [as10]="$as10"
    [tauas10]="$tau $as10" [taueval2]="$tau $eval2" [tauyaw3eval2]="$tau $yaw3 $eval2"
    [gyro]="$gyro" [taugyro]="$tau $gyro" [tauyaw3gyro]="$tau $yaw3 $gyro $eval2"
    [tauyaw3track]="$tau $yaw3 $eval2 $track" [tauyaw3gyrotrack]="$tau $yaw3 $gyro $eval2 $track"
    [rate300]="$rate300" [rate1000]="$rate1000" [tauyaw3trackrate300]="$tau $yaw3 $eval2 $track $rate300"
    [tauyaw3trackrate1000]="$tau $yaw3 $eval2 $track $rate1000"
    [caps10]="$(caps 10)" [tauyaw3trackcaps1]="$tau $yaw3 $eval2 $track $(caps 1)"
    [tauyaw3trackcaps10]="$tau $yaw3 $eval2 $track $(caps 10)"
    [tauyaw3trackcaps100]="$tau $yaw3 $eval2 $track $(caps 100)"
    [tauyaw3trackfilt10]="$tau $yaw3 $eval2 $track --config.env.action_filter_tau=0.1"
    [tauyaw3trackfilt0]="$tau $yaw3 $eval2 $track --config.env.action_filter_tau=0"
    [tauyaw3gait]="$tau $yaw3 $eval2 --config.sac.best_policy_by=gait"  # ranked against step 0
    # a third of the randomisation's draws at the ends of its ranges (friction 0.4 / 1.5, ...)
    [tauyaw3trackends]="$tau $yaw3 $eval2 $track --config.env.randomization.range_ends=0.33"
    # on the preset as it is (go1seeds): a tenth of the command draws standing (v* = ω* = 0: the
    # Go1 policy of go1cmd_tauyaw3gait_s1 creeps and, under the training solver's iterations in C
    # MuJoCo and on MJX-JAX, falls where told to stand on slippery ground: docs/decisions.md);
    # the actor charged for its distance from the searched gait (ANYmal C's evaluations fall below step 0)
    [stand]="--config.env.commands.zero_command_probability=0.1"
    [anchor10]="--config.sac.smoothness.anchor=10" [anchor100]="--config.sac.smoothness.anchor=100"
    # the kept policy chosen only among evaluations within the attitude target (0.10 rad, mean
    # of the episodes' peak roll and pitch error: Go1 seed 2 rolls 0.102–0.113, Go2 pitches 0.112)
    [att]="--config.sac.best_policy_max_attitude=0.1"
    # the gait search ranking only gaits within an attitude (SAC hardly changes a searched gait's
    # roll; 0.085 kept 5 of 7 Go1 gaits that meet the targets and none of 5 that miss them, two
    # of those by 0.0006 rad: search_attitude.py, README "The attitude gate")
    [searchatt]="--config.sac.gait_search.max_attitude=0.085"
    # that bound with the best 32 gaits rerun on 128 robots each (ANYmal C's preset confirms on
    # 256): searchatt's seed-2 gait never fell on its 4 robots and survives 0.36–0.41 at step 0
    [searchattc]="--config.sac.gait_search.max_attitude=0.085 --config.sac.gait_search.confirm_robots=128"
    # the best of the search's 4 best gaits by command tracking with its own feed-forward (README,
    # "Gaits chosen by their tracking": step 0 spreads more than SAC moves it)
    [tracked]="--config.sac.gait_search.track_gaits=4"
    # the same with each finalist's attitude scored against 0.10 rad (README, "Gaits chosen by
    # their tracking": tracked's seeds kept gaits that roll 0.114-0.168 rad)
    [trackatt]="--config.sac.gait_search.track_gaits=4 --config.sac.gait_search.track_attitude=0.1"
    # ... among the search's 8 best (trackatt's seeds 0 and 2: none of the 4 within every target)
    [trackatt8]="$trackatt8"
    # ... among the 8 best of a search that ranks only level gaits (searchatt's bound)
    [searchtrackatt8]="--config.sac.gait_search.max_attitude=0.085 $trackatt8"
    # ... among its 16 best (searchtrackatt8's seed 2: none of its 8 within the speed target)
    [searchtrackatt16]="--config.sac.gait_search.max_attitude=0.085 ${trackatt8/=8/=16}"
    # ... with the training evaluations' robots in the four robustness conditions, a quarter
    # each: the kept policy must beat step 0 in every condition's tracking and falls
    # (searchtrackatt16's seeds 0 and 1 trailed their gaits at friction 0.4 and at 40 ms)
    [searchtrackatt16cond]="--config.sac.gait_search.max_attitude=0.085 ${trackatt8/=8/=16} --config.env.randomization.eval_conditions=robustness"
    # Eq. 12's roll weight w5 ×3 with trackatt8 (SAC has moved a gait's roll by <= 0.023 rad at
    # w5 30; trackatt's misses are rolls of 0.104-0.111)
    [trackatt8roll90]="$trackatt8 --config.env.reward.roll=90"
    # the turn action's reach cut to the rhythm's (turn_bound 0.5 × action_scale 0.2): the drive
    # turns; SAC's turn value moves each side's hip swing by up to ±50 % at the default
    [turn10]="--config.env.turn_bound=0.1"
    # n-step returns (FastTD3's 3): the critic's target sums three steps of rewards
    [nstep3]="--config.sac.n_step=3"
    # the forward term on the speed low-passed over 0.25 s, as the yaw term's yaw rate (per step
    # it charges Go2's gait 0.57 of a 0.05-m/s error, low-passed 0.86: docs/env.md)
    [spdtau]="--config.env.commands.speed_tau=0.25"
    # w1 ×5: ANYmal C's SAC gains 585 per episode in the orientation term for 118 lost in the
    # forward term (anymalcmd_nstep3_s0's reward_terms in campaign.json); at ×5 that trade pays
    # nothing
    [fw2250]="--config.env.reward.forward=2250"
    # distributional critics (FastSAC's 101 atoms) on the default ±250 of scaled returns
    # (reward × 0.1 / (1 − γ): the shipped ANYmal C policy earns 4885 in 400 steps, so about +120)
    [dist]="--config.sac.critic_atoms=101"
    # what the reward and the drive depend on observed (the drive's gain, heading correction, the
    # yaw term's low-passed yaw rate) and the gyro: the critic's state was not Markov in them
    [drive]="--config.env.commands.observe_drive=True $gyro"
  )
  [[ -z ${MAX_SECONDS:-} || $MAX_SECONDS =~ ^[0-9]+$ ]] ||
    { echo "bad MAX_SECONDS '$MAX_SECONDS': whole seconds" >&2; exit 2; }
  specs=()
  if [ "$verb" = go1seeds ]; then
    name=${1:?usage: run_gpu.sh go1seeds LEVER SEED...}; shift
    (( $# )) || { echo "usage: run_gpu.sh go1seeds LEVER SEED...: no SEED" >&2; exit 2; }
    [ -n "${lever[$name]+set}" ] || { echo "unknown lever $name (${!lever[*]})" >&2; exit 2; }
    declare -A robots=([go1]=unitree_go1 [go2]=unitree_go2 [anymal]=anybotics_anymal_c)
    for token in "$@"; do  # SEED (Go1) or ROBOT:SEED, ROBOT go1, go2 or anymal
      [[ $token == *:* ]] && robot=${token%%:*} seed=${token#*:} || robot=go1 seed=$token
      [[ -n ${robots[$robot]:-} && $seed =~ ^[0-9]+$ ]] ||
        { echo "bad SEED '$token': N or ROBOT:N, ROBOT one of ${!robots[*]}" >&2; exit 2; }
      specs+=("${robot}cmd_${name}_s$seed@menagerie:${robots[$robot]}@$seed@${lever[$name]}${MAX_SECONDS:+ --config.sac.max_seconds=$MAX_SECONDS}")
    done
  else
    for name in "$@"; do
      [ -n "${lever[$name]+set}" ] || { echo "unknown lever $name (${!lever[*]})" >&2; exit 2; }
      # (MAX_SECONDS: another budget than 450 s, named in the run: go1_LEVERtS_s0)
      specs+=("go1_${name}${MAX_SECONDS:+t$MAX_SECONDS}_s0@menagerie:unitree_go1@0@$gait ${lever[$name]}${MAX_SECONDS:+ --config.sac.max_seconds=$MAX_SECONDS}")
    done
  fi
  for next in ${VERBS:-train wait evaluate pack}; do bash "$0" $next "${specs[@]}"; done ;;
stop)  # the bracketed first letters keep each pattern from matching a shell that names it
  pkill -f "[q]uadcos.train .*--output_dir=$runs/"
  pkill -f "[q]uadcos.evaluate --no_progress"
  pkill -f "[e]xperiments/robustness/measure.py"
  exit 0 ;;
*) echo "unknown verb $verb" >&2; exit 2 ;;
esac
