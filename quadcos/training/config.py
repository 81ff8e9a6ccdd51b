"""Configuration of the SAC trainer."""

from typing import Any

import ml_collections
from ml_collections import config_dict

from quadcos._util.overrides import flatten

# Trainer config fields no program reads: the host loop's, the checkpoints' and the keys' (the
# keys are arguments of the programs, not constants). Trainers and their traced programs are
# shared by configs that differ only in these (`reuse.for_run`, `quadcos._util.caches.Program`).
HOST_FIELDS = frozenset(
    {
        "seed",
        "num_timesteps",
        "eval_interval",
        "checkpoint_interval",
        "keep_checkpoints",
        "save_replay",
        "best_policy_by",
        "best_policy_tracking_targets",
        "best_policy_max_attitude",
        "at_actor_start",
    }
)


def program_fields(config: ml_collections.ConfigDict) -> dict[str, Any]:
    """The trainer config's fields that its programs read: all but `HOST_FIELDS`, flattened."""
    return {k: v for k, v in flatten(config.to_dict()).items() if k not in HOST_FIELDS}


def prefill_steps(config: ml_collections.ConfigDict) -> int:
    """Steps of the `num_envs` envs that fill the replay to `min_replay_size` before the first
    update (each `num_envs` env steps)."""
    return -(-config.min_replay_size // config.num_envs)


def default_config() -> ml_collections.ConfigDict:
    """Returns a fresh, locked SAC trainer config (unknown keys are an error).

    Units: "env steps" count transitions, so one vectorised step of all
    `num_envs` environments is `num_envs` env steps.
    """
    config = ml_collections.ConfigDict()
    _interaction(config)
    _sac(config)
    _gait_search(config)
    _curriculum(config)
    _host_loop(config)
    config.lock()
    return config


def _interaction(config: ml_collections.ConfigDict) -> None:
    """How many envs step, for how long."""
    # Training environments stepped in parallel (one vectorised step).
    config.num_envs = 256
    # Env steps to train for, prefill included. Training stops at the first
    # chunk boundary at or past it, so it may overshoot by less than a chunk.
    config.num_timesteps = 5_000_000
    # s from the process's start (0: no limit): the run ends at the first chunk boundary after it
    # as it ends at num_timesteps (evaluation, checkpoint, policy/, policy_best/). Not carried
    # across --resume: each process gets its own budget.
    config.max_seconds = 0.0
    # Env steps after which a training episode is truncated (not a fall:
    # the critic does not treat truncation as a terminal state).
    config.episode_length = 1000


def _sac(config: ml_collections.ConfigDict) -> None:
    """SAC's own settings (Haarnoja et al. 2018), exploration, networks and replay."""
    # Transitions per gradient update.
    config.batch_size = 256
    # Initial entropy temperature α (then tuned automatically, as in Brax's SAC). A small value
    # keeps early exploration near the action centre.
    config.init_alpha = 1.0
    # Target entropy of the temperature tuning; None: Brax's −0.5 · action_size. Lower values
    # make the exploring policy's actions stay closer to its mean.
    config.target_entropy = config_dict.placeholder(float)
    # Scale of the policy's output layer at initialisation (1: Brax's init); < 1 starts the
    # policy's mean action near 0, the env's action centre.
    config.policy_output_scale = 1.0
    # Exploration std (pre-tanh) of a fresh policy; None: Brax's init (softplus(0) ≈ 0.69). A
    # gait that noise of ~0.1 on its phases already topples needs a small start (see
    # experiments/README.md); the temperature tuning then moves it towards `target_entropy`.
    config.init_std = config_dict.placeholder(float)
    # Mean number of vectorised env steps an env holds its exploration draw (policy noise, and
    # the prefill's uniform actions); 1 = a fresh draw every step (Brax). Held noise explores
    # whole gaits of a rhythm controller rather than jitter (experiments/from_scratch).
    config.noise_hold_steps = 1
    # Gradient updates (after the prefill) in which only the critics learn; the actor and the
    # temperature start afterwards.
    config.actor_warmup_steps = 0
    # Run-config overrides (KEY=VALUE words: "env.reward.forward=1600 sac.max_grad_norm=1.0") that
    # take effect as the actor starts learning, the critics having warmed up under the others;
    # rewards and learning settings only (quadcos.training.phases). "": none.
    config.at_actor_start = ""
    # The actor and the temperature learn in one gradient update of every `policy_delay` (TD3's
    # delayed policy update); the critics in every one.
    config.policy_delay = 1
    # LayerNorm after each hidden layer of the critics (FastTD3, SimBa): a Q that cannot grow
    # without bound under many updates per env step.
    config.critic_layer_norm = False
    # The critics also observe what the env knows and the policy does not (an asymmetric
    # actor-critic: an env's `privileged` inputs, quadcos.env.privileged: a randomised robot's
    # draw, pushes and pending action, clean velocities, the drive's state); the policy acts on
    # its observation alone.
    config.privileged_critic = False
    # Distributional critics (C51, as FastTD3 / FastSAC: quadcos.training.distributional): each
    # critic a categorical distribution over `critic_atoms` returns evenly spaced on
    # `critic_value_range` (v_min, v_max: the discounted returns of the scaled reward and the
    # entropy bonus, −α log π a step); targets beyond it are clipped to its ends. 0: Brax's
    # scalar twin Q.
    config.critic_atoms = 0
    config.critic_value_range = (-250.0, 250.0)
    # CAPS (Mysore et al. 2021): the actor's loss also charges `temporal` · the squared change of
    # its deterministic action from a state to the next and `spatial` · that to a state with
    # observation noise of `sigma` normaliser stds (quadcos.training.updates.smoothness_loss);
    # `anchor` · the squared distance of that action from the env's action centre (a from-scratch
    # run's searched gait); all 0: Brax's actor loss.
    config.smoothness = ml_collections.ConfigDict(
        dict(temporal=0.0, spatial=0.0, sigma=0.05, anchor=0.0)
    )
    # Gradient updates per vectorised env step, i.e. per `num_envs` new
    # transitions (replay ratio = updates_per_step * batch_size / num_envs).
    config.updates_per_step = 1
    # True: each env step's updates draw from the replay buffer as it stood before that step and
    # the envs act with the parameters before the updates, so the updates need not wait for the
    # physics (with XLA's concurrent command buffers the GPU runs them side by side:
    # docs/benchmarks.md). False: updates after the env step, on a buffer holding its transitions.
    config.overlap_updates = False
    # Replay capacity in transitions; the oldest are overwritten first.
    # Memory: replay_size * (2 * obs_size + action_size + 3) * 4 bytes.
    config.replay_size = 1_000_000
    # How the prefill acts: "uniform" random actions in [-1, 1] (Brax) or "policy", the fresh
    # policy's own exploration (with an action centre and a small init_std: the centre's gait).
    config.prefill_actions = "uniform"
    # Transitions collected with `prefill_actions` before learning starts
    # (again after resuming from a checkpoint saved without its replay buffer).
    config.min_replay_size = 8192
    # Hidden layer widths of the policy and of each of the two Q networks.
    config.hidden_sizes = ml_collections.ConfigDict(dict(policy=(256, 256), q=(256, 256)))
    # Adam learning rates of the actor, the critics and the temperature.
    config.learning_rate = ml_collections.ConfigDict(dict(actor=3e-4, critic=3e-4, alpha=3e-4))
    # Discount factor gamma of the soft Bellman target.
    config.discount = 0.99
    # Rewards each stored transition sums before the critic's target bootstraps: up to n steps
    # of its episode (quadcos.training.n_step; FastTD3 uses 3). 1: Brax's one-step transitions.
    config.n_step = 1
    # Polyak rate of the target Q networks: target <- (1 - tau) target + tau q.
    config.tau = 0.005
    # Rewards are multiplied by this in the critic target.
    config.reward_scaling = 1.0
    # Standardise observations with running mean/std (Welford) before the MLPs.
    config.normalize_observations = True
    # Clip actor and critic gradients to this global norm; None: no clipping.
    config.max_grad_norm = config_dict.placeholder(float)
    # Seeds network init, env resets, exploration and replay sampling.
    config.seed = 0
    # Devices the run spreads over, data-parallel (quadcos.training.parallel); None: every device
    # of every process. num_envs, batch_size, replay_size and num_eval_envs stay global and must
    # divide evenly by it.
    config.num_devices = config_dict.placeholder(int)


def _gait_search(config: ml_collections.ConfigDict) -> None:
    """The gait search of a from-scratch run."""
    # A from-scratch run's first phase (quadcos.evaluation.gait_search, timed with the run): a
    # population search over constant rhythm parameters (A_k, A_h, T, φ1, φ3), round 1 uniform
    # over §3.3's ranges, later rounds around the `elite` best; a candidate scores its robots' mean
    # Eq. 13 episode reward when none fell. The best becomes the action centre SAC starts from.
    # symmetric: candidates keep φ3 = φ1 − π (mirror-symmetric gaits; SAC may leave it later).
    # min_speed: m/s a candidate's robots must reach to be ranked (0: any speed): on average, or
    # with min_speed_of="slowest" each of them (under randomisation: on every robot drawn).
    # max_attitude: rad a candidate's robots' mean peak roll and pitch error must stay within to
    # be ranked (0: any): SAC hardly changes the searched gait's attitude (experiments/commands).
    # confirm_robots: after the rounds, the best distinct candidates run once more on that many
    # robots each (as many as the batch holds; 0: none) and the gait kept is the best of that
    # run — the clean ones by reward, else the one that fell least.
    # track_gaits: with the command's feed-forward, its measurement on that many of the best
    # gaits that turn both ways (not only the best), each then walked under random commands and
    # the run's randomisation (quadcos.evaluation.gait_tracking), and the gait kept is the one
    # that tracks best without a fall (within max_attitude, where set); 0: the best only.
    # track_attitude: rad; > 0: "tracks best" also scores each of them by its mean peak roll and
    # pitch error against this target (gait_tracking.score: the worst of its ratios to 0.10 m/s,
    # 0.15 rad/s and this), so a gait that tracks but rolls ranks below a level one; 0: off.
    # compile_trainer: the run's envs and trainer built before the search on a placeholder gait,
    # their programs compiling while it runs (quadcos.training.ahead; a fresh run on one device).
    # max_fraction: in a run with a time budget (max_seconds), the search runs no round (nor its
    # confirmation) that would end past this fraction of the budget, as timed by the round before
    # (0: every round).
    config.gait_search = ml_collections.ConfigDict(
        dict(
            num_candidates=2048,
            robots_per_candidate=2,
            rounds=6,
            elite=16,
            seconds=5.0,
            symmetric=True,
            min_speed=0.0,
            min_speed_of="mean",
            max_attitude=0.0,
            confirm_robots=0,
            track_gaits=0,
            track_attitude=0.0,
            compile_trainer=True,
            max_fraction=0.5,
        )
    )


def _curriculum(config: ml_collections.ConfigDict) -> None:
    """The course curriculum of a lane terrain."""
    # Each env runs on the lane of its level (a random: family's lanes are in order of slope):
    # up promote_lanes lanes after an episode without a fall that crossed its course or walked
    # promote_m m, down one after a fall or a time-out short of promote_m / 2 m
    # (quadcos.training.curriculum). A lane is climbed at most once an episode, so the pace is
    # episodes per env: with one lane a success 300-s any-slope runs reach lane 25-34 of 64, with
    # two (--preset=any_slope) lane 48-56 by 50 M env steps. Envs start on the
    # lowest start_fraction of the lanes; past the top lane an env restarts on a lane drawn
    # uniformly from the top restart_fraction of them. enabled=False: each env keeps the lane and
    # spawn point of its first reset (Brax's auto-reset).
    config.curriculum = ml_collections.ConfigDict(
        dict(
            enabled=True, start_fraction=0.25, promote_m=4.0, promote_lanes=1, restart_fraction=1.0
        )
    )


def _host_loop(config: ml_collections.ConfigDict) -> None:
    """The host loop: chunks, evaluations, checkpoints, the best policy."""
    # Vectorised env steps per compiled chunk; the host sees results (metrics,
    # NaN checks, signals) once per chunk.
    config.steps_per_chunk = 64
    # Env steps between evaluations (and metrics rows); an evaluation runs after
    # the first chunk that crosses each multiple, and once at the end.
    config.eval_interval = 100_000
    # Parallel deterministic evaluation episodes.
    config.num_eval_envs = 128
    # Env steps per evaluation episode (the time limit; ending earlier is a fall).
    config.eval_episode_length = 1000
    # Env steps between checkpoints (crossing rule as for evaluation); a
    # checkpoint is also written at the end and on SIGINT/SIGTERM.
    config.checkpoint_interval = 500_000
    # Checkpoints kept on disk (the newest ones); >= 2 allows falling back when
    # the newest one is corrupt.
    config.keep_checkpoints = 3
    # Also keep the policy of the best training-time evaluation (eval/episode_reward) in
    # run_dir/policy_best (its step and reward in its policy.json, under best_of_run): a run whose
    # last policy is worse than an earlier one (experiments/any_slope: the generalist's late
    # collapse into stalling) still yields the good one.
    config.keep_best_policy = False
    # With keep_best_policy: an evaluation that falls in at most this fraction of its episodes
    # beats every one that falls more, whatever their rewards (1.0: the reward alone ranks).
    config.best_policy_max_fall_rate = 1.0
    # With keep_best_policy: what ranks the evaluations on the same side of that bound: "reward"
    # (eval/episode_reward), or "tracking" for robots that follow velocity commands: the worse of
    # speed and yaw-rate tracking RMS relative to best_policy_tracking_targets (m/s, rad/s), or
    # "gait": the same relative to the run's step-0 evaluation (the gait it started from).
    config.best_policy_by = "reward"
    config.best_policy_tracking_targets = (0.10, 0.15)
    # With keep_best_policy, > 0: an evaluation whose robots roll or pitch off the slope by more
    # than this (rad, the mean of the episodes' peaks: eval/mean_max_abs_roll, _pitch_error)
    # ranks below every one within it, as a fall rate above the bound does (0: off).
    config.best_policy_max_attitude = 0.0
    # Store the replay buffer in checkpoints (exact resume, large files).
    config.save_replay = False
