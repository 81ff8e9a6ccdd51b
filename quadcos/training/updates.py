"""One SAC update (Haarnoja et al. 2018, arXiv:1812.05905) with Brax's losses, and the actor's
optional regulariser: smoothness (CAPS: Mysore et al. 2021, arXiv:2012.06644) and an anchor at
the action centre.

The temperature, critic and actor gradients are all taken at the state before the update, as in
Brax's SAC. On several devices the batch is split over them and XLA sums the gradients (the
losses are means over the whole batch), so every device applies the same update.
"""

import dataclasses
import functools
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import ml_collections
import optax
from brax.training import types
from brax.training.agents.sac import losses as sac_losses
from brax.training.agents.sac import networks as sac_networks_lib

from quadcos.training import distributional

Metrics = dict[str, jax.Array]


@dataclasses.dataclass(frozen=True)
class SACUpdate:
    """`__call__(state, (transitions, key))` → (state, metrics): one gradient step of SAC.

    Attributes:
      alpha_loss, critic_loss, actor_loss: Brax's `sac.losses.make_losses`.
      alpha_optimizer, q_optimizer, policy_optimizer: their optax optimisers.
      tau: Polyak rate of the target critics.
      actor_warmup_steps: updates during which only the critics learn.
      policy_delay: after the warm-up, the actor and the temperature learn in one update of
        every `policy_delay` (TD3's delayed policy update), the critics in every one.
    """

    alpha_loss: Callable[..., jax.Array]
    critic_loss: Callable[..., jax.Array]
    actor_loss: Callable[..., jax.Array]
    alpha_optimizer: optax.GradientTransformation
    q_optimizer: optax.GradientTransformation
    policy_optimizer: optax.GradientTransformation
    tau: float
    actor_warmup_steps: int
    policy_delay: int = 1
    smoothness: Callable[..., jax.Array] | None = None

    @classmethod
    def from_config(
        cls,
        config: ml_collections.ConfigDict,
        sac_networks: Any,
        action_size: int,
        critics: distributional.Critics | None = None,
    ) -> "SACUpdate":
        """The update of a trainer `config` (`quadcos.training.config`) for Brax's SAC networks
        `sac_networks` acting in `action_size` dimensions: Adam for each part, the actor's and
        critic's gradients clipped to `max_grad_norm` where it is set; with `critics`
        (distributional, the twin Q of `sac_networks` their means) their cross-entropy loss."""
        alpha_loss, critic_loss, actor_loss = sac_losses.make_losses(
            sac_network=sac_networks,
            reward_scaling=config.reward_scaling,
            discounting=config.discount,
            # Brax's losses use action_size only for the temperature's target entropy,
            # −0.5·action_size; passing −2·target_entropy sets that target.
            action_size=action_size
            if config.target_entropy is None
            else -2.0 * config.target_entropy,
        )
        if critics is not None:
            critic_loss = distributional.CriticLoss(
                sac_networks, critics, config.reward_scaling, config.discount
            )
        return cls(
            alpha_loss=alpha_loss,
            critic_loss=critic_loss,
            actor_loss=actor_loss,
            alpha_optimizer=optax.adam(config.learning_rate.alpha),
            q_optimizer=_optimizer(config.learning_rate.critic, config.max_grad_norm),
            policy_optimizer=_optimizer(config.learning_rate.actor, config.max_grad_norm),
            tau=config.tau,
            actor_warmup_steps=config.actor_warmup_steps,
            policy_delay=config.policy_delay,
            smoothness=_smoothness(sac_networks, config.smoothness),
        )

    def __call__(
        self, state: Any, batch: tuple[types.Transition, jax.Array]
    ) -> tuple[Any, Metrics]:
        transitions, key = batch
        key_alpha, key_critic, key_actor = jax.random.split(key, 3)
        alpha = jnp.exp(state.log_alpha)
        alpha_loss, alpha_grad = jax.value_and_grad(self.alpha_loss)(
            state.log_alpha, state.policy_params, state.normalizer_params, transitions, key_alpha
        )
        # (distributional critics: the loss and a metric of their target)
        aux = isinstance(self.critic_loss, distributional.CriticLoss)
        critic_out, q_grad = jax.value_and_grad(self.critic_loss, has_aux=aux)(
            state.q_params,
            state.policy_params,
            state.normalizer_params,
            state.target_q_params,
            alpha,
            transitions,
            key_critic,
        )
        critic_loss, critic_metrics = critic_out if aux else (critic_out, {})
        actor_objective = jax.value_and_grad(self._actor_loss, has_aux=True)
        (actor_loss, smoothness), policy_grad = actor_objective(
            state.policy_params,
            state.normalizer_params,
            state.q_params,
            alpha,
            transitions,
            key_actor,
        )
        log_alpha, alpha_optimizer_state = _apply(
            self.alpha_optimizer, alpha_grad, state.log_alpha, state.alpha_optimizer_state
        )
        q_params, q_optimizer_state = _apply(
            self.q_optimizer, q_grad, state.q_params, state.q_optimizer_state
        )
        policy_params, policy_optimizer_state = _apply(
            self.policy_optimizer, policy_grad, state.policy_params, state.policy_optimizer_state
        )
        # During the warm-up only the critics learn: an actor that climbs an untrained Q
        # walks away from the action centre's gait before the critic can value it. After it, the
        # actor and the temperature learn in one update of every `policy_delay`.
        warm = (state.gradient_steps.hi > 0) | (state.gradient_steps.lo >= self.actor_warmup_steps)
        actor_learns = warm & (state.gradient_steps.lo % self.policy_delay == 0)
        (log_alpha, alpha_optimizer_state, policy_params, policy_optimizer_state) = jax.tree.map(
            lambda new, old: jnp.where(actor_learns, new, old),
            (log_alpha, alpha_optimizer_state, policy_params, policy_optimizer_state),
            (
                state.log_alpha,
                state.alpha_optimizer_state,
                state.policy_params,
                state.policy_optimizer_state,
            ),
        )
        target_q_params = jax.tree.map(
            lambda target, q: (1 - self.tau) * target + self.tau * q,
            state.target_q_params,
            q_params,
        )
        state = state.replace(
            policy_params=policy_params,
            policy_optimizer_state=policy_optimizer_state,
            q_params=q_params,
            q_optimizer_state=q_optimizer_state,
            target_q_params=target_q_params,
            log_alpha=log_alpha,
            alpha_optimizer_state=alpha_optimizer_state,
            gradient_steps=state.gradient_steps + 1,
        )
        metrics = {
            "critic_loss": critic_loss,
            "actor_loss": actor_loss,
            "alpha_loss": alpha_loss,
            "alpha": jnp.exp(log_alpha),
            **critic_metrics,
            **smoothness,
        }
        return state, metrics

    def _actor_loss(
        self, policy_params, normalizer_params, q_params, alpha, transitions, key
    ) -> tuple[jax.Array, Metrics]:
        """The actor's loss to descend, and its smoothness term as a metric where it has one."""
        args = (policy_params, normalizer_params, q_params, alpha, transitions)
        if self.smoothness is None:
            return self.actor_loss(*args, key), {}
        key_sac, key_near = jax.random.split(key)
        sac = self.actor_loss(*args, key_sac)
        smooth = self.smoothness(policy_params, normalizer_params, transitions, key_near)
        return sac + smooth, {"smoothness": smooth}


