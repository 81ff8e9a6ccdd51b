"""Soft Actor-Critic as one compiled program per chunk of env steps.

Built from Brax's SAC pieces (networks, losses, gradient updates, running statistics, training
wrappers) because stock `brax.training.agents.sac.train` calls `jax.device_put_replicated`, which
JAX 0.10 removed. One device, or data-parallel over several (`config.num_devices`,
`quadcos.training.parallel`): the same program, jitted on a state whose envs and replay buffer are
split over the devices (XLA partitions it); each device steps its envs, fills and samples its own
ring of the buffer, and the gradients are summed across devices.

One chunk is `steps_per_chunk` iterations of: act with the stochastic policy in all training envs,
guard against non-finite env outputs, insert the transitions into the replay buffer, update the
observation statistics, then `updates_per_step` SAC updates (Haarnoja et al. 2018,
arXiv:1812.05905). With `overlap_updates` the updates come first, on the buffer as it stood before
the env step, and the policy acts with the parameters before them: the updates and the env step no
longer depend on each other, so the GPU may run them side by side.
"""

import concurrent.futures
import functools
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import ml_collections
from brax import envs
from brax.envs.wrappers import training as training_wrappers
from brax.training import types
from brax.training.acme import running_statistics, specs
from brax.training.agents.sac import networks as sac_networks
from jax.sharding import PartitionSpec

from quadcos._util import caches
from quadcos.env import privileged
from quadcos.training import batched_envs, curriculum, networks, parallel, periodic_eval, updates
from quadcos.training import config as config_lib
from quadcos.training import n_step
from quadcos.training import replay as replay_lib
from quadcos.training import state as state_lib

Metrics = dict[str, jax.Array]
PREFILL_ACTIONS = ("uniform", "policy")
MIN_STD = networks.MIN_STD
make_networks = networks.make_networks
TrainingState = state_lib.TrainingState


