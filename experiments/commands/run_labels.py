"""What each run of the commanded-gait campaign changed, by the table it appears in
(experiments/commands/README.md; table.py reads the runs' numbers from campaign.json and
training_feed_forward.json and these labels from here)."""

LEVERS = {  # run in training_feed_forward.json -> its change from the preset
    "go1_s0": "—",
    "go1_s1": "— (seed 1)",
    "go2_s0": "— (Go2)",
    "go1_s0_leash": "`heading_leash` 0.1",
    "scale05_go1_s0": "`action_scale` 0.5",
    "scale05_go1_s1": "`action_scale` 0.5 (seed 1)",
    "scale05_go2_s0": "`action_scale` 0.5 (Go2)",
    "scale05_anymal_s0": "`action_scale` 0.5 (ANYmal C)",
}
CAMPAIGN = {  # run in campaign.json -> its drive (docs/env.md, "Feed-forward")
    "go1_s0": "v_ref",
    "go2_s0": "v_ref",
    "go1_map_s0": "map, b from its last segment",
    "go2_map_s0": "map, b from its last segment",
    "go2_map2_s0": "map",
    "go1_map2_s1": "map",
    "go2_rate_s0": "map; yaw-rate reward, w1 450, LayerNorm critics, actor every 2nd update",
    "go1_rate_s0": "map; yaw-rate reward, w1 450, LayerNorm critics, actor every 2nd update",
    "go1_rate_s1": "the preset, loops open (seed 1)",
    "go1_rate_s2": "the preset, loops open (seed 2)",
    "anymal_rate_s0": "the preset, loops open (ANYmal C): its gait stands, v_ref 0.80 kept",
    "anymal_ms_s0": "the preset, loops open, gait search `min_speed` 0.15 (ANYmal C): its gait"
    " falls, v_ref 0.80 kept",
    "go1path_s0": "Go1's MJCF by its path (no preset): the probe chose a 10-ms step; its gait falls"
    " in C MuJoCo, v_ref 1.00 kept",
    "go1path5_s0": "Go1's MJCF by its path, the probe's 5 ms (the preset's physics), 225 s: v_ref"
    " 0.68, no map (its gait falls in C MuJoCo at one of three frictions)",
    "go1long_s0": "the preset, loops open (seed 0), 540 s: the ten minutes of the targets",
    "go1long_s1": "the preset, loops open (seed 1), 540 s",
    "go1long_s2": "the preset, loops open (seed 2), 540 s",
    "go1utd2_s1": "the preset, loops open (seed 1), 540 s, two SAC updates per env step",
    "go1utd2_s2": "the preset, loops open (seed 2), 540 s, two SAC updates per env step",
    "go1spd_s0": "the preset, loops open (seed 0), its speed observed"
    " (`commands.observed_speed_tau` 0.25 s), 450 s, two runs sharing one GPU: its gait barely"
    " turns (b 6.69 m) and falls",
    "go1spd_s1": "as `go1spd_s0`, seed 1",
    "go1gain_s0": "the preset, heading loop open (seed 0), with the drive's gain"
    " (`commands.speed_gain_rate` 1), 300 s: its feed-forward measured under the gain (map 0.25"
    " … 1.01 m/s, v_ref 1.01)",
    "go1gain_s1": "as `go1gain_s0`, seed 1",
    "go1gain_s2": "as `go1gain_s0`, seed 2",
    "go1gain2_s0": "the preset, heading loop open (seed 0), with the drive's gain, 300 s, its"
    " feed-forward measured with the gain off",
    "go1gain2_s1": "as `go1gain2_s0`, seed 1",
    "go1gain2_s2": "as `go1gain2_s0`, seed 2",
    "go1loops_s0": "the preset (seed 0): the drive's gain (1/s) and heading loop (2/s) closed,"
    " 300 s",
    "go1loops_s1": "as `go1loops_s0`, seed 1",
    "go1loops_s2": "as `go1loops_s0`, seed 2",
    "go2long_s0": "the preset, loops open (Go2, seed 0), 540 s:"
    " `../policies/unitree_go2_command` at commit c65e57b",
    "go2loops_s0": "the preset (Go2, seed 0): the drive's loops closed, 300 s",
    "go2loops540_s0": "as `go2loops_s0`, 540 s",
    "go1loops540_s0": "as `go1loops_s0`, 540 s: its best evaluation the searched gait (step 0)",
    "anymal_conf_s0": "the preset, loops open, gait search `min_speed` 0.15, its 16 best confirmed"
    " on 256 robots each (ANYmal C), 540 s: the best fell in 11.7 %, v_ref 0.80 kept",
    "anymal_it20_300_s0": "as `anymal_conf_s0` with 20 / 20 solver iterations, 300 s, MJX-Warp:"
    " the best confirmed fell in 4.7 %, v_ref 0.44 with a map",
    "anymal_cmd_s0": "the preset with its ANYmal C settings (servos kp 300, kd 4; 20 / 20"
    " iterations; search floored at 0.15 m/s, confirmed on 256 robots), 540 s, MJX-Warp",
    "anymal_cap_s0": "as `anymal_cmd_s0` with the drive's turn capped at 0.4 rad/s, 420 s",
    "anymal_reward_s0": "as `anymal_cap_s0`, the yaw term on the yaw rate low-passed over 0.25 s,"
    ' "moving" along the heading (the preset then), 480 s: its best evaluation the searched gait'
    " (step 0; `../policies/anybotics_anymal_c_command` at commit efcb692)",
    "go1warp_s0": "the preset (seed 0), 300 s, MJX-Warp, two runs sharing one GPU",
    "go2warp_s0": "as `go1warp_s0`, Go2",
    "go1tau_s0": "the preset (seed 0) with ANYmal C's reward: the yaw rate low-passed over 0.25 s,"
    ' "moving" along the heading; 450 s, MJX-Warp, two runs sharing one GPU',
    "go2tau_s0": "as `go1tau_s0`, Go2",
}
ANYMAL = {  # run in campaign.json -> its change from `anymal_it20_300_s0` (first row)
    "anymal_it20_300_s0": "— (alone on the GPU)",
    "anymal_ref_s0": "search under the trained scales: v_ref 0.4, `scale_max` 1.0; 540 s, 3 runs"
    " on one GPU",
    "anymal_per_s0": "period floor 0.25 s; 540 s, 3 runs on one GPU",
    "anymal_refper_s0": "both; 540 s, 3 runs on one GPU",
    "anymal_per25_300_s0": "period floor 0.25 s; 2 runs on one GPU",
    "anymal_per30_300_s0": "period floor 0.30 s; 2 runs on one GPU",
    "anymal_per30ms30_300_s0": "period floor 0.30 s, gait search `min_speed` 0.3; 2 runs on one"
    " GPU",
    "anymal_per30as40_300_s0": "period floor 0.30 s, action bounds 0.4; 2 runs on one GPU",
    "anymal_per30ms30_s0": "period floor 0.30 s, gait search `min_speed` 0.3; 540 s, alone,"
    " 1024 episodes",
    "anymal_trot_s0": "from the open-loop trot below (no search), its feed-forward measured on it,"
    " period floor 0.25 s; 540 s, a GPU each, 1024 episodes",
    "anymal_trot_as10_s0": "as `anymal_trot_s0`, action bounds 0.1",
    "anymal_servo300_s0": "servos kp 300, kd 4 (the MJCF's: kp 100); 540 s, MJX-JAX, 2 runs on"
    " one GPU: the search took 776 s, SAC 270 k env steps with its actor not yet learning",
    "anymal_servo300rhythm_s0": "servos kp 300, kd 4, from `servo_gains.py`'s fastest kp-300"
    " rhythm (no search), its feed-forward measured on it; as `anymal_servo300_s0`",
    "anymal_cmd_s0": "`--preset=command` without the turn cap (servos kp 300, kd 4, the drive's"
    " loops closed); 540 s, alone, 1024 episodes",
    "anymal_cap_s0": "`--preset=command` with the drive's turn capped at 0.4 rad/s; 420 s, alone,"
    " 1024 episodes",
    "anymal_tau_s0": "from `anymal_cap_s0`'s gait and feed-forward (no search), the yaw term on"
    " the yaw rate low-passed over 0.25 s; 420 s, 2 runs on one GPU, 1024 episodes",
    "anymal_tauhd_s0": "as `anymal_tau_s0`, r_s's \"moving\" along the heading",
    "anymal_reward_s0": "`--preset=command` as it is: both (the yaw rate low-passed, \"moving\""
    " along the heading), its gait searched under them; 480 s, alone, 1024 episodes",
}
NO_PRESET = {  # run in campaign.json -> what it loads: Go1's MJCF by its path against the preset
    "go1path5_300_s0": "Go1's MJCF by its path: the solver probe's physics, loops open",
    "go1ref200_s0": "`menagerie:unitree_go1`: the preset's physics (rate only, 200 s)",
    "go1pathloops_s0": "Go1's MJCF by its path, the drive's loops closed (the preset)",
}
# the command preset as it is (the yaw rate low-passed, w4 x3, the kept policy ranked against
# step 0 every 2 M env steps), 480 s from nothing: Go1's three seeds and Go2's sharing one GPU,
# ANYmal C's two another
PRESET = ("go1cmd_tauyaw3gait_s0", "go1cmd_tauyaw3gait_s1", "go1cmd_tauyaw3gait_s2",
          "go2cmd_tauyaw3gait_s0", "go1cmd_base_s0", "go1cmd_base_s2", "anymalcmd_s0",
          "anymalcmd_s1")
