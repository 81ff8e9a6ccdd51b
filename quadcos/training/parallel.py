"""Data-parallel training over the devices of a mesh (one host or several).

One training run spreads over a 1-D `jax.sharding.Mesh` whose axis is `AXIS`: every device steps
its own slice of the training envs, keeps its own slice of the replay buffer and samples it, and
the SAC gradients are averaged across devices in one collective per update (`pmean`), so that
parameters, optimiser states and observation statistics stay identical everywhere. The compiled
functions are `shard_map`s of the single-device ones (`sharded`): inside them each array has its
local shape, `shard_index()` says which slice is this device's, and `pmean` / `psum` are the
identity on one device, where nothing is sharded at all.

`num_envs`, `batch_size`, `replay_size` and `num_eval_envs` stay global (the whole run's): each
must divide evenly by the number of devices (`check_divisible`).

Several hosts: `initialize_distributed` (`jax.distributed.initialize`) before anything touches a
device; then `jax.devices()` lists every process's devices and the mesh spans them all.
"""

import dataclasses
import logging
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
from jax.sharding import Mesh, NamedSharding, PartitionSpec

logger = logging.getLogger(__name__)

AXIS = "devices"
# The config's sizes that are global and must split evenly over the devices.
GLOBAL_SIZES = ("num_envs", "batch_size", "replay_size", "num_eval_envs")


@dataclasses.dataclass(frozen=True)
class Layout:
    """How a run spreads over devices: `mesh` None is one device (no `shard_map`, no collectives)."""

    mesh: Mesh | None

    @property
    def shards(self) -> int:
        return 1 if self.mesh is None else self.mesh.size

    @property
    def axis_name(self) -> str | None:
        return None if self.mesh is None else AXIS

    def replicated(self) -> NamedSharding | None:
        return None if self.mesh is None else NamedSharding(self.mesh, PartitionSpec())


def make_layout(num_devices: int | None) -> Layout:
    """The first `num_devices` of `jax.devices()` (every process's devices; None: all of them).

    Raises:
      ValueError: `num_devices` is below 1 or above the devices there are.
    """
    devices = jax.devices()
    count = len(devices) if num_devices is None else int(num_devices)
    if not 1 <= count <= len(devices):
        raise ValueError(
            f"num_devices={num_devices}: this run sees {len(devices)} device(s)"
            f" ({devices[0].platform}); choose 1 to {len(devices)}"
        )
    if count == 1 and jax.process_count() == 1:
        return Layout(mesh=None)
    return Layout(mesh=Mesh(devices[:count], (AXIS,)))


def check_divisible(config: Any, shards: int) -> None:
    """One line naming the first global size that does not split over `shards` devices.

    Raises:
      ValueError: e.g. "num_envs=100 does not divide evenly over 3 devices".
    """
    for name in GLOBAL_SIZES:
        value = int(config[name])
        if value % shards:
            raise ValueError(
                f"{name}={value} does not divide evenly over {shards} devices;"
                f" use a multiple of {shards} (e.g. {value - value % shards or shards})"
            )


def shard_index(axis_name: str | None) -> jax.Array:
    """This device's position on the mesh axis (0 on one device)."""
    return jnp.zeros((), jnp.int32) if axis_name is None else jax.lax.axis_index(axis_name)


def pmean(tree: Any, axis_name: str | None) -> Any:
    """The mean over devices of every leaf (one collective); the identity on one device."""
    return tree if axis_name is None else jax.lax.pmean(tree, axis_name)


def psum(tree: Any, axis_name: str | None) -> Any:
    """The sum over devices of every leaf; the identity on one device."""
    return tree if axis_name is None else jax.lax.psum(tree, axis_name)


def local_rows(array: jax.Array, shard: jax.Array | int, shards: int) -> jax.Array:
    """Slice `shard` of `shards` (along axis 0) of an array every device holds whole: drawing
    global random numbers and slicing keeps a run's randomness that of one device."""
    if shards == 1:
        return array
    size = array.shape[0] // shards
    return jax.lax.dynamic_slice_in_dim(array, shard * size, size)


