"""On-device ring replay buffer with masked insertion.

Brax's `replay_buffers.UniformSamplingQueue` cannot be used here for two
reasons: it inserts a whole batch contiguously, so transitions of envs that
produced non-finite values cannot be left out (the NaN guard needs masked
insertion), and once full it `jnp.roll`s the entire buffer on every insert,
an O(capacity) copy per env step. This buffer keeps Brax's storage layout
(each transition flattened into one row of a 2-D array, unflattened on
sampling) but writes rows in a ring with a scatter whose masked rows are
dropped, so an insert costs O(num_envs).
"""

from typing import Generic, TypeVar

import flax
import jax
import jax.numpy as jnp
import numpy as np
from brax.training import types
from jax import flatten_util

Sample = TypeVar("Sample")


@flax.struct.dataclass
class ReplayState:
    """Contents of the ring buffer.

    Attributes:
      data: (capacity, row_size) flattened transitions.
      insert_position: () int32, row written next (the oldest once full).
      size: () int32, number of valid rows, at most capacity.
    """

    data: jax.Array
    insert_position: jax.Array
    size: jax.Array


class RingReplay(Generic[Sample]):
    """Fixed-capacity FIFO of transitions with uniform sampling."""

    def __init__(self, capacity: int, dummy_sample: Sample):
        """Derives the row layout from one unbatched `dummy_sample`."""
        flat, unflatten = flatten_util.ravel_pytree(dummy_sample)
        self.capacity = capacity
        self._row_size = flat.shape[0]
        self._dtype = flat.dtype
        self._flatten = jax.vmap(lambda sample: flatten_util.ravel_pytree(sample)[0])
        self._unflatten = jax.vmap(unflatten)

    def init(self) -> ReplayState:
        """Returns an empty buffer."""
        return ReplayState(
            data=jnp.zeros((self.capacity, self._row_size), self._dtype),
            insert_position=jnp.zeros((), jnp.int32),
            size=jnp.zeros((), jnp.int32),
        )

    def insert(self, state: ReplayState, samples: Sample, valid: jax.Array) -> ReplayState:
        """Appends the rows of `samples` whose `valid` (batch,) bool is set.

        Valid rows keep their order and are packed next to each other; invalid
        rows get the out-of-range index `capacity` and are dropped by the scatter.
        """
        rows = self._flatten(samples)
        valid = valid.astype(jnp.int32)
        offsets = jnp.cumsum(valid) - valid
        index = (state.insert_position + offsets) % self.capacity
        index = jnp.where(valid > 0, index, self.capacity)
        num_valid = jnp.sum(valid)
        return ReplayState(
            data=state.data.at[index].set(rows, mode="drop"),
            insert_position=(state.insert_position + num_valid) % self.capacity,
            size=jnp.minimum(state.size + num_valid, self.capacity),
        )

    def sample(self, state: ReplayState, key: jax.Array, batch_size: int) -> Sample:
        """Draws `batch_size` transitions uniformly, with replacement."""
        index = jax.random.randint(key, (batch_size,), 0, state.size)
        return self._unflatten(state.data[index])


def reshard(stored: ReplayState, shards: int) -> ReplayState:
    """A buffer saved as some number of rings (positions of shape () for one device, (k,) for
    k) laid out again as `shards` rings of the same total capacity, on the host: a checkpoint
    saved on k devices resumes on any other count. Every stored transition is kept; the newest
    are dealt round-robin to the new rings so that each ring overwrites its oldest first."""
    data = np.asarray(stored.data)
    positions = np.atleast_1d(np.asarray(stored.insert_position))
    sizes = np.atleast_1d(np.asarray(stored.size))
    old_capacity = data.shape[0] // positions.shape[0]
    # Each old ring's rows newest first, then interleaved across rings by recency.
    newest_first = []
    for ring, (position, size) in enumerate(zip(positions, sizes)):
        rows = data[ring * old_capacity : (ring + 1) * old_capacity]
        order = (position - 1 - np.arange(size)) % old_capacity if size else np.zeros(0, int)
        newest_first.append(rows[order])
    depth = max(len(rows) for rows in newest_first)
    merged = [rows[age] for age in range(depth) for rows in newest_first if age < len(rows)]
    capacity = data.shape[0] // shards
    new_data = np.zeros_like(data)
    new_sizes = np.zeros(shards, np.int32)
    for ring in range(shards):
        rows = merged[ring::shards][:capacity][::-1]  # oldest first
        new_data[ring * capacity : ring * capacity + len(rows)] = rows
        new_sizes[ring] = len(rows)
    new_positions = (new_sizes % capacity).astype(np.int32)
    if shards == 1:
        return ReplayState(data=new_data, insert_position=new_positions[0], size=new_sizes[0])
    return ReplayState(data=new_data, insert_position=new_positions, size=new_sizes)


class ShardedReplay(Generic[Sample]):
    """`shards` rings side by side in one buffer: ring d holds rows [d·C/n, (d+1)·C/n) and the
    transitions of envs [d·E/n, (d+1)·E/n), and is sampled for its share of every batch. Split
    over devices along the rows, each ring's inserts and draws stay on its device."""

    def __init__(self, ring: RingReplay[Sample], shards: int):
        self.ring = ring
        self.shards = shards
        self.capacity = ring.capacity * shards

    def init(self) -> ReplayState:
        """An empty buffer; its positions have one entry per ring."""
        empty = self.ring.init()
        return ReplayState(
            data=jnp.zeros((self.capacity,) + empty.data.shape[1:], empty.data.dtype),
            insert_position=jnp.zeros((self.shards,), jnp.int32),
            size=jnp.zeros((self.shards,), jnp.int32),
        )

    def _rings(self, state: ReplayState) -> ReplayState:
        return state.replace(data=self._split(state.data))

    def _split(self, x: jax.Array) -> jax.Array:
        return jnp.reshape(x, (self.shards, x.shape[0] // self.shards) + x.shape[1:])

    def insert(self, state: ReplayState, samples: Sample, valid: jax.Array) -> ReplayState:
        """Each ring appends the valid rows of its envs (`samples` batched over all envs)."""
        rings = jax.vmap(self.ring.insert)(
            self._rings(state), jax.tree.map(self._split, samples), self._split(valid)
        )
        return rings.replace(data=jnp.reshape(rings.data, state.data.shape))

    def sample(self, state: ReplayState, key: jax.Array, per_ring: int) -> Sample:
        """(shards, per_ring) transitions, drawn uniformly from each ring."""
        keys = jax.random.split(key, self.shards)
        return jax.vmap(lambda ring, key: self.ring.sample(ring, key, per_ring))(
            self._rings(state), keys
        )


def for_transitions(
    capacity: int, shards: int, observation_size: int, action_size: int
) -> "RingReplay | ShardedReplay":
    """A buffer of `capacity` SAC transitions (Brax's, with the truncation flag): one ring per
    device of `shards`, filled by that device's envs and sampled by it."""
    obs = jnp.zeros((observation_size,))
    dummy = types.Transition(
        observation=obs,
        action=jnp.zeros((action_size,)),
        reward=jnp.zeros(()),
        discount=jnp.zeros(()),
        next_observation=obs,
        extras={"state_extras": {"truncation": jnp.zeros(())}, "policy_extras": {}},
    )
    ring = RingReplay(capacity // shards, dummy)
    return ring if shards == 1 else ShardedReplay(ring, shards)
