"""The run's config (`{"env": ..., "sac": ...}`), the named presets the CLI offers
(`--preset=`), and `build_config`: defaults, then a preset, then overrides, checked."""

import math
import re
from typing import Any

import ml_collections

from quadcos import env as env_lib
from quadcos import terrain as terrain_lib
from quadcos._util.cli import UsageError
from quadcos._util.overrides import apply_overrides, flat_keys
from quadcos.equations import oscillator
from quadcos.robot import sources as robot_sources
from quadcos.training import best_policy, checks, phases
from quadcos.training.config import default_config as sac_config

# Presets: overrides of the default config, applied before the flags. A preset's PER_ROBOT entry
# maps a robot's short name (`quadcos.robot.sources.short_name`: "anybotics_anymal_c" for
# menagerie:anybotics_anymal_c; a path loads none) to what the preset needs on that robot beyond
# its RobotPreset, applied after the preset and before the flags.
PER_ROBOT = "per_robot"
# SAC set up to start from the env's action centre (the fixed trot, or the gait a search found) and
# explore around it: a fresh
# policy's mean is the centre with a small exploration std, the prefill acts with it, and the
# actor waits until the critics have seen its data (experiments/README.md, "learning to walk").
_START_FROM_THE_TROT: dict[str, Any] = {
    "sac.policy_output_scale": 0.01,
    "sac.init_std": 0.15,
    "sac.init_alpha": 0.01,
    "sac.prefill_actions": "policy",
    "sac.actor_warmup_steps": 2_000,
}

PRESETS: dict[str, dict[str, Any]] = {
    # A complete, tiny run (a few minutes on two CPU cores, mostly compilation); used by tests.
    "smoke": {
        "sac.num_envs": 4,
        "sac.num_timesteps": 1_024,
        "sac.episode_length": 100,
        "sac.batch_size": 32,
        "sac.replay_size": 4_096,
        "sac.min_replay_size": 256,
        "sac.hidden_sizes.policy": (32, 32),
        "sac.hidden_sizes.q": (32, 32),
        "sac.steps_per_chunk": 32,
        "sac.eval_interval": 512,
        "sac.num_eval_envs": 2,
        "sac.eval_episode_length": 50,
        "sac.checkpoint_interval": 512,
    },
    # The paper's flat experiment at CPU scale: `make train`.
    "cpu": {
        "sac.num_envs": 32,
        "sac.num_timesteps": 200_000,
        "sac.episode_length": 500,
        "sac.batch_size": 256,
        # 4 updates per env step lose the trot at the actor's first updates and end no faster
        # than it; 12 learn past it (docs/decisions.md, "Experiments").
        "sac.updates_per_step": 12,
        "sac.replay_size": 200_000,
        "sac.min_replay_size": 4_096,
        "sac.hidden_sizes.policy": (128, 128),
        "sac.hidden_sizes.q": (128, 128),
        **_START_FROM_THE_TROT,
        "sac.reward_scaling": 0.1,
        "sac.learning_rate.actor": 3e-4,
        "sac.learning_rate.critic": 1e-3,
        "sac.learning_rate.alpha": 1e-3,
        "sac.steps_per_chunk": 100,
        "sac.eval_interval": 50_000,
        "sac.num_eval_envs": 16,
        "sac.eval_episode_length": 500,
        "sac.checkpoint_interval": 50_000,
    },
    # The fast path: thousands of robots on one GPU.
    "gpu": {
        "sac.num_envs": 4_096,
        "sac.num_timesteps": 10_000_000,
        "sac.episode_length": 1_000,
        "sac.batch_size": 8_192,
        # 1 update per step loses the trot at the actor's first updates; 8 learns
        # (experiments/flat_gpu).
        "sac.updates_per_step": 8,
        "sac.replay_size": 4_000_000,
        "sac.min_replay_size": 65_536,
        "sac.hidden_sizes.policy": (256, 256),
        "sac.hidden_sizes.q": (256, 256),
        **_START_FROM_THE_TROT,
        "sac.reward_scaling": 0.1,
        "sac.learning_rate.actor": 3e-4,
        "sac.learning_rate.critic": 1e-3,
        "sac.learning_rate.alpha": 1e-3,
        "sac.steps_per_chunk": 50,
        "sac.eval_interval": 2_000_000,
        "sac.num_eval_envs": 1_024,
        "sac.eval_episode_length": 400,
        "sac.checkpoint_interval": 2_000_000,
    },
}
# From scratch on one GPU (experiments/from_scratch): no gait is given. The run first searches
# constant rhythm parameters (quadcos.evaluation.gait_search, a few seconds on a GPU), then SAC
# starts from the gait found, exploring around it as the trot start does around the trot. Eq. 9's
# r_s is paid only while the robot moves (≥ 0.1 m/s, low-passed over 1 s): paid for standing too,
# SAC unlearns the found gait and stands (experiments/from_scratch, run scratch_alive_s0). 20 M env
# steps (about 3 minutes on an H100 with Warp): speed and pitch error still improve after 10 M;
# the policy of the best evaluation is kept beside the last, which one seed lost in its last
# million steps (experiments/from_scratch).
PRESETS["scratch"] = {
    **PRESETS["gpu"],
    "env.action_centre": "search",
    "env.survival_min_speed": 0.1,
    "sac.num_timesteps": 20_000_000,
    "sac.eval_interval": 1_000_000,
    "sac.keep_best_policy": True,
    # The kept policy is the best-rewarded evaluation among those with at most 1 % falls: ranked
    # by reward alone a faster policy that falls beats a slower one that never does (Eq. 13's fall
    # penalty r_p is paid once, Eq. 10's r_y every metre).
    "sac.best_policy_max_fall_rate": 0.01,
}
# One policy for any slope (experiments/any_slope): from scratch on a family of random courses of
# up to 12°, lane by lane (the course curriculum), robots spawned along them; the slope estimate and
# the oscillator's phase observed; front and hind hip offsets up to 0.6 rad; r_y paid up to
# 0.8 m/s; the best evaluation's policy kept; two lanes climbed a success, so that the curriculum
# reaches the steepest lanes within the budget: 300 s, and past the top lane a restart on the
# steeper half of the lanes, so that it stays there (worst held-out course 0.64-0.94 -> 0.94-0.98
# over seeds 0-2: experiments/any_slope/seeds.json, seeds_restart_all.json); the rhythm let in
# over an episode's first 0.25 s, which halves the step off from standing's attitude error on
# flat ground (without it: seeds_no_ramp.json).
PRESETS["any_slope"] = {
    **PRESETS["scratch"],
    "env.terrain": "random:max_deg=12,sections=3-5,len=1-3,seed=0",
    "env.spawn_x_max": 20.0,
    "env.observe_slope": True,
    "env.observe_phase": True,
    "env.posture_bound": 0.6,
    "env.forward_speed_cap": 0.8,
    "sac.episode_length": 400,
    "sac.gait_search.num_candidates": 1_024,
    "sac.gait_search.robots_per_candidate": 4,
    "sac.eval_interval": 10_000_000,
    "sac.num_timesteps": 400_000_000,
    "env.start_ramp_s": 0.25,
    "sac.curriculum.promote_lanes": 2,
    "sac.curriculum.restart_fraction": 0.5,
    "sac.max_seconds": 300.0,
}

