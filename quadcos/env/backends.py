"""Which MJX implementation simulates the robots: MuJoCo's JAX port or MuJoCo Warp.

`impl="warp"` runs MJX's physics as Warp kernels called from JAX (mujoco-mjx vendors MuJoCo Warp;
it needs only the `warp-lang` package). On our robot it is 2.4–3.6× the JAX
physics (BENCHMARKS.md). `impl="auto"` picks Warp where it can run and JAX elsewhere, so the CPU
path (CI, `make train`) stays JAX.

Warp preallocates its contact and constraint buffers: contacts for all worlds of a batch
together (`naconmax`), constraint rows per world (`njmax`). `warp_sizes` derives them from the
largest batch the env will be stepped in and a per-robot bound.
"""

import functools
import importlib.util
import logging

import jax
import ml_collections
import mujoco

from quadcos._util import quiet
from quadcos._util.quiet import warp_absence_unprinted
from quadcos.env import warp_arena, warp_preload

logger = logging.getLogger(__name__)

with warp_absence_unprinted():  # MJX prints a notice to stdout when warp-lang is absent
    from mujoco import mjx

IMPLS = ("auto", "jax", "warp")
INSTALL_HINT = "pip install 'quadcos[warp]'  (warp-lang; MJX's Warp backend needs a CUDA GPU)"


@functools.cache
def warp_installed() -> bool:
    """Whether the `warp-lang` package can be imported (checked without importing it)."""
    return importlib.util.find_spec("warp") is not None


def cuda_available() -> bool:
    """Whether JAX sees a CUDA GPU."""
    try:
        return bool(jax.devices("cuda"))
    except RuntimeError:
        return False


def resolve_impl(impl: str, gpu_physics: str = "warp", *, warn: bool = True) -> str:
    """"jax" or "warp" for a configured `impl`: "auto" = `gpu_physics` (the robot's faster
    physics on a GPU, measured: quadcos.robot.presets) where a CUDA GPU is present (and
    warp-lang, for Warp), else JAX (with `warn`, a warning where Warp is missing); an explicit
    "warp" also runs on the CPU, slowly, as MJX allows. Raises ValueError for an unknown name or
    "warp" without warp-lang."""
    if impl not in IMPLS:
        raise ValueError(f"unknown impl {impl!r}; known: {', '.join(IMPLS)}")
    if impl == "auto":
        on_gpu = cuda_available()
        runnable = gpu_physics == "jax" or warp_installed()
        if on_gpu and not runnable and warn:
            logger.warning(
                "impl 'auto' runs MJX-JAX: this robot's GPU physics is MJX-Warp, and warp-lang is"
                " not installed (%s)",
                INSTALL_HINT,
            )
        impl = gpu_physics if on_gpu and runnable else "jax"
    if impl == "warp":
        if not warp_installed():
            raise ValueError(f"impl 'warp' needs warp-lang, which is not installed: {INSTALL_HINT}")
        quiet.quiet_warp()  # before Warp loads a module: no line per module (unless --verbose)
    return impl


def warp_sizes(config: ml_collections.ConfigDict, mj_model=None) -> dict[str, int]:
    """Warp's buffer sizes for an env config: `naconmax` (contacts, all worlds of the largest
    batch together) and `njmax` (constraint rows per world: `constraints_per_env`, or with 0 as
    many as the robot can need, `constraint_rows` with the config's contact counts, and at least
    the 64 the paper's robot's results were measured with)."""
    warp = config.warp
    rows = warp.constraints_per_env or max(
        _PAPER_ROWS, constraint_rows(mj_model, warp.contacts_per_env, warp.hfield_contacts)
    )
    return {"naconmax": warp.max_envs * warp.contacts_per_env, "njmax": rows}


_PAPER_ROWS = 64


