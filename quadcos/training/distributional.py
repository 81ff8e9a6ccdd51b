"""A distributional critic (`config.critic_atoms`): C51 (Bellemare et al. 2017, arXiv:1707.06887)
as FastTD3 and FastSAC (arXiv:2512.01996) put it in off-policy locomotion.

Each of the twin critics gives a categorical distribution p(s, a) over `atoms` returns z_1 … z_N
evenly spaced on `config.critic_value_range` [v_min, v_max]; its Q is the mean Σ_i p_i z_i, so
the actor and the temperature learn from it by Brax's own losses. The critics learn by
cross-entropy against the soft Bellman target's distribution,

    T z_j = r + γ · d · (z_j − α log π(a' | s')),   a' ~ π(· | s'),

with p' the target critic's whose mean is lower (clipped double Q on distributions, as FastTD3;
FastSAC averages the two), each T z_j clipped to the support and its probability split between
the two atoms beside it (C51's projection: where no T z_j is clipped it keeps the target's mean,
so the mean of the target is Brax's scalar target). The returns the support must hold are the
scaled rewards' and the entropy bonus's, −α log π a step, which `reward_scaling` does not scale.
Truncated transitions are masked as in Brax's critic loss; d is the transition's discount
(n-step returns store γ^m there: quadcos.training.n_step)."""

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
from brax.training import networks as brax_networks
from brax.training import types
from brax.training.agents.sac import networks as sac_networks
from flax import linen

N_CRITICS = 2


@dataclasses.dataclass(frozen=True)
class Support:
    """`atoms` returns evenly spaced on [v_min, v_max]."""

    atoms: int
    v_min: float
    v_max: float

    def __post_init__(self):
        if self.atoms < 2 or not self.v_min < self.v_max:
            raise ValueError(
                f"a critic's support needs >= 2 atoms on v_min < v_max, got {self.atoms} atoms on"
                f" [{self.v_min}, {self.v_max}]"
            )

    @property
    def values(self) -> jax.Array:
        return jnp.linspace(self.v_min, self.v_max, self.atoms)

    def mean(self, logits: jax.Array) -> jax.Array:
        """The expected return of each distribution of `logits` (..., atoms)."""
        return jnp.sum(jax.nn.softmax(logits, axis=-1) * self.values, axis=-1)


@dataclasses.dataclass(frozen=True)
class Critics:
    """The twin categorical critics: `logits(normalizer, params, obs, action)` → (batch, 2,
    atoms); `q_network` is the same parameters seen through their means, (batch, 2), the shape of
    Brax's twin Q, so that everything reading Q (the actor's and the temperature's losses) reads
    the means."""

    support: Support
    logits: Callable[..., jax.Array]
    q_network: brax_networks.FeedForwardNetwork


def make_critics(
    observation_size: int,
    action_size: int,
    preprocess: types.PreprocessObservationFn,
    hidden_sizes: Sequence[int],
    layer_norm: bool,
    support: Support,
) -> Critics:
    """Two MLPs of `hidden_sizes` (Brax's, with LayerNorm where `layer_norm`) on (observation,
    action), each ending in `support.atoms` logits."""

    class Module(linen.Module):
        @linen.compact
        def __call__(self, obs: jax.Array, actions: jax.Array) -> jax.Array:
            hidden = jnp.concatenate([obs, actions], axis=-1)
            heads = [
                brax_networks.MLP(
                    layer_sizes=[*hidden_sizes, support.atoms],
                    activation=linen.relu,
                    kernel_init=jax.nn.initializers.lecun_uniform(),
                    layer_norm=layer_norm,
                )(hidden)
                for _ in range(N_CRITICS)
            ]
            return jnp.stack(heads, axis=-2)

    module = Module()

    def logits(normalizer_params, params, obs, actions):
        return module.apply(params, preprocess(obs, normalizer_params), actions)

    def init(key):
        return module.init(key, jnp.zeros((1, observation_size)), jnp.zeros((1, action_size)))

    q_network = brax_networks.FeedForwardNetwork(
        init=init, apply=lambda *args: support.mean(logits(*args))
    )
    return Critics(support=support, logits=logits, q_network=q_network)