# the preset with the kept policy chosen among evaluations within 0.10 rad of roll and pitch
# error (`sac.best_policy_max_attitude`, lever `att`): Go1's three seeds two sharing one GPU,
# Go2's sharing another with Go1 seed 2 and ANYmal C's `anymalcmd_nstep3_s0`
ATTITUDE = ("go1cmd_att_s0", "go1cmd_att_s1", "go1cmd_att_s2", "go2cmd_att_s0")
# the preset with the gait search ranking only gaits within 0.085 rad of mean peak roll and pitch
# error (`sac.gait_search.max_attitude`, lever `searchatt`): Go1's three seeds and Go2's sharing
# one GPU; then Go1's three with the best 32 gaits confirmed on 128 robots each (`searchattc`:
# `sac.gait_search.confirm_robots`), sharing one GPU with two ANYmal C runs
SEARCH_ATTITUDE = ("go1cmd_searchatt_s0", "go1cmd_searchatt_s1", "go1cmd_searchatt_s2",
                   "go2cmd_searchatt_s0", "go1cmd_searchattc_s0", "go1cmd_searchattc_s1",
                   "go1cmd_searchattc_s2")
# the preset with the gait chosen among the search's 4 best by its tracking of random commands
# (`sac.gait_search.track_gaits` 4, lever `tracked`): Go1's three seeds sharing one GPU with
# `anymalfix_turn10caps10_s0`
TRACKED = ("go1cmd_tracked_s0", "go1cmd_tracked_s1", "go1cmd_tracked_s2")
# the same with each finalist's attitude scored too (`sac.gait_search.track_attitude` 0.1, lever
# `trackatt`): Go1's three seeds and Go2's sharing one GPU with `anymalfix_turn10heldcaps10_s0`
TRACK_ATTITUDE = ("go1cmd_trackatt_s0", "go1cmd_trackatt_s1", "go1cmd_trackatt_s2",
                  "go2cmd_trackatt_s0")
