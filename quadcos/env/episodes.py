"""Deterministic episodes of a batched env: the one rollout loop of every evaluation.

Training-time evaluation (`SACTrainer.evaluate`), `quadcos.evaluation` (and through it the bench's
time to walk) all step their robots with `run_episodes`; they differ only in what they count.
"""

from collections.abc import Callable
from typing import Any, TypeVar

import jax
import jax.numpy as jnp
from brax import envs

Stats = TypeVar("Stats")


def run_episodes(
    step: Callable[[envs.State, jax.Array], envs.State],
    act: Callable[[jax.Array], jax.Array],
    state: envs.State,
    stats: Stats,
    update: Callable[[Stats, envs.State, jax.Array], Stats],
    num_steps: int,
    observe: Callable[[envs.State], Any] | None = None,
) -> tuple[envs.State, Stats, Any]:
    """`num_steps` control steps of a batch of robots under a deterministic policy (traceable).

    Args:
      step: the batched env step, (state, actions (n, action_size)) -> state.
      act: observations (n, obs_size) -> actions (n, action_size).
      state: the batched env state to start from.
      stats: per-episode statistics, updated after every step by `update(stats, new state,
        step index)` (the index counts from 0 within this call).
      num_steps: steps to take; episodes that end earlier are the statistics' business.
      observe: new state -> what to record after every step (stacked along a leading axis).

    Returns:
      The last state, the statistics and the stacked observations (None without `observe`).
    """

    def body(carry, index):
        state, stats = carry
        state = step(state, act(state.obs))
        stats = update(stats, state, index)
        return (state, stats), None if observe is None else observe(state)

    (state, stats), observed = jax.lax.scan(body, (state, stats), jnp.arange(num_steps))
    return state, stats, observed
