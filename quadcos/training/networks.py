"""The SAC networks (Brax's tanh-Gaussian policy and twin Q), their initialisation, and how the
training envs explore with them."""

from typing import Any, Sequence

import jax
import jax.numpy as jnp
from brax.training import networks as brax_networks
from brax.training import types
from brax.training.acme import running_statistics
from brax.training.agents.sac import networks as sac_networks

from quadcos.training import distributional

MIN_STD = 0.001  # Brax's NormalTanhDistribution: std = softplus(raw) + min_std


def make_networks(
    observation_size: int,
    action_size: int,
    policy_hidden_sizes: Sequence[int],
    q_hidden_sizes: Sequence[int],
    normalize_observations: bool,
    critic_layer_norm: bool = False,
    critics: distributional.Critics | None = None,
    critic_observation_size: int | None = None,
) -> sac_networks.SACNetworks:
    """Brax SAC networks (tanh-Gaussian policy, twin Q) with separate widths; with
    `critic_layer_norm` the critics normalise each hidden layer (Brax's `layer_norm`); with
    `critics` (`make_critics`) the twin Q is their means. With a `critic_observation_size` beyond
    `observation_size` the critics observe that much (the policy's observation, then the
    privileged inputs: `config.privileged_critic`) and the policy its first `observation_size`."""
    preprocess = _preprocessor(normalize_observations)
    critic_size = critic_observation_size or observation_size
    policy_side = sac_networks.make_sac_networks(
        observation_size,
        action_size,
        preprocess_observations_fn=preprocess,
        hidden_layer_sizes=tuple(policy_hidden_sizes),
    )
    if critics is None:
        critics = sac_networks.make_sac_networks(
            critic_size,
            action_size,
            preprocess_observations_fn=preprocess,
            hidden_layer_sizes=tuple(q_hidden_sizes),
            q_network_layer_norm=critic_layer_norm,
        )
    policy_network = policy_side.policy_network
    if critic_size != observation_size:
        policy_network = _first_entries(policy_network, observation_size)
    return sac_networks.SACNetworks(
        policy_network=policy_network,
        q_network=critics.q_network,
        parametric_action_distribution=policy_side.parametric_action_distribution,
    )


def _first_entries(
    network: brax_networks.FeedForwardNetwork, size: int
) -> brax_networks.FeedForwardNetwork:
    """`network` on the first `size` entries of its observations and of their normaliser (a
    critic's observation, or the policy's own)."""

    def apply(normalizer_params: Any, params: Any, obs: jax.Array) -> jax.Array:
        own = running_statistics.NestedMeanStd(
            mean=normalizer_params.mean[..., :size], std=normalizer_params.std[..., :size]
        )
        return network.apply(own, params, obs[..., :size])

    return brax_networks.FeedForwardNetwork(init=network.init, apply=apply)


def make_critics(
    observation_size: int, action_size: int, config: Any
) -> distributional.Critics | None:
    """The distributional critics of a trainer `config` (`critic_atoms` on
    `critic_value_range`, `hidden_sizes.q`, `critic_layer_norm`); None where `critic_atoms` is 0
    (Brax's scalar twin Q)."""
    if not config.critic_atoms:
        return None
    support = distributional.Support(config.critic_atoms, *config.critic_value_range)
    return distributional.make_critics(
        observation_size,
        action_size,
        _preprocessor(config.normalize_observations),
        config.hidden_sizes.q,
        config.critic_layer_norm,
        support,
    )


def _preprocessor(normalize_observations: bool) -> types.PreprocessObservationFn:
    if normalize_observations:
        return running_statistics.normalize
    return types.identity_observation_preprocessor


def initial_output_layer(params: Any, scale: float, init_std: float | None) -> Any:
    """The fresh policy's last Dense layer: kernel × `scale` (with scale << 1 the mean action is
    ~0, the env's action centre, instead of a random offset); with `init_std`, the std half of
    the bias set so that Brax's softplus(·) + min_std gives that std everywhere."""
    layers = params["params"]
    last = max(layers, key=lambda name: int(name.rsplit("_", 1)[1]))
    layer = {**layers[last], "kernel": layers[last]["kernel"] * scale}
    if init_std is not None:
        bias = layer["bias"]
        action_size = bias.shape[-1] // 2
        raw_std = jnp.log(jnp.expm1(jnp.asarray(init_std - MIN_STD, bias.dtype)))
        layer["bias"] = bias.at[action_size:].set(raw_std)
    return {**params, "params": {**layers, last: layer}}


def exploring_actions(
    networks: sac_networks.SACNetworks,
    params: tuple[Any, Any],
    obs: jax.Array,
    noise: jax.Array,
    key: jax.Array,
    *,
    hold_steps: int,
    episode_start: jax.Array,
    uniform: bool = False,
) -> tuple[jax.Array, jax.Array]:
    """(num_envs, action_size) exploring actions and the envs' held noise after this step.

    The policy's tanh-Gaussian samples (`params` = (normaliser, policy) parameters), or with
    `uniform` actions uniform in [-1, 1] (the prefill's). With `hold_steps` = 1 each step draws
    afresh (Brax's SAC). With more, each env keeps its standard-normal draw `noise` (mapped
    through its CDF for `uniform`) and redraws it with probability 1 / hold_steps a step and
    whenever its episode starts, so that a rhythm controller's parameters stay put long enough
    for a gait to show.
    """
    if hold_steps == 1:
        if uniform:
            return jax.random.uniform(key, noise.shape, minval=-1.0, maxval=1.0), noise
        policy = sac_networks.make_inference_fn(networks)(params)
        return policy(obs, key)[0], noise
    key_redraw, key_noise = jax.random.split(key)
    redraw = (jax.random.uniform(key_redraw, noise.shape[:1]) < 1.0 / hold_steps) | episode_start
    noise = jnp.where(redraw[:, None], jax.random.normal(key_noise, noise.shape), noise)
    if uniform:
        return 2.0 * jax.scipy.stats.norm.cdf(noise) - 1.0, noise
    normalizer_params, policy_params = params
    logits = networks.policy_network.apply(normalizer_params, policy_params, obs)
    distribution = networks.parametric_action_distribution
    gaussian = distribution.create_dist(logits)
    return distribution.postprocess(gaussian.loc + gaussian.scale * noise), noise