# the same among the search's 8 best (lever `trackatt8`): Go1's three seeds sharing one GPU
TRACK_ATTITUDE8 = ("go1cmd_trackatt8_s0", "go1cmd_trackatt8_s1", "go1cmd_trackatt8_s2")
# ... of a search that ranks only gaits within 0.085 rad (lever `searchtrackatt8`: searchatt's
# bound): Go1's three seeds sharing one GPU
SEARCH_TRACK_ATTITUDE8 = ("go1cmd_searchtrackatt8_s0", "go1cmd_searchtrackatt8_s1",
                          "go1cmd_searchtrackatt8_s2")
# ... among its 16 best (lever `searchtrackatt16`): Go1's three seeds sharing one GPU
SEARCH_TRACK_ATTITUDE16 = ("go1cmd_searchtrackatt16_s0", "go1cmd_searchtrackatt16_s1",
                           "go1cmd_searchtrackatt16_s2")
# ... with the training evaluations' robots in the four robustness conditions, the kept policy
# ranked against step 0 in each (`randomization.eval_conditions`, lever `searchtrackatt16cond`):
# Go1's three seeds sharing one GPU
SEARCH_TRACK_CONDITIONS16 = (
    "go1cmd_searchtrackatt16cond_s0",
    "go1cmd_searchtrackatt16cond_s1",
    "go1cmd_searchtrackatt16cond_s2",
    "go2cmd_searchtrackatt16cond_s0",
)
# ... with 2 updates per env step, not 8 (ANYmal C's lever, `sac.updates_per_step`): Go1's three
# seeds and Go2's sharing one GPU
CONDITIONS16_UPDATES2 = ("go1cmd_upd2_s0", "go1cmd_upd2_s1", "go1cmd_upd2_s2", "go2cmd_upd2_s0")
# ... with the training evaluations 20 s long, as measure.py's episodes (`sac.eval_episode_length`
# 1000, the preset 400): Go1's three seeds and Go2's sharing one GPU
CONDITIONS16_EVAL20 = ("go1cmd_ev20_s0", "go1cmd_ev20_s1", "go1cmd_ev20_s2", "go2cmd_ev20_s0")
# the preset as it is (lever `preset`), each training evaluation group in its own condition:
# Go1's three seeds and Go2's sharing one GPU, then ANYmal C's seeds 0 and 1 sharing it
PRESET_CONDITIONS = ("go1cmd_preset_s0", "go1cmd_preset_s1", "go1cmd_preset_s2",
                     "go2cmd_preset_s0", "anymalcmd_preset_s0", "anymalcmd_preset_s1")