# A flat policy robust to latency, pushes and slippery ground that keeps its speed
# (experiments/robustness: 4 of 4 seeds survive 40 ms of latency, 50-N pushes every 2 s and
# friction 0.4 in every episode at 0.91-1.00 m/s nominal). From scratch on flat with every domain
# randomisation on but friction (held at the MJCF's 1.5: a slippery range makes the search keep
# gaits that are slow on it), pushes as often as they are measured, observation noise; the
# rhythm's period down to 0.15 s (the paper's range is (0, 2] s; at the default 0.2 s the fastest
# gaits stood at the floor, under 0.8 m/s); a 20-s randomised gait search floored at 0.85 m/s whose
# best are confirmed on 64 robots each. The kept policy is, on each seed measured, the searched
# gait (SAC's later policies walk faster and fall more); SAC reaches 0.3 of each range around it.
PRESETS["robust"] = {
    **PRESETS["scratch"],
    "env.terrain": "flat",
    "env.period_min": 0.15,
    "env.action_scale": 0.3,
    "env.randomization.enabled": True,
    "env.randomization.obs_noise": 0.02,
    "env.randomization.friction": (1.5, 1.5),
    "env.randomization.push_interval_s": 2.0,
    "sac.gait_search.seconds": 20.0,
    "sac.gait_search.num_candidates": 1_024,
    "sac.gait_search.robots_per_candidate": 8,
    "sac.gait_search.rounds": 8,
    "sac.gait_search.min_speed": 0.85,
    "sac.gait_search.confirm_robots": 64,
    "sac.max_seconds": 300.0,
}