def constraint_rows(mj_model, contacts: int, hfield_contacts: int = 0) -> int:
    """Constraint rows a world of `mj_model` can need: `contacts` contacts (at least
    `hfield_contacts` where the ground is a heightfield: a foot sphere touches several of its
    triangles at once; the robot preset's, `quadcos.robot.presets`) of its largest condim (a
    pyramidal cone takes 2 (condim − 1) rows a contact, an elliptic one condim), a row per limited
    joint, and its equality constraints (6 rows each, at most). Menagerie's Go1 has condim-6
    feet: 10 rows a contact."""
    if (mj_model.geom_type == mujoco.mjtGeom.mjGEOM_HFIELD).any():
        contacts = max(contacts, hfield_contacts)
    colliding = mj_model.geom_contype | mj_model.geom_conaffinity
    condim = int(mj_model.geom_condim[colliding > 0].max(initial=3))
    pyramidal = mj_model.opt.cone == 0  # mjCONE_PYRAMIDAL
    per_contact = 2 * (condim - 1) if pyramidal and condim > 1 else condim
    return contacts * per_contact + int(mj_model.jnt_limited.sum()) + 6 * mj_model.neq


def default_warp_config() -> ml_collections.ConfigDict:
    """Warp buffer bounds. Four foot spheres make ≤ 4 contacts on a plane and a few more on a
    heightfield; a pyramidal cone of condim 3 gives 4 rows a contact. Playground's Go1 uses 4
    contacts and 40 rows a world on flat ground, 8 and 60 on rough terrain."""
    config = ml_collections.ConfigDict()
    config.max_envs = 16384  # the largest batch stepped at once; the trainer raises it as needed
    config.contacts_per_env = 8
    config.constraints_per_env = 0  # 0: what the robot can need (constraint_rows)
    # Contacts a world can make on a heightfield (sizes the rows); 0: the robot preset's.
    config.hfield_contacts = 0
    # CUDA graph capture of MJX-Warp's calls (warp.JaxCallableGraphMode): "auto" is MJX's choice
    # (Warp captures and replays a graph per call on a GPU), or one of GRAPH_MODES by name.
    config.graph_mode = "auto"
    # The solver's early exit as a conditional node of the step's CUDA graph (MuJoCo Warp's
    # `graph_conditional`, its default); False runs all the MJCF's `iterations` every step.
    config.graph_conditional = True
    # MuJoCo Warp's scratch arrays from fixed blocks instead of allocations inside each call's
    # graph (`quadcos.env.warp_arena`; always on with graph_mode "jax", which needs it). Once an
    # env turns it on, every MJX-Warp call of the process uses it.
    config.arena = False
    return config


GRAPH_MODES = ("auto", "warp", "warp_staged", "jax", "none")


# XLA's default command buffers (xla/debug_options_flags.cc) with loops added. Not branches: with
# them (the course curriculum's resets, an MJX-Warp call under `lax.cond`, in a conditional node)
# and concurrent scheduling a --preset=any_slope run hung after its first chunk; without either it
# ran, and the bench's rows run as fast without branches (benchmarks/h100/gait/).
_COMMAND_BUFFERS = "FUSION,CUBLAS,CUBLASLT,CUSTOM_CALL,CUDNN,DYNAMIC_SLICE_FUSION,WHILE"


def compiler_options(impl: str, warp_config: ml_collections.ConfigDict) -> dict[str, str]:
    """XLA options (`jax.jit(compiler_options=...)`) for the programs that step this physics.
    With MJX-Warp's calls recorded by XLA (graph mode "jax"): loops in XLA's command buffers too,
    so that a chunk of env steps is one graph launch where its loop holds no branch
    (`_COMMAND_BUFFERS`), and work that does not depend on other work in a graph's branches side
    by side (CONCURRENT: e.g. the SAC updates beside the physics, `overlap_updates`). Otherwise
    none."""
    if impl != "warp" or warp_config.graph_mode != "jax":
        return {}
    return {
        "xla_gpu_enable_command_buffer": _COMMAND_BUFFERS,
        "xla_gpu_command_buffer_scheduling_mode": "CONCURRENT",
    }