def sharded(
    fn: Callable[..., Any],
    layout: Layout,
    in_specs: Any,
    out_specs: Any,
    donate_argnums: int | tuple[int, ...] = (),
) -> Callable[..., Any]:
    """`jax.jit(fn)` on one device; on a mesh, `jit` of `fn` mapped over it with `shard_map`."""
    if layout.mesh is None:
        return jax.jit(fn, donate_argnums=donate_argnums)
    # check_vma=False: the env code's scans start carries from constants (invariant across
    # devices) that the steps make device-varying; what is replicated is made so explicitly
    # (`pmean`, `psum`, keys every device holds alike), which the tests check.
    mapped = jax.shard_map(
        fn, mesh=layout.mesh, in_specs=in_specs, out_specs=out_specs, check_vma=False
    )
    return jax.jit(mapped, donate_argnums=donate_argnums)


def named_shardings(layout: Layout, specs: Any) -> Any:
    """`specs` (a tree of PartitionSpec) as NamedShardings on the layout's mesh."""
    return jax.tree.map(
        lambda spec: NamedSharding(layout.mesh, spec),
        specs,
        is_leaf=lambda node: isinstance(node, PartitionSpec),
    )


def join_slices(specs: Any, slices: list[Any]) -> Any:
    """The global tree of per-device `slices`: leaves split along `AXIS` joined in device order,
    the others (alike on every device) taken from the first slice."""
    return jax.tree.map(
        lambda spec, *leaves: jnp.concatenate(leaves) if spec == PartitionSpec(AXIS) else leaves[0],
        specs,
        *slices,
        is_leaf=lambda node: isinstance(node, PartitionSpec),
    )


def state_specs(abstract_state: Any, sharded_fields: tuple[str, ...], num_envs: int) -> Any:
    """The `PartitionSpec` of every leaf of a (global) training state: split along axis 0 for the
    leaves of `sharded_fields` that have a leading axis (the envs', the replay buffer's), all else
    replicated. Leaves of those fields without the env axis (MJX-Warp's shared buffers) stay
    replicated."""

    def field_specs(name: str, value: Any) -> Any:
        if name not in sharded_fields:
            return jax.tree.map(lambda _: PartitionSpec(), value)
        if name == "env_state":
            return jax.tree.map(
                lambda leaf: PartitionSpec(AXIS)
                if leaf.ndim and leaf.shape[0] == num_envs
                else PartitionSpec(),
                value,
            )
        return jax.tree.map(lambda leaf: PartitionSpec(AXIS), value)

    fields = {
        field.name: field_specs(field.name, getattr(abstract_state, field.name))
        for field in dataclasses.fields(abstract_state)
    }
    return abstract_state.replace(**fields)


def initialize_distributed(
    coordinator: str | None, num_processes: int | None, process_id: int | None
) -> None:
    """`jax.distributed.initialize` for a run over several processes (hosts), before any device
    is touched; nothing when `coordinator` is None.

    Raises:
      ValueError: `coordinator` without `num_processes` and `process_id`, or an id out of range.
    """
    if coordinator is None:
        if num_processes is not None or process_id is not None:
            raise ValueError("--num_processes and --process_id need --coordinator=HOST:PORT")
        return
    if num_processes is None or process_id is None:
        raise ValueError("--coordinator needs --num_processes=N and --process_id=I")
    if not 0 <= process_id < num_processes:
        raise ValueError(f"--process_id={process_id}: choose 0 to {num_processes - 1}")
    jax.distributed.initialize(
        coordinator_address=coordinator, num_processes=num_processes, process_id=process_id
    )
    logger.info(
        "process %d of %d; %d local / %d global devices",
        jax.process_index(),
        jax.process_count(),
        jax.local_device_count(),
        jax.device_count(),
    )


def is_writer() -> bool:
    """Whether this process writes the run's files (config, metrics, policy): process 0."""
    return jax.process_index() == 0