# A commanded, randomised policy on any robot (`--preset=command
# --robot=menagerie:unitree_go1`): from scratch on flat ground as `scratch` (the gait search, then
# SAC around the gait found), with velocity commands — v* and ω* drawn from the robot's ranges
# (quadcos.robot.presets; derived from its size where it has no preset) at every reset and every
# 5 s, observed and tracked by the reward (quadcos.env.commands) — and one more action value that
# turns (the left/right hip-amplitude difference: it works on 8- and 12-joint robots alike). Every
# domain randomisation is on, friction over its whole 0.4-1.5 range, 50-N pushes every 2 s on
# average, latency up to 40 ms, observation noise 0.02, drawn at a growing level over each robot's
# first 2 s. The command's feed-forward sets each side's stride from its commanded speed (a
# differential drive through a speed map measured on the gait found: quadcos.deploy.calibration),
# so SAC learns what the drive misses, within 0.2 of each rhythm range around the searched gait
# (with 0.5 SAC left the gait and stood: experiments/commands). The reward tracks the yaw rate
# rather than a heading the policy cannot see, low-passed over 0.25 s (the tracking metric's
# windows, not each stride's sway), its forward term and w4 ×3, and the critics carry LayerNorm
# with the actor updated every second step: with the heading, unnormalised critics or w1 = 150
# SAC lost to the searched gait (experiments/commands, "SAC's levers"). The kept policy is the
# evaluation (every 2 M env steps) that improves most on the run's step 0, the searched gait, in
# the worse of its speed and yaw-rate tracking: ranked by reward, no Go1 seed's kept policy beat
# its gait in every robustness condition; ranked so, each of three Go1 seeds' and Go2's did
# (experiments/commands, "The preset's shared settings"). The gait search scores candidates on
# the run's commanded reward under the drive. The drive's loops are closed in training as at
# deployment: its gain (1/s) removes the speed error the map leaves, its heading loop (2/s) the
# slow drift of the heading (quadcos.env.commands; with both, ranked by reward, Go1's three seeds
# tracked 0.091-0.103 m/s and 0.092-0.132 rad/s, without 0.102-0.128 and 0.139-0.153:
# experiments/commands). About 8 minutes on one GPU (max_seconds).
_LEVEL_TRACKED_GAIT_RANKED_BY_CONDITIONS = {
    "sac.gait_search.max_attitude": 0.085,
    "sac.gait_search.track_gaits": 16,
    "sac.gait_search.track_attitude": 0.1,
    "env.randomization.eval_conditions": "robustness",
}
_PRIVILEGED = {"sac.privileged_critic": True}
_ANYMAL_AT_ACTOR_START = ",".join((
    "sac.learning_rate.critic=3e-4", "sac.learning_rate.alpha=1e-9",
    "sac.learning_rate.actor=3e-5", "sac.max_grad_norm=1.0", "sac.target_entropy=-12",
    "sac.smoothness.temporal=30", "sac.smoothness.spatial=30", "env.reward.forward=1600",
    "sac.reward_scaling=0.028",
))
PRESETS["command"] = {
    **PRESETS["scratch"],
    "env.terrain": "flat",
    "env.commands.spec": "random",
    "env.commands.feed_forward": True,
    "env.commands.tracking": "yaw_rate",
    "env.commands.speed_gain_rate": 1.0,
    "env.commands.heading_gain": 2.0,
    "env.commands.yaw_rate_tau": 0.25,
    "env.reward.forward": 450.0,
    "env.reward.yaw": 120.0,
    "env.turn_mode": "hip_amplitude_difference",
    "env.observe_phase": True,
    "env.action_scale": 0.2,
    "env.period_min": 0.15,
    "env.randomization.enabled": True,
    "env.randomization.obs_noise": 0.02,
    "env.randomization.push_interval_s": 2.0,
    "env.randomization.ramp_s": 2.0,
    "sac.episode_length": 1_000,
    "sac.eval_episode_length": 400,
    "sac.num_timesteps": 400_000_000,
    "sac.eval_interval": 2_000_000,
    "sac.best_policy_by": "gait",
    "sac.gait_search.num_candidates": 1_024,
    "sac.gait_search.robots_per_candidate": 4,
    "sac.gait_search.seconds": 10.0,
    "sac.critic_layer_norm": True,
    "sac.policy_delay": 2,
    "sac.max_seconds": 480.0,
    PER_ROBOT: {
        # Go1 and Go2: the gait chosen among the 16 best level gaits of the search (roll and pitch
        # error within 0.085 rad) by its tracking of random commands and its attitude, and the
        # training evaluations' robots in the four robustness conditions, so that the kept policy
        # must beat its gait in each: Go1 seeds 0-2 and Go2 seed 0 meet every target; Go1 seeds 1
        # and 2 keep policies from training (12.1 and 6.0 M env steps of SAC) that track better
        # than their gaits in all eight (condition, measure) cells, Go1 seed 0 and Go2 keep their
        # gaits (no evaluation of SAC's beat step 0 at 40 ms). With the search's best gait every
        # Go1 seed kept a policy better in all 36 cells, but two of three missed a target; with
        # the shared settings Go2's kept policy pitched 0.112 rad (experiments/commands, "The
        # preset with each condition's group read", "Gaits chosen by their tracking"). Their
        # critics observe what the policy cannot (the robot's draw, the push, the pending action,
        # the drive's state): with it Go1's three seeds and Go2's seeds 0 and 1 (of three) keep
        # policies from training (6.0-17.1 M env steps) that beat their gaits in all eight cells,
        # and all six meet every target, where without it Go1's seed 0 and Go2's kept step 0;
        # ANYmal C's kept step 0 either way (experiments/commands, "A privileged critic").
        "unitree_go1": _LEVEL_TRACKED_GAIT_RANKED_BY_CONDITIONS | _PRIVILEGED,
        "unitree_go2": _LEVEL_TRACKED_GAIT_RANKED_BY_CONDITIONS | _PRIVILEGED,
        # ANYmal C's MJCF servos (kp 100 for 45 kg) sag under an open-loop rhythm: with them no
        # search kept a gait that walks 0.15 m/s without falls (with its preset's 4 / 8 solver
        # iterations the searched gaits fell in 12 % of episodes and more). With kp 300, kd 4,
        # 20 / 20 iterations and candidates asked for 0.15 m/s, their best confirmed on 256
        # robots, the searched gait tracks 0.080 m/s and 0.140 rad/s under random commands and
        # the training randomisation, 0.998 surviving (experiments/commands, "ANYmal C levers":
        # anymal_servo300_s0), and walks C MuJoCo at 0.66-0.73 m/s at every friction. A gait's
        # turn by side differences goes only so far (less on low friction), and the drive's loops
        # wind a lagging turn up into strides at their clip: the drive turns at most 0.4 rad/s,
        # its command range (with the cap, a run's policy at friction 0.4 tracked 0.130 m/s and
        # 0.257 rad/s, without 0.344 and 0.362; docs/env.md, "The drive's turn cap"). Its reward
        # counts "moving" along its heading: with each step's yaw rate and "moving" along x, SAC
        # made its searched gait track worse and the run kept SAC's (0.095 m/s, 0.173 rad/s
        # against the gait's 0.074, 0.115); with the low-passed yaw rate and the heading the run
        # kept a gait tracking 0.063 m/s, 0.091 rad/s (experiments/commands, "ANYmal C
        # levers").
        "anybotics_anymal_c": {
            "env.commands.turn_max": 0.4,
            "env.survival_speed_frame": "heading",
            "env.servo_kp": 300.0,
            "env.servo_kd": 4.0,
            "env.solver_iterations": 20,
            "env.ls_iterations": 20,
            "sac.gait_search.min_speed": 0.15,
            "sac.gait_search.confirm_robots": 256,
            # 2 updates per env step, not 8 (replay ratio 4, not 16: Raffin's low replay ratio for
            # SAC on massively parallel envs), the training evaluations in the four robustness
            # conditions: seeds 0 and 1 keep their searched gaits, within every target (SAC's
            # evaluations trail step 0 in a condition, by 1.37-1.99 from 6 M env steps on), and
            # so do seeds 0, 2 and 3 alone on a GPU (1.03-2.87 over 23-26 M env steps). With
            # each condition's group mixing all four, seed 0 kept a policy from 8.1 M env steps,
            # no worse than its gait in any of the 12 (condition, measure) cells (the shipped
            # one); with 8 updates none of fifteen runs of other levers did (experiments/commands,
            # "ANYmal C: SAC against its searched gait").
            "sac.updates_per_step": 2,
            "env.randomization.eval_conditions": "robustness",
            # As the actor starts (env step 4.16 M), SAC's five settings against its critics'
            # loss growth (critic and temperature learning rates, actor's ÷10, gradients clipped,
            # target entropy), CAPS's smoothness at 30 and the forward term w1 1600 with the
            # rewards scaled by 0.028, not 0.1 (w1 1600's rewards on w1 450's scale); a third of
            # the randomisation's draws at its ranges' ends throughout. Seeds 0 and 1, alone on a
            # GPU, keep policies from training (6.0 and 18.1 M env steps) that track better than
            # their gaits in all eight (condition, measure) cells (seed 1's searched gait, and so
            # its policy, misses the speed target), where without the ends seed 0 kept its
            # gait, its best evaluations behind it only in the speed at friction 0.4
            # (experiments/commands, "From one state at the actor's start").
            "sac.at_actor_start": _ANYMAL_AT_ACTOR_START,
            "env.randomization.range_ends": 0.33,
        },
    },
}