def put_model(
    mj_model, impl: str, warp_config: ml_collections.ConfigDict | None = None
) -> mjx.Model:
    """The device model for a resolved `impl` (with Warp, captured in CUDA graphs as
    `warp_config.graph_mode` says, the solver's early exit a conditional graph node where
    `warp_config.graph_conditional`, MuJoCo Warp's scratch arrays from `warp_arena` where
    `warp_config.arena` or graph mode "jax"). With Warp, the per-step console warning that the
    solver reached its iteration limit is off: our MJCF sets few iterations on purpose, and the
    JAX physics stops there silently too. Buffer overflows (dropped contacts) still warn."""
    if impl != "warp":
        return mjx.put_model(mj_model, device=local_device(), impl=impl)
    warp_config = warp_config or default_warp_config()
    mode = None
    if warp_config.graph_mode != "auto":
        import warp  # noqa: PLC0415 — installed wherever impl is warp

        mode = warp.JaxCallableGraphMode[warp_config.graph_mode.upper()]
    if warp_config.arena or warp_config.graph_mode == "jax":
        warp_arena.install()
    model = mjx.put_model(mj_model, device=local_device(), impl=impl, graph_mode=mode)
    from mujoco.mjx.third_party.mujoco_warp._src.types import OverflowType  # noqa: PLC0415

    option = model.opt._impl  # noqa: SLF001 — Warp's own options live there
    quiet = int(option.warn_overflow) & ~int(OverflowType.ITERATIONS | OverflowType.LS_ITERATIONS)
    changed = {"warn_overflow": quiet, "graph_conditional": bool(warp_config.graph_conditional)}
    sizes = warp_sizes(ml_collections.ConfigDict({"warp": warp_config}), mj_model)
    warp_preload.preload(mj_model, changed, sizes)
    option = option.replace(**changed)
    return model.replace(opt=model.opt.replace(_impl=option))


# MJX's JAX physics as jitted functions of (model, data), one pair per process: JAX keeps a jitted
# function's trace per argument layout, so every env of one robot (a test's, an evaluation's after
# training) reuses the first env's trace of MJX's physics instead of tracing it anew. XLA inlines
# the call: the compiled program is the one a direct call gives. MJX-Warp's calls stay direct.
def _pose(model: mjx.Model, data: mjx.Data) -> mjx.Data:
    """MJX-JAX's position stage short of collisions and constraints: bodies, geoms, sites, the
    actuators' transmission and the position sensors."""
    for stage in (mjx.kinematics, mjx.com_pos, mjx.camlight, mjx.tendon, mjx.transmission):
        data = stage(model, data)
    return mjx.sensor_pos(model, data)


_JAX_PHYSICS = {"step": jax.jit(mjx.step), "pose": jax.jit(_pose)}


def step(model: mjx.Model, data: mjx.Data) -> mjx.Data:
    """MJX's `step` (one physics step of `model`'s implementation)."""
    return (_JAX_PHYSICS["step"] if model.impl == mjx.Impl.JAX else mjx.step)(model, data)


def pose(model: mjx.Model, data: mjx.Data) -> mjx.Data:
    """A reset's derived quantities: where its bodies, geoms and position sensors are. MJX-JAX
    computes only that (`_pose`: a reset's program without the collision pipeline and solver that
    `forward` adds, which the next `step` computes anyway: `forward` leaves `qacc_warmstart`, the
    one result a step reads back, untouched); MJX-Warp runs its `forward`."""
    return (_JAX_PHYSICS["pose"] if model.impl == mjx.Impl.JAX else mjx.forward)(model, data)


def make_data(mj_model, impl: str, config: ml_collections.ConfigDict) -> mjx.Data:
    """A fresh `mjx.Data` for one robot (batch with `jax.vmap`)."""
    if impl == "warp":
        return mjx.make_data(
            mj_model, device=local_device(), impl="warp", **warp_sizes(config, mj_model)
        )
    return mjx.make_data(mj_model, device=local_device(), impl="jax")


def local_device() -> jax.Device:
    """This process's first device, where an env's model and data live (MJX's default, the
    first of `jax.devices()`, is process 0's in a run over several processes)."""
    return jax.local_devices()[0]
