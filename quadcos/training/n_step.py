"""n-step returns (`config.n_step`): each stored transition carries the discounted rewards of up to
n steps of its env and the state after them, so that the critic's target looks n steps ahead:

    R = Σ_{k=0}^{m} γ^k r_k,   target = R + γ^{m+1} (1 − done_m) V(s_{m+1})

with m ≤ n − 1 the last step of the window that belongs to the transition's episode. Brax's
critic loss computes r + γ · discount · V(s'), so the n-step transition stores R as its reward,
γ^m (1 − done_m) as its discount and s_{m+1} as its next observation.

The window of an env's transitions stops before a step it cannot look through: after a step that
ended the episode (done: its discount 0, a fall or a time-limit truncation), at a step whose values
are not finite (the NaN guard restarts that env), and at a truncated step (its next observation
is a reset's, which Brax's loss masks), bootstrapping from the state before it instead. A window's
first transition keeps Brax's one-step meaning: truncated, it stays masked. n = 1 is Brax's
transition unchanged.

The trainer keeps its last n − 1 vectorised steps (`Queue`, oldest first) and stores, for each
new step, the n-step transitions of the oldest; the queue starts with steps marked non-finite, so
nothing is stored for the first n − 1 steps of a run. With `overlap_updates` each chunk stores an
empty step first (its carried transitions are stored one step late): a window stops there, at the
chunk's start.
"""

import jax
import jax.numpy as jnp
from brax.training import types

# The last n − 1 vectorised steps' transitions, each (n − 1, num_envs, ...), oldest first, and
# which of them are finite (n − 1, num_envs).
Queue = tuple[types.Transition, jax.Array]


def empty_queue(like: types.Transition, n: int) -> Queue:
    """A queue of n − 1 steps shaped as `like` (one vectorised step's transitions), all marked
    non-finite: nothing of them is ever stored."""
    transitions = jax.tree.map(lambda x: jnp.zeros((n - 1, *x.shape), x.dtype), like)
    return transitions, jnp.zeros((n - 1, like.reward.shape[0]), bool)


def push(
    queue: Queue, transitions: types.Transition, finite: jax.Array, discount: float
) -> tuple[Queue, tuple[types.Transition, jax.Array]]:
    """The queue with one more vectorised step (`transitions`, `finite` (num_envs,)), and the
    n-step transitions of its oldest step with which of them to store (those that are finite)."""
    stack = lambda old, new: jnp.concatenate([old, new[None]])  # noqa: E731
    window = jax.tree.map(stack, queue[0], transitions)
    window_finite = stack(queue[1], finite)
    oldest = returns(window, window_finite, discount)
    newer = jax.tree.map(lambda x: x[1:], (window, window_finite))
    return newer, (oldest, window_finite[0])


def returns(window: types.Transition, finite: jax.Array, discount: float) -> types.Transition:
    """The n-step transitions of the window's first step: `window` holds n consecutive
    vectorised steps (n, num_envs, ...), `finite` (n, num_envs) which of them are finite."""
    truncated = window.extras["state_extras"]["truncation"]
    reward, kept_discount = window.reward[0], window.discount[0]
    next_observation = window.next_observation[0]
    looking = jnp.ones_like(finite[0])
    for k in range(1, window.reward.shape[0]):
        looking = looking & (window.discount[k - 1] > 0) & finite[k] & (truncated[k] == 0)
        reward = reward + jnp.where(looking, discount**k * window.reward[k], 0.0)
        kept_discount = jnp.where(looking, discount**k * window.discount[k], kept_discount)
        next_observation = jnp.where(
            looking[:, None], window.next_observation[k], next_observation
        )
    first = jax.tree.map(lambda x: x[0], window)
    return first._replace(
        reward=reward, discount=kept_discount, next_observation=next_observation
    )