def project(
    probs: jax.Array, reward: jax.Array, discount: jax.Array, support: Support
) -> jax.Array:
    """C51's projection onto `support` of the distributions `probs` (batch, atoms) moved to
    reward + discount · z (reward and discount (batch,)): each moved atom, clipped to
    [v_min, v_max], splits its probability between the two atoms beside it in proportion to its
    closeness (a hat function of width one atom spacing)."""
    return _spread(probs, _moved(reward, discount, support), support)


def _moved(reward: jax.Array, discount: jax.Array, support: Support) -> jax.Array:
    """(batch, atoms): reward + discount · z of each atom z."""
    return reward[:, None] + discount[:, None] * support.values


def _spread(probs: jax.Array, moved: jax.Array, support: Support) -> jax.Array:
    """`project`'s split of each atom's probability, its atom moved to `moved`."""
    spacing = (support.v_max - support.v_min) / (support.atoms - 1)  # exact, not float32's
    position = jnp.clip((moved - support.v_min) / spacing, 0.0, support.atoms - 1.0)
    weight = jnp.clip(1.0 - jnp.abs(position[:, :, None] - jnp.arange(support.atoms)), 0.0, 1.0)
    return jnp.einsum("bj,bji->bi", probs, weight)


@dataclasses.dataclass(frozen=True, eq=False)  # hashed by identity: a static of the jitted update
class CriticLoss:
    """The critics' loss, called with the arguments of Brax's SAC critic loss (q_params,
    policy_params, normalizer_params, target_q_params, alpha, transitions, key) → (the two
    critics' summed cross-entropy to `target`, the mean over the batch (truncated transitions
    count as 0, as in Brax's loss); {"critic_target_clipped": the target's probability that
    fell beyond the support and was clipped to its ends, the mean over the batch}: where it is
    more than a little, `critic_value_range` is too narrow for the returns)."""

    networks: sac_networks.SACNetworks
    critics: Critics
    reward_scaling: float
    discounting: float

    def target(
        self,
        policy_params: Any,
        normalizer_params: Any,
        target_q_params: Any,
        alpha: jax.Array,
        transitions: types.Transition,
        key: jax.Array,
    ) -> tuple[jax.Array, jax.Array]:
        """(batch, atoms): the soft Bellman target's distribution on the support, from the
        target critic whose mean at (s', a' ~ π(· | s')) is lower; (batch,): its probability
        that lay beyond the support (clipped to its ends)."""
        distribution = self.networks.parametric_action_distribution
        next_obs = transitions.next_observation
        next_params = self.networks.policy_network.apply(normalizer_params, policy_params, next_obs)
        next_raw = distribution.sample_no_postprocessing(next_params, key)
        next_log_prob = distribution.log_prob(next_params, next_raw)
        next_action = distribution.postprocess(next_raw)
        next_logits = self.critics.logits(normalizer_params, target_q_params, next_obs, next_action)
        lower = jnp.argmin(self.critics.support.mean(next_logits), axis=-1)  # (batch,)
        next_probs = jnp.take_along_axis(
            jax.nn.softmax(next_logits, axis=-1), lower[:, None, None], axis=1
        )[:, 0]
        discount = transitions.discount * self.discounting
        shift = transitions.reward * self.reward_scaling - discount * alpha * next_log_prob
        support = self.critics.support
        moved = _moved(shift, discount, support)
        beyond = (moved < support.v_min) | (moved > support.v_max)
        clipped = jnp.sum(jnp.where(beyond, next_probs, 0.0), axis=-1)
        return _spread(next_probs, moved, support), clipped

    def __call__(self, q_params: Any, *target_args: Any) -> tuple[jax.Array, dict]:
        """The loss of the critics `q_params` and its metric; `target_args` are `target`'s
        (policy_params, normalizer_params, target_q_params, alpha, transitions, key)."""
        _, normalizer_params, _, _, transitions, _ = target_args
        target, clipped = jax.lax.stop_gradient(self.target(*target_args))
        logits = self.critics.logits(
            normalizer_params, q_params, transitions.observation, transitions.action
        )
        cross_entropy = -jnp.sum(target[:, None] * jax.nn.log_softmax(logits, axis=-1), axis=-1)
        truncation = transitions.extras["state_extras"]["truncation"]
        loss = jnp.mean(jnp.sum(cross_entropy, axis=-1) * (1 - truncation))
        return loss, {"critic_target_clipped": jnp.mean(clipped)}