# levers against the 40-ms cell on the preset, seed 0: latency always 40 ms in training (`lat40`),
# a third of the draws at the ranges' ends (`ends`), and for ANYmal C `anchor10` with the groups
# read; Go1's and Go2's four sharing one GPU, then ANYmal C's two
LATENCY_LEVERS = ("go1cmd_lat40_s0", "go2cmd_lat40_s0", "go1cmd_ends_s0", "go2cmd_ends_s0",
                  "anymalcmd_lat40_s0", "anymalcmd_anchor10cond_s0")
# the preset with the critics observing what the policy cannot (`priv`: sac.privileged_critic),
# three runs sharing one GPU each time: seed 0 of each robot; Go1's seeds 1 and 2 with ANYmal C
# seed 0 with the actor's learning rate ÷10 as well; Go2's seeds 1 and 2 with ANYmal C seed 0
# anchored to its gait (λ 10)
PRIVILEGED = ("go1cmd_priv_s0", "go1cmd_priv_s1", "go1cmd_priv_s2", "go2cmd_priv_s0",
              "go2cmd_priv_s1", "go2cmd_priv_s2", "anymalcmd_priv_s0", "anymalcmd_privalr_s0",
              "anymalcmd_privanchor10_s0")
# ANYmal C's kept policy against SAC's evaluations (item 4), seed 0 with the preset from nothing
ANYMAL_SAC = {  # run in campaign.json -> its change from the preset, and how it shared the GPU
    "anymalcmd_s0": "— (two runs sharing one GPU)",
    "anymalfw900_s0": "w1 ×2 (`reward.forward` 900, the preset 450; two runs sharing one GPU)",
    "anymalyaw40_s0": "w4 ÷3 (`reward.yaw` 40, the preset 120; two runs sharing one GPU)",
    "anymalalone_s0": "— (alone on the GPU)",
    "anymalcmd_anchor10_s0": "λ‖μ(s)‖² in the actor's loss, λ 10 (`sac.smoothness.anchor`; two"
    " sharing)",
    "anymalcmd_anchor100_s0": "the same, λ 100 (two sharing)",
    "anymalcmd_nstep3_s0": "n-step returns, n 3 (`sac.n_step`; three sharing)",
    "anymalcmd_fw2250_s0": "w1 ×5 (`reward.forward` 2250; two sharing)",
    "anymalcmd_dist_s0": "a distributional critic, 101 atoms (`sac.critic_atoms`; two sharing)",
    "anymalfix_drive_s0": "the drive's state and the gyro observed (`commands.observe_drive`,"
    " `observe_angular_velocity`), `anymalcmd_dist_s0`'s gait given; 160 s alone, 512 episodes",
    "anymalfix_turn10_s0": "the turn action's reach ÷5 (`env.turn_bound` 0.1, the preset 0.5), the"
    " same gait given; 400 s, five runs sharing one GPU",
    "anymalfix_spdtau_s0": "the forward term on the speed low-passed over 0.25 s"
    " (`commands.speed_tau`), the same gait given; 400 s, five sharing",
    "anymalfix_turn10caps10_s0": "`anymalfix_turn10_s0`'s with CAPS's smoothness terms, 10 and 10"
    " (`sac.smoothness.temporal`, `spatial`); 480 s, four runs sharing one GPU",
    "anymalfix_turn10heldcaps10_s0": "`anymalfix_turn10caps10_s0`'s with the period and phases"
    " held at the gait's (`env.held_rhythm` period,phi1,phi3); 480 s, five runs sharing one GPU",
    "anymalcmd_condalr_s0": "the training evaluations' robots in the four robustness conditions"
    " (`randomization.eval_conditions`) and the actor's learning rate ÷10 (3e-5; two sharing)",
    "anymalcmd_condupd2_s0": "those conditions and 2 updates per env step, not 8"
    " (`sac.updates_per_step`: replay ratio 4, not 16; two sharing)",
    "anymalcmd_privfw6k_s0": "the privileged critic and w1 ×13 (`reward.forward` 6000; the preset"
    " with both ANYmal C settings, three runs sharing one GPU)",
    "anymalcmd_privfw2kyaw40_s0": "the privileged critic, w1 ×4 and w4 ÷3 (`reward.forward` 1800,"
    " `reward.yaw` 40; three sharing)",
    "anymalcmd_fw6k_s0": "w1 ×13 (`reward.forward` 6000; three sharing)",
    "anymalcmd_privwarm500_s0": "the privileged critic and the actor's warm-up ÷4 (500 updates,"
    " `sac.actor_warmup_steps`: the actor learns from env step 1.1 M; two runs sharing one GPU)",
    "anymalcmd_privwarm500fw6k_s0": "`anymalcmd_privwarm500_s0`'s with w1 ×13 (`reward.forward`"
    " 6000; two sharing)",
    "anymalcmd_privwarm500fw6kalone_s0": "`anymalcmd_privwarm500fw6k_s0`'s alone on the GPU",
    "anymalcmd_presetalone_s0": "— (the preset as it is, with both ANYmal C settings; alone on"
    " the GPU)",
    "anymalcmd_yaw40alone420_s0": "w4 ÷3 (`reward.yaw` 40, the preset 120); alone on the GPU for"
    " 420 s, not 480, training only",
    "anymalcmd_gain3_s0": "the drive's speed loop 3× faster (`commands.speed_gain_rate` 3, the"
    " preset 1; two runs sharing one GPU)",
    "anymalcmd_gain3filt5_s0": "the same and the action filter's τ 0.5 s (`env.action_filter_tau`,"
    " the preset 0.25 s; two sharing)",
    "anymalcmd_gain3alone440_s0": "the speed loop 3× faster alone on the GPU for 440 s, training"
    " only",
    "anymalcmd_presetalone_s2": "— (the preset as it is, seed 2; alone on the GPU, training"
    " only)",
    "anymalcmd_presetalone_s3": "— (the preset as it is, seed 3; alone on the GPU, training"
    " only)",
    "anymalcmd_filt5alone420_s0": "the action filter's τ 0.5 s (`env.action_filter_tau`, the preset"
    " 0.25 s); alone on the GPU for 420 s, training only",
    "anymalgait_base_s0": "— (`anymalcmd_presetalone_s0`'s gait given; three runs sharing one"
    " GPU, training only)",
    "anymalgait_clr_s0": "the critics' learning rate ÷3.3 (`sac.learning_rate.critic` 3e-4, the"
    " preset 1e-3), the same gait given; three sharing",
    "anymalgait_afix_s0": "α held at 0.01 (`sac.learning_rate.alpha` 1e-9), the same gait; three"
    " sharing",
    "anymalgait_clip_s0": "gradients clipped at norm 1 (`sac.max_grad_norm`), the same gait; three"
    " sharing",
    "anymalgait_tent_s0": "the target entropy −12 (`sac.target_entropy`; Brax's −0.5·dim(A), −3, by"
    " default), the same gait; three sharing",
    "anymalgait_alr_s0": "the actor's learning rate ÷10 (`sac.learning_rate.actor` 3e-5), the same"
    " gait; three sharing",
    "anymalgait_all_s0": "the five above together, the same gait; two runs sharing one GPU",
    "anymalgait_allslow_s0": "the five and the target critics 5× slower (`sac.tau` 0.001), the"
    " same gait; two sharing",
    "anymalfork_caps10_s0": "CAPS's smoothness terms 10 and 10 (`sac.smoothness.temporal`,"
    " `spatial`), the same gait, resumed from one run at the actor's start; 400 s, three sharing",
    "anymalfork_allcaps_s0": "the five (`anymalgait_all_s0`'s) and CAPS 10, 10, from the same"
    " start; 400 s, three sharing",
    "anymalfork_allrate_s0": "the five and the action-rate term 300 (`reward.action_rate`), from"
    " the same start; 400 s, three sharing",
    "anymalfork_allcaps30_s0": "the five and CAPS 30, 30, from the same start; 400 s, three"
    " sharing",
    "anymalfork_allcapsrate_s0": "the five, CAPS 10, 10 and the action-rate term 300, from the same"
    " start; 400 s, three sharing",
    "anymalfork_alldel_s0": "the five alone, from the same start (its `sac.policy_delay` 2 is the"
    " preset's own); 400 s, three sharing",
    "anymalfork_allhhip_s0": "the five and the hip amplitude held at the gait's (`env.held_rhythm`"
    " amplitude_hip), from the same start; 350 s, three sharing",
    "anymalfork_allhamp_s0": "the five and both amplitudes held (amplitude_knee,amplitude_hip),"
    " from the same start; 350 s, three sharing",
    "anymalfork_allslow5_s0": "the five with the actor's learning rate 1e-5 (not 3e-5), from the"
    " same start; 350 s, three sharing",
    "anymalfork_allcaps30fw1600_s0": "the five, CAPS 30, 30 and w1 1600 (`reward.forward`, the"
    " preset 450: a speed error of 0.10 m/s costs 8 a control step, not 2.25; the yaw term 18 for"
    " 0.15 rad/s), from the same start; 400 s, three sharing",
    "anymalfork_allcaps30g95_s0": "the five, CAPS 30, 30 and the discount 0.95 (`sac.discount`, by"
    " default 0.99), from the same start; 400 s, three sharing",
    "anymalfork_allg95_s0": "the five and the discount 0.95, from the same start; 400 s, three"
    " sharing",
    "anymalcmd_capsfw_s0": "`anymalfork_allcaps30fw1600_s0`'s settings from nothing (its own gait"
    " search, its actor from env step 4.16 M); alone on the GPU for 380 s",
    "anymalcmd_capsfw3600ev1_s0": "`anymalcmd_capsfw_s0`'s with w1 3600 (a speed error of 0.10 m/s"
    " costs 18 a control step, as the yaw term's 0.15 rad/s), evaluated every 1 M env steps; alone"
    " on the GPU for 270 s",
    "anymalcmd_switch_s0": "`anymalfork_allcaps30fw1600_s0`'s fork in one process from nothing:"
    " the preset with `sac.at_actor_start` set to its settings (the five, CAPS 30, 30, w1 1600),"
    " switched at env step 4.16 M; alone on the GPU for 480 s",
    "anymalcmd_switchrs028_s0": "`anymalcmd_switch_s0`'s with `sac.reward_scaling` 0.028 from the"
    " switch too (w1 1600's rewards on w1 450's scale); alone on the GPU for 480 s",
    "anymalcmd_switchrs028ends_s0": "`anymalcmd_switchrs028_s0`'s with a third of the"
    " randomisation's draws at its ranges' ends (`randomization.range_ends` 0.33); alone on the GPU"
    " for 480 s (the preset since)",
    "anymalcmd_switchrs028ends_s1": "the same, seed 1; alone on the GPU for 480 s",
}
SAC_LEVERS = {  # run in campaign.json (run_gpu.sh levers) -> its change from `base`
    "go2_base": "— (heading tracked, w1 150, Brax's critics, actor every update)",
    "go2_ln": "LayerNorm critics",
    "go2_rate": "yaw rate tracked",
    "go2_rate_ln": "yaw rate, LayerNorm",
    "go2_rate_fw3": "yaw rate, w1 450",
    "go2_rate_fw6": "yaw rate, w1 900",
    "go2_rate_ln_fw3": "yaw rate, w1 450, LayerNorm",
    "go2_rate_ln_fw3_d2": "yaw rate, w1 450, LayerNorm, actor every 2nd update",
}
GO1_LEVERS = {  # run in campaign.json (run_gpu.sh go1) -> its change from the preset
    "go1_base_s0": "— (the preset from `go1loops540_s0`'s searched gait)",
    "go1_lr_s0": "critic and temperature learning rates 3e-4 (the preset: 1e-3)",
    "go1_warm_s0": "the actor's warm-up 20,000 updates (2,000): about 10 M env steps",
    "go1_yaw3_s0": "the yaw term's weight w4 ×3 (120)",
    "go1_tau_s0": "the yaw term on the yaw rate low-passed over 0.25 s (`commands.yaw_rate_tau`)",
    "go1_tauyaw3_s0": "both",
    "go1_as10_s0": "action bounds 0.1 (`env.action_scale`; the preset 0.2)",
    "go1_tauas10_s0": "the yaw rate low-passed, action bounds 0.1",
    "go1_taueval2_s0": "the yaw rate low-passed, an evaluation every 2 M env steps (10 M)",
    "go1_tauyaw3eval2_s0": "the yaw rate low-passed, w4 ×3, an evaluation every 2 M env steps",
    "go1_gyro_s0": "the torso's angular velocity observed (`env.observe_angular_velocity`)",
    "go1_tauyaw3gyro_s0": "`go1_tauyaw3eval2_s0`'s, the angular velocity observed",
    "go1_tauyaw3track_s0": "`go1_tauyaw3eval2_s0`'s, the kept policy ranked by tracking"
    " (`sac.best_policy_by=tracking`)",
    "go1_tauyaw3gyrotrack_s0": "`go1_tauyaw3eval2_s0`'s, the angular velocity observed, ranked"
    " by tracking",
    "go1_rate300_s0": "the command's change charged, w_a 300 (`reward.action_rate`)",
    "go1_rate1000_s0": "the command's change charged, w_a 1000",
    "go1_tauyaw3trackrate300_s0": "`go1_tauyaw3track_s0`'s, the command's change charged, w_a 300",
    "go1_tauyaw3trackrate1000_s0": "`go1_tauyaw3track_s0`'s, the command's change charged, w_a"
    " 1000",
    "go1_tauyaw3gaitt330_s0": "`go1_tauyaw3eval2_s0`'s, the kept policy ranked against step 0"
    " (`sac.best_policy_by=gait`); 330 s, two runs sharing the GPU",
    "go1_tauyaw3trackendst330_s0": "`go1_tauyaw3track_s0`'s, a third of the randomisation's draws"
    " at its ranges' ends (`randomization.range_ends=0.33`); 330 s, two runs sharing the GPU",
}