class SACTrainer:
    """The compiled pieces of SAC training for one env and one config.

    `init`, `prefill`, `train_chunk` and `evaluate` are jitted; `prefill` and
    `train_chunk` donate the training state passed to them. `chunk_traces`
    counts how often `train_chunk` was traced (it should be once).
    """

    def __init__(
        self,
        env: envs.Env,
        config: ml_collections.ConfigDict,
        eval_env: envs.Env | None = None,
    ):
        """Builds networks, losses and wrapped envs.

        Args:
          env: unbatched, unwrapped Brax env; wrapped here with Vmap, Episode
            (time limit `episode_length`) and AutoReset wrappers (on a lane terrain, the course
            curriculum in AutoReset's place: `quadcos.training.curriculum`).
          config: see `quadcos.training.config.default_config`.
          eval_env: unbatched env for evaluation; `env` when None.
        """
        # A private copy: the traced functions read it when they are compiled.
        self.config = config.copy_and_resolve_references()
        self.env = curriculum.wrap(env, config.episode_length, config.curriculum)
        self.eval_env = training_wrappers.VmapWrapper(eval_env or env)
        # A quadcos env's gait (what a gait search sets: the action map's centre, the drive's
        # map) goes into the env states as data, an argument of init and the evaluation: their
        # programs serve every gait.
        self._gait = state_lib.gait_of(env)
        self._eval_gait = state_lib.gait_of(eval_env or env)
        # Jitted once and called inside init, prefill and the chunk: tracing the MJX reset and
        # step is most of a small run's start-up, and a nested jit is traced once for all three.
        self.layout = parallel.make_layout(config.num_devices)
        parallel.check_divisible(config, self.layout.shards)
        shards = self.layout.shards
        if config.n_step > 1 and shards > 1:
            raise ValueError(
                f"config.n_step={config.n_step} runs on one device; this run spans {shards}"
                " (--config.sac.num_devices=1, or n_step 1)"
            )
        self._reset_envs, self._step_envs = batched_envs.reset_and_step(
            self.env, self.layout, config.num_envs, self._gait, getattr(env, "impl", "jax")
        )
        self.observation_size = batched_envs.observation_size(
            env, self._reset_envs, config.num_envs
        )
        self.action_size = env.action_size
        # privileged_critic: the critics observe more than the policy, stored after its obs
        extra = privileged.of(env) if config.privileged_critic else privileged.Privileged(0, None)
        self._privileged, critic_size = extra.observe, self.observation_size + extra.size
        self.critic_observation_size = critic_size
        critics = networks.make_critics(critic_size, self.action_size, config)
        self.networks = make_networks(
            self.observation_size,
            self.action_size,
            config.hidden_sizes.policy,
            config.hidden_sizes.q,
            config.normalize_observations,
            config.critic_layer_norm,
            critics,
            critic_size,
        )
        self._make_policy = sac_networks.make_inference_fn(self.networks)
        self._sgd_step = updates.SACUpdate.from_config(
            config, self.networks, self.action_size, critics
        )
        self.replay = replay_lib.for_transitions(
            config.replay_size, shards, critic_size, self.action_size
        )
        self.num_prefill_steps = config_lib.prefill_steps(config)
        self._key_init, self._eval_key = jax.random.split(jax.random.PRNGKey(config.seed))
        self.chunk_traces = 0
        programs = config_lib.program_fields(config)
        fingerprint = caches.trainer_fingerprint(env, eval_env, programs, self.layout.mesh is None)
        self._compile(config, getattr(env, "compiler_options", None) or None, fingerprint)

    def _compile(
        self, config: ml_collections.ConfigDict, options: dict | None, fingerprint: str | None
    ) -> None:
        """Jits `init`, `prefill`, `train_chunk` and the evaluation, placed on the devices of
        `self.layout`. `options`: XLA's options for the programs that step the training envs
        (none but with MJX-Warp's calls recorded by XLA: `quadcos.env.backends.compiler_options`).
        Not the evaluation's: with them its program took 55 s more to compile (one H200) for no
        gain to speak of. With a `fingerprint` (`caches.trainer_fingerprint`: one device,
        MJX-JAX) each is a `caches.Program`, traced once and kept on disk."""
        self._eval_keys = jax.random.split(self._eval_key, config.num_eval_envs)
        self._specs = None  # where each part of the state lives; on one device, nowhere to say
        if fingerprint is not None:
            self._init = caches.Program(self._init_state, "init", fingerprint)
            self.prefill = caches.Program(self._prefill, "prefill", fingerprint, donate=True)
            self.train_chunk = caches.Program(
                self._train_chunk, "train_chunk", fingerprint, donate=True
            )
            self._evaluate_compiled = caches.Program(self._evaluate, "evaluate", fingerprint)
            return
        self._init = jax.jit(self._init_state)
        if self.layout.mesh is not None:  # a one-argument program: the gait a constant of it
            init = functools.partial(self._init_state, gait=self._gait)
            self._specs = parallel.state_specs(
                jax.eval_shape(init, self._key_init),
                ("env_state", "exploration_noise", "replay"),
                config.num_envs,
            )
            self._init = parallel.jit(init, self.layout, None, self._specs)
        self.prefill = parallel.jit(
            self._prefill, self.layout, self._specs, self._specs, True, options
        )
        self.train_chunk = parallel.jit(
            self._train_chunk, self.layout, self._specs, (self._specs, None), True, options
        )
        # The keys are an argument, not a constant of the program: runs of any seed share it (and
        # the persistent compilation cache's copy). On several devices each device runs its share
        # of the episodes (the same episodes as on one device) and the means are averaged.
        self._evaluate_compiled = jax.jit(self._evaluate)
        if self.layout.mesh is not None:
            replicated, split = PartitionSpec(), PartitionSpec(parallel.AXIS)
            self._evaluate_compiled = jax.jit(
                parallel.per_device(
                    lambda *args: jax.lax.pmean(self._evaluate(*args), parallel.AXIS),
                    self.layout,
                    (replicated, replicated, split, replicated),
                    replicated,
                )
            )

    def init(self) -> TrainingState:
        """Returns the initial training state (empty replay buffer), committed to the default
        device as a restored checkpoint is: a fresh and a resumed run then call the compiled
        functions with the same signature and share the persistent compilation cache. On
        several devices, built where it lives (every process builds its devices' part)."""
        if self.layout.mesh is None:
            return jax.device_put(self._init(self._key_init, self._gait), jax.devices()[0])
        return self._init(self._key_init)

    @functools.cached_property
    def state_shapes(self) -> TrainingState:
        """`init`'s state as shapes (`jax.ShapeDtypeStruct`), not run; on one device placed too,
        so that the programs compile from it before the state exists (`compile_ahead`)."""
        shapes = jax.eval_shape(self.init)
        if self.layout.mesh is not None:
            return shapes
        device = jax.sharding.SingleDeviceSharding(jax.devices()[0])
        return jax.tree.map(lambda x: x.update(sharding=device), shapes)

    def compile_ahead(
        self, state: TrainingState, *, prefill: bool
    ) -> list[concurrent.futures.Future[Any]]:
        """Traces `train_chunk` (and `prefill`, if it will run) for `state` now and compiles them
        (or loads them from the persistent cache) at once, each in a thread of its own, with
        `evaluate` traced and compiled in a third: XLA compiles without holding the GIL, so a
        cold start waits for the longest program, not for their sum, and the evaluation is
        traced while the host waits for the others. A later call of either waits for its
        program and runs it; `state` (or on one device `state_shapes`) must keep its shapes and
        placement (a chunk returns the state as it took it). Returns the compilations (futures);
        a second call does nothing and returns none."""
        if isinstance(self.train_chunk, _Compiling):
            return []
        lowered = {"train_chunk": self.train_chunk.lower(state)}
        if prefill:
            lowered["prefill"] = self.prefill.lower(state)
        pool = concurrent.futures.ThreadPoolExecutor(len(lowered) + 1, "quadcos-compile")
        for name, program in lowered.items():
            setattr(self, name, _Compiling(pool.submit(program.compile)))
        evaluate = self._evaluate_compiled
        # Shapes and placements only (`state` is donated to the prefill meanwhile); an array not
        # committed to a device (the keys) goes where the others are, as in a call.
        args = jax.tree.map(
            lambda x: jax.ShapeDtypeStruct(
                x.shape, x.dtype, sharding=x.sharding if getattr(x, "committed", True) else None
            ),
            (state.normalizer_params, state.policy_params, self._eval_keys, self._eval_gait),
        )
        self._evaluate_compiled = _Compiling(pool.submit(lambda: evaluate.lower(*args).compile()))
        pool.shutdown(wait=False)
        return [
            program.compiled
            for program in (self.train_chunk, self.prefill, self._evaluate_compiled)
            if isinstance(program, _Compiling)
        ]

    def replay_size(self, state: TrainingState) -> int:
        """Transitions in the replay buffer, over all devices."""
        return int(jnp.sum(state.replay.size))

    def _init_state(self, key: jax.Array, gait: dict[str, jax.Array] | None) -> TrainingState:
        key_policy, key_q, key_env, key_train = jax.random.split(key, 4)
        key_noise = jax.random.fold_in(key, 4)  # fold_in(key, i) is split(key, n)[i]: i ≥ 4
        policy_params = networks.initial_output_layer(
            self.networks.policy_network.init(key_policy),
            self.config.policy_output_scale,
            self.config.init_std,
        )
        q_params = self.networks.q_network.init(key_q)
        # Temperature α starts at config.init_alpha (Brax: 1).
        log_alpha = jnp.log(jnp.asarray(self.config.init_alpha, jnp.float32))
        state = TrainingState(
            policy_params=policy_params,
            policy_optimizer_state=self._sgd_step.policy_optimizer.init(policy_params),
            q_params=q_params,
            q_optimizer_state=self._sgd_step.q_optimizer.init(q_params),
            target_q_params=q_params,
            log_alpha=log_alpha,
            alpha_optimizer_state=self._sgd_step.alpha_optimizer.init(log_alpha),
            normalizer_params=running_statistics.init_state(
                specs.Array((self.critic_observation_size,), jnp.dtype("float32"))
            ),
            env_state=state_lib.with_gait(
                self._reset_envs(jax.random.split(key_env, self.config.num_envs)), gait
            ),
            replay=self.replay.init(),
            key=key_train,
            env_steps=types.UInt64(hi=0, lo=0),
            gradient_steps=types.UInt64(hi=0, lo=0),
            nan_resets=types.UInt64(hi=0, lo=0),
            exploration_noise=jax.random.normal(
                key_noise, (self.config.num_envs, self.action_size)
            ),
        )
        if self.config.n_step > 1:
            like, _ = self._nothing_pending(state)
            state = state.replace(n_step_queue=n_step.empty_queue(like, self.config.n_step))
        return state_lib.strongly_typed(state)

    # --- Acting ----------------------------------------------------------------

    def _exploring_actions(
        self, state: TrainingState, key: jax.Array, uniform: bool = False
    ) -> tuple[jax.Array, TrainingState]:
        """The exploring actions of all training envs (see `networks.exploring_actions`), with
        each env's held draw updated in the state."""
        actions, noise = networks.exploring_actions(
            self.networks,
            (state.normalizer_params, state.policy_params),
            state.env_state.obs,
            state.exploration_noise,
            key,
            hold_steps=self.config.noise_hold_steps,
            episode_start=state.env_state.done > 0,
            uniform=uniform,
        )
        return actions, state.replace(exploration_noise=noise)

    def _env_step(
        self, state: TrainingState, actions: jax.Array, key_reset: jax.Array
    ) -> tuple[TrainingState, Metrics, state_lib.Pending]:
        """Steps all training envs; returns their transitions for the replay buffer (`_store`),
        those with non-finite values marked.

        An env whose observation or reward is non-finite restarts (`_reset_where`, done = 1),
        its transition is neither stored nor counted in the observation statistics, and
        `nan_resets` counts it.
        """
        env_state = state.env_state
        next_env_state = self._step_envs(env_state, actions)
        transitions = state_lib.transitions(env_state, actions, next_env_state, self._privileged)
        finite = (
            jnp.all(jnp.isfinite(transitions.observation), axis=-1)
            & jnp.all(jnp.isfinite(transitions.next_observation), axis=-1)
            & jnp.isfinite(transitions.reward)
        )
        next_env_state = self._reset_where(~finite, next_env_state, key_reset)

        clean_obs = jnp.where(finite[:, None], transitions.observation, 0.0)
        updated_normalizer = running_statistics.update(
            state.normalizer_params,
            clean_obs,
            weights=finite.astype(jnp.float32),
        )
        num_finite = jnp.sum(finite)
        reward_sum = jnp.sum(jnp.where(finite, transitions.reward, 0.0))
        # With no valid row Welford would divide 0 by a zero count.
        normalizer_params = jax.tree.map(
            lambda new, old: jnp.where(num_finite > 0, new, old),
            updated_normalizer,
            state.normalizer_params,
        )
        state = state.replace(
            env_state=state_lib.strongly_typed(next_env_state),
            normalizer_params=normalizer_params,
            env_steps=state.env_steps + self.config.num_envs,
            nan_resets=state.nan_resets + (self.config.num_envs - num_finite).astype(jnp.uint32),
        )
        metrics = {"reward": reward_sum / jnp.maximum(num_finite, 1)}
        if "course_level" in next_env_state.info:  # the course curriculum's mean lane
            metrics["course_level"] = jnp.mean(next_env_state.info["course_level"].astype(float))
        return state, metrics, (transitions, finite)

    def _store(self, state: TrainingState, pending: state_lib.Pending) -> TrainingState:
        """`state` with the finite ones of `pending`'s transitions in its replay buffer; with
        `n_step` n > 1 those of n steps before, as n-step transitions (`n_step.push`)."""
        if state.n_step_queue is not None:
            queue, pending = n_step.push(state.n_step_queue, *pending, self.config.discount)
            state = state.replace(n_step_queue=queue)
        return state.replace(replay=self.replay.insert(state.replay, *pending))

    def _nothing_pending(self, state: TrainingState) -> state_lib.Pending:
        """Transitions of the envs' shapes, all marked non-finite: storing them stores nothing."""
        env_state = state.env_state
        actions = jnp.zeros((self.config.num_envs, self.action_size))
        transitions = state_lib.transitions(env_state, actions, env_state, self._privileged)
        return jax.tree.map(jnp.zeros_like, transitions), jnp.zeros((self.config.num_envs,), bool)

    def _reset_where(self, mask: jax.Array, env_state: envs.State, key: jax.Array) -> envs.State:
        """Restarts the masked envs: from their episode's first state where the training
        wrappers keep it (`state_lib.restart_where`), else (the course curriculum) by replacing
        the whole state with a fresh reset."""
        if state_lib.keeps_first_state(env_state):
            return state_lib.restart_where(mask, env_state)

        def reset_masked() -> envs.State:
            fresh = self._reset_envs(jax.random.split(key, self.config.num_envs))
            fresh = state_lib.carry_gait(fresh, env_state)
            fresh = fresh.replace(done=jnp.ones_like(fresh.done))
            return jax.tree.map(
                lambda new, old: state_lib.where_per_env(mask, new, old),
                fresh,
                env_state,
            )

        # Resetting is as costly as a step, so only do it when an env needs it.
        return jax.lax.cond(jnp.any(mask), reset_masked, lambda: env_state)

    def _prefill(self, state: TrainingState) -> TrainingState:
        """Fills the replay buffer with `min_replay_size` steps of `config.prefill_actions`."""

        def step(state: TrainingState, _) -> tuple[TrainingState, None]:
            key, key_action, key_reset = jax.random.split(state.key, 3)
            uniform = self.config.prefill_actions == "uniform"
            actions, state = self._exploring_actions(state, key_action, uniform=uniform)
            state, _, transitions = self._env_step(state.replace(key=key), actions, key_reset)
            return self._store(state, transitions), None

        state, _ = jax.lax.scan(step, state, None, length=self.num_prefill_steps)
        return state_lib.strongly_typed(state)

    # --- Learning --------------------------------------------------------------

    def _train_chunk(self, state: TrainingState) -> tuple[TrainingState, Metrics]:
        """`steps_per_chunk` x (one env step of all envs + SAC updates).

        Returns the new state and the chunk's metrics, each averaged over the
        chunk: critic_loss, actor_loss, alpha_loss, alpha, reward (mean reward per
        stored transition).
        """
        self.chunk_traces += 1
        config = self.config

        def step(
            carry: tuple[TrainingState, state_lib.Pending | None], _
        ) -> tuple[tuple[TrainingState, state_lib.Pending | None], Metrics]:
            state, pending = carry
            key, key_action, key_reset, key_sample, key_sgd = jax.random.split(state.key, 5)
            if pending is not None:
                # overlap_updates: the previous step's transitions are stored and the updates
                # drawn first, so that nothing of them waits for this step's physics.
                state = self._store(state, pending)
                learner, sgd_metrics = self._learn(state, key_sample, key_sgd)
            actions, state = self._exploring_actions(state, key_action)
            state, env_metrics, transitions = self._env_step(
                state.replace(key=key), actions, key_reset
            )
            if pending is None:
                state = self._store(state, transitions)
                learner, sgd_metrics = self._learn(state, key_sample, key_sgd)
            else:
                pending = transitions
            state = state.replace(**{name: getattr(learner, name) for name in state_lib.LEARNER})
            return (state, pending), {**env_metrics, **sgd_metrics}

        pending = self._nothing_pending(state) if config.overlap_updates else None
        (state, pending), metrics = jax.lax.scan(
            step, (state, pending), None, length=config.steps_per_chunk
        )
        if pending is not None:
            state = self._store(state, pending)
        return state_lib.strongly_typed(state), jax.tree.map(jnp.mean, metrics)

    def _learn(
        self, state: TrainingState, key_sample: jax.Array, key_sgd: jax.Array
    ) -> tuple[TrainingState, Metrics]:
        """`updates_per_step` SAC updates on batches drawn from `state.replay`: the state with
        its `state_lib.LEARNER` fields updated (and no envs or replay: the updates carry only what
        they change), and the updates' mean metrics."""
        batches = self._sample_batches(state.replay, key_sample)
        keys = jax.random.split(key_sgd, self.config.updates_per_step)
        learner = state.replace(
            env_state=None, replay=None, exploration_noise=None, n_step_queue=None
        )
        learner, metrics = jax.lax.scan(self._sgd_step, learner, (batches, keys))
        return learner, jax.tree.map(jnp.mean, metrics)

    def _sample_batches(self, replay: replay_lib.ReplayState, key: jax.Array) -> types.Transition:
        """(updates_per_step, batch_size) transitions; on several devices each device's ring
        gives its share of every batch."""
        updates, batch = self.config.updates_per_step, self.config.batch_size
        shards = self.layout.shards
        if shards == 1:
            sample = self.replay.sample(replay, key, updates * batch)
            return jax.tree.map(lambda x: jnp.reshape(x, (updates, batch) + x.shape[1:]), sample)
        sample = self.replay.sample(replay, key, updates * batch // shards)  # (shards, n, ...)

        def batches(x: jax.Array) -> jax.Array:
            x = jnp.reshape(x, (shards, updates, batch // shards) + x.shape[2:]).swapaxes(0, 1)
            return jnp.reshape(x, (updates, batch) + x.shape[3:])

        return jax.tree.map(batches, sample)

    # --- Evaluation ------------------------------------------------------------

    def evaluate(
        self,
        normalizer_params: running_statistics.RunningStatisticsState,
        policy_params: types.Params,
    ) -> Metrics:
        """The training-time evaluation: the same episodes (initial states) every call."""
        return self._evaluate_compiled(
            normalizer_params, policy_params, self._eval_keys, self._eval_gait
        )

    def _evaluate(
        self,
        normalizer_params: running_statistics.RunningStatisticsState,
        policy_params: types.Params,
        keys: jax.Array,
        gait: dict[str, jax.Array] | None,
    ) -> Metrics:
        """`periodic_eval.evaluate` of the deterministic policy (tanh of the Gaussian mean) from
        the initial states `keys` draw, one episode each, with `gait` (a quadcos env's)."""
        policy = self._make_policy((normalizer_params, policy_params), deterministic=True)
        env = self.eval_env if gait is None else state_lib.GaitEnv(self.eval_env, gait)
        return periodic_eval.evaluate(
            env,
            lambda obs: policy(obs, keys[0])[0],  # deterministic: the key is not used
            keys,
            episode_length=self.config.eval_episode_length,
        )


class _Compiling:
    """A program compiling in another thread (`SACTrainer.compile_ahead`): a call waits for it,
    then runs it."""

    def __init__(self, compiled: concurrent.futures.Future[Callable[..., Any]]):
        self.compiled = compiled

    def __call__(self, *args: Any) -> Any:
        return self.compiled.result()(*args)