def default_config() -> ml_collections.ConfigDict:
    """The whole run's config: {"env": env config, "sac": trainer config}."""
    config = ml_collections.ConfigDict()
    config.env = env_lib.default_config()
    config.sac = sac_config()
    return config


def build_config(base: dict[str, Any], overrides: dict[str, Any]) -> ml_collections.ConfigDict:
    """default_config() with `base`, then its PER_ROBOT settings for the robot the run loads, then
    `overrides` applied, then checked (terrain spec, env and trainer values) so that a bad value
    is reported before anything is built or written."""
    try:
        base = dict(base)
        per_robot = base.pop(PER_ROBOT, {})
        config = apply_overrides(default_config(), base)
        robot = overrides.get("env.robot", config.env.robot)
        config = apply_overrides(config, per_robot.get(robot_sources.short_name(str(robot)), {}))
        overrides = _expand_groups(overrides, flat_keys(config))
        centre = overrides.get("env.action_centre")
        if isinstance(centre, tuple) and all(isinstance(v, (int, float)) for v in centre):
            overrides["env.action_centre"] = oscillator.centre_spec(centre)  # A_k,A_h,T,φ1,φ3
        non_finite = {
            key: value
            for key, value in overrides.items()
            if isinstance(value, float) and not math.isfinite(value)
        }
        finite = {key: value for key, value in overrides.items() if key not in non_finite}
        config = apply_overrides(config, finite)
        # apply_overrides refuses non-finite floats before any range check: set them here, so
        # that the checks below name the allowed range.
        for key, value in non_finite.items():
            try:
                apply_overrides(config, {key: 1.0})  # the key exists and takes floats
            except ValueError:
                apply_overrides(config, {key: value})  # raises naming the key and the value
            *parents, leaf = key.split(".")
            node = config
            for parent in parents:
                node = node[parent]
            node[leaf] = value
        terrain_lib.parse(config.env.terrain)
        env_lib.validate_config(config.env)
        _check_sac(config.sac)
        if config.sac.at_actor_start.strip():
            if not config.sac.actor_warmup_steps:
                raise ValueError(
                    "config.sac.at_actor_start needs config.sac.actor_warmup_steps > 0"
                )
            second = phases.second(config)
            env_lib.validate_config(second.env)
            _check_sac(second.sac)
        by = config.sac.best_policy_by
        if config.sac.keep_best_policy and by in best_policy.TRACKED and not config.env.commands.spec:
            raise ValueError(
                f"config.sac.best_policy_by {by!r} ranks evaluations by command tracking: it"
                " needs config.env.commands.spec"
            )
        randomization = config.env.randomization
        if randomization.eval_conditions.strip() and not randomization.enabled:
            raise ValueError(
                "config.env.randomization.eval_conditions needs config.env.randomization.enabled"
            )
        if non_finite:  # in range, as far as the checks above know
            key, value = next(iter(non_finite.items()))
            raise ValueError(f"bad value {value} for config key {key!r}: it must be finite")
    except (ValueError, TypeError, FileNotFoundError) as error:
        raise UsageError(str(error)) from None
    return config


def _check_sac(config: ml_collections.ConfigDict) -> None:
    """`checks.check_config`, its errors naming fields as config.sac.<key>."""
    try:
        checks.check_config(config)
    except checks.ConfigError as error:  # it names fields as config.<sac key>
        raise ValueError(re.sub(r"\bconfig\.", "config.sac.", str(error))) from None


def _expand_groups(overrides: dict[str, Any], known: list[str]) -> dict[str, Any]:
    """A group key (`sac.learning_rate`) as each of its values (`sac.learning_rate.actor`, ...)."""
    expanded = {}
    for key, value in overrides.items():
        members = [name for name in known if name.startswith(key + ".")]
        expanded |= dict.fromkeys(members, value) if members and key not in known else {key: value}
    return expanded