def smoothness_loss(
    networks: sac_networks_lib.SACNetworks,
    policy_params: Any,
    normalizer_params: Any,
    transitions: types.Transition,
    key: jax.Array,
    *,
    temporal: float,
    spatial: float,
    sigma: float,
    anchor: float = 0.0,
) -> jax.Array:
    """CAPS's regulariser of the deterministic policy μ (the tanh of the Gaussian's mean), and its
    anchor:

        temporal · mean ‖μ(s) − μ(s')‖² + spatial · mean ‖μ(s) − μ(s̃)‖² + anchor · mean ‖μ(s)‖²,

    s → s' a stored transition, s̃ = s + sigma · std ⊙ ε with ε ~ N(0, I) and std the observation
    normaliser's (noise of `sigma` in the units the networks see). Squared distances (smooth at
    0, where CAPS's Euclidean distance has no gradient). μ = 0 is the env's action centre (the
    searched gait of a from-scratch run), so the anchor charges the policy's distance from it."""
    distribution = networks.parametric_action_distribution

    def mean_action(observation: jax.Array) -> jax.Array:
        logits = networks.policy_network.apply(normalizer_params, policy_params, observation)
        return distribution.mode(logits)

    def mean_square(difference: jax.Array) -> jax.Array:
        return jnp.mean(jnp.sum(difference**2, axis=-1))

    observation = transitions.observation
    action = mean_action(observation)
    loss = anchor * mean_square(action)
    # (a term with weight 0 costs no forward pass: the weights are fixed at tracing)
    if temporal:
        loss += temporal * mean_square(action - mean_action(transitions.next_observation))
    if spatial:
        std = getattr(normalizer_params, "std", 1.0)
        nearby = observation + sigma * std * jax.random.normal(key, observation.shape)
        loss += spatial * mean_square(action - mean_action(nearby))
    return loss


def _smoothness(
    networks: sac_networks_lib.SACNetworks, weights: ml_collections.ConfigDict
) -> Callable[..., jax.Array] | None:
    """`smoothness_loss` of `networks` at `weights` (config.smoothness); None where each of its
    weights is 0, so that the update is Brax's."""
    if weights.temporal == 0 and weights.spatial == 0 and weights.anchor == 0:
        return None
    return functools.partial(
        smoothness_loss,
        networks,
        temporal=weights.temporal,
        spatial=weights.spatial,
        sigma=weights.sigma,
        anchor=weights.anchor,
    )


def _apply(
    optimizer: optax.GradientTransformation, grad: Any, params: Any, optimizer_state: Any
) -> tuple[Any, Any]:
    updates, optimizer_state = optimizer.update(grad, optimizer_state)
    return optax.apply_updates(params, updates), optimizer_state


def _optimizer(learning_rate: float, max_grad_norm: float | None) -> optax.GradientTransformation:
    adam = optax.adam(learning_rate)
    if max_grad_norm is None:
        return adam
    return optax.chain(optax.clip_by_global_norm(max_grad_norm), adam)
