"""Data-parallel training over the devices of a mesh (one host or several).

One training run spreads over a 1-D `jax.sharding.Mesh` whose axis is `AXIS`. The compiled
functions are the one-device program, jitted (`jit`) on a training state whose envs and replay
buffer are split along their first axis over the devices and whose networks, optimiser states
and statistics are replicated: XLA's SPMD partitioner gives every device its slice of the envs
to step and its ring of the buffer (`replay.ShardedReplay`) to fill and sample, and sums the
gradients across devices, so that the parameters stay identical everywhere. The exceptions run
in a `shard_map` (`per_device`): MJX-Warp's step, a custom call the partitioner cannot split, and
the training-time evaluation, each device on its share of the episodes.

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
from jax.sharding import Mesh, NamedSharding, PartitionSpec

logger = logging.getLogger(__name__)

AXIS = "devices"
# The config's sizes that are global and must split evenly over the devices.
GLOBAL_SIZES = ("num_envs", "batch_size", "replay_size", "num_eval_envs")


@dataclasses.dataclass(frozen=True)
class Layout:
    """How a run spreads over devices: `mesh` None is one device (nothing is placed)."""

    mesh: Mesh | None

    @property
    def shards(self) -> int:
        return 1 if self.mesh is None else self.mesh.size


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


def jit(
    fn: Callable[..., Any],
    layout: Layout,
    in_specs: Any,
    out_specs: Any,
    donate: bool = False,
    compiler_options: dict[str, str] | None = None,
) -> Callable[..., Any]:
    """`jax.jit(fn)` of a one-argument function; on a mesh with the argument and result placed
    as `in_specs` / `out_specs` say (None: replicated), so that the state keeps its layout from
    call to call. `compiler_options`: XLA's, for this program."""
    donate_argnums = (0,) if donate else ()
    if layout.mesh is None:
        return jax.jit(fn, donate_argnums=donate_argnums, compiler_options=compiler_options)
    shardings = lambda specs: (  # noqa: E731
        NamedSharding(layout.mesh, PartitionSpec())
        if specs is None
        else named_shardings(layout, specs)
    )
    out = tuple(map(shardings, out_specs)) if isinstance(out_specs, tuple) else shardings(out_specs)
    return jax.jit(
        fn,
        in_shardings=(shardings(in_specs),),
        out_shardings=out,
        donate_argnums=donate_argnums,
        compiler_options=compiler_options,
    )


def named_shardings(layout: Layout, specs: Any) -> Any:
    """`specs` (a tree of PartitionSpec) as NamedShardings on the layout's mesh."""
    return jax.tree.map(
        lambda spec: NamedSharding(layout.mesh, spec),
        specs,
        is_leaf=lambda node: isinstance(node, PartitionSpec),
    )


def env_specs(abstract_env_state: Any, num_envs: int) -> Any:
    """The `PartitionSpec` of every leaf of a batched env state: split along axis 0 where the
    leaf has the env axis, replicated where not (MJX-Warp's buffers shared by a batch's worlds)."""
    return jax.tree.map(
        lambda leaf: (
            PartitionSpec(AXIS) if leaf.ndim and leaf.shape[0] == num_envs else PartitionSpec()
        ),
        abstract_env_state,
    )


def per_device(fn: Callable[..., Any], layout: Layout, in_specs: Any, out_specs: Any) -> Any:
    """`fn` run by every device on its own slice of the envs (`jax.shard_map`): the training-time
    evaluation's episodes, and the training envs' steps with MJX-Warp.

    MJX-Warp's step is an XLA custom call, which the SPMD partitioner cannot
    split, so under plain `jit` every device would gather all envs and step them whole. Inside
    `shard_map` each device's call steps its own worlds with its own Warp module and stream (Warp
    reads the device from XLA's call frame). Leaves specified replicated (Warp's shared buffers)
    stay each device's own scratch.

    Programs holding such a `shard_map` are partitioned by GSPMD, not Shardy: with jax 0.11.2 on
    two H100s, XLA's `shardy-xla` pass segfaults on a `shard_map` of the MJX step (either physics;
    `experiments/scaling/stages.py 2 jax step`), and compiles and runs it with Shardy off."""
    _partition_with_gspmd()
    return jax.shard_map(
        fn, mesh=layout.mesh, in_specs=in_specs, out_specs=out_specs, check_vma=False
    )


def _partition_with_gspmd() -> None:
    """Turns Shardy off for the process (JAX's `jax_use_shardy_partitioner`), once, logged."""
    if jax.config.jax_use_shardy_partitioner:
        logger.info("per-device programs: XLA partitions with GSPMD (Shardy crashes on them)")
        jax.config.update("jax_use_shardy_partitioner", False)


def state_specs(abstract_state: Any, sharded_fields: tuple[str, ...], num_envs: int) -> Any:
    """The `PartitionSpec` of every leaf of a (global) training state: split along axis 0 for the
    leaves of `sharded_fields` that have a leading axis (the envs', the replay buffer's), all else
    replicated. Leaves of those fields without the env axis (MJX-Warp's shared buffers) stay
    replicated."""

    def field_specs(name: str, value: Any) -> Any:
        if name not in sharded_fields:
            return jax.tree.map(lambda _: PartitionSpec(), value)
        if name == "env_state":
            return env_specs(value, num_envs)
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
