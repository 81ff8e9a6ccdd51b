"""The on-disk caches that make a second start fast: JAX's persistent compilation cache, Warp's
kernel cache, both on by default under one per-user directory, and the trainer's traced programs
kept inside the compilation cache (`Program`).

`QUADCOS_CACHE_DIR` moves them (default `~/.cache/quadcos`); `QUADCOS_CACHE_DIR=off` turns them
off. `JAX_COMPILATION_CACHE_DIR` / `WARP_CACHE_PATH`, when set, win for their own cache.

A traced program is traced once (`jax.export`: the StableHLO module of its flattened arguments and
results) and saved under `<compilation cache>/traced/`, keyed by its name, its arguments'
structure, shapes and dtypes, the backend, the caller's fingerprint (what the program closes
over: the env's and trainer's configs, the robot's compiled model, the terrain) and the code that
traces it (every source file of quadcos and the versions of the libraries it calls). A later
process with the same key loads the module and compiles it, which the compilation cache answers:
it skips tracing and lowering. Any change to those inputs is a new key; a file that cannot be read
is traced again and rewritten.
"""

import functools
import hashlib
import importlib.metadata
import inspect
import json
import logging
import os
import pathlib
import pickle
import re
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from jax import export

from quadcos._util import files

CACHE_ENV = "QUADCOS_CACHE_DIR"


def cache_root() -> pathlib.Path | None:
    """The caches' parent directory, or None when `QUADCOS_CACHE_DIR=off`."""
    value = os.environ.get(CACHE_ENV, "")
    if value.lower() in ("off", "0", "none", "false"):
        return None
    return pathlib.Path(value).expanduser() if value else pathlib.Path.home() / ".cache" / "quadcos"


def enable() -> dict[str, str | None]:
    """Switches both caches on (call once, in a CLI's main, before compiling anything). Returns
    {"jax": dir or None, "warp": dir or None, "state": "cold" | "warm"} for the run's records."""
    root = cache_root()
    jax_dir = (
        jax.config.jax_compilation_cache_dir  # set by the caller (tests): keep it
        or os.environ.get("JAX_COMPILATION_CACHE_DIR")
        or (root and str(root / "jax"))
    )
    if jax_dir:
        jax.config.update("jax_compilation_cache_dir", jax_dir)
        # MJX programs are many and small: cache every one, however quick its compile.
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
        jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    warp_dir = os.environ.get("WARP_CACHE_PATH") or (root and str(root / "warp"))
    if warp_dir:
        os.environ.setdefault("WARP_CACHE_PATH", warp_dir)
    return {"jax": jax_dir, "warp": warp_dir, "state": state(jax_dir)}


def state(jax_dir: str | None) -> str:
    """ "cold" (no cache, or an empty one), else "warm": what this process starts from."""
    directory = pathlib.Path(jax_dir) if jax_dir else None
    warm = directory is not None and directory.is_dir() and any(directory.iterdir())
    return "warm" if warm else "cold"


logger = logging.getLogger("quadcos.train")

TRACED = "traced"  # the folder of traced programs, in the compilation cache
LIBRARIES = ("jax", "jaxlib", "mujoco", "mujoco-mjx", "brax", "flax", "optax")


def traced_directory() -> pathlib.Path | None:
    """Where traced programs are kept: inside JAX's compilation cache, None while it is off."""
    cache = jax.config.jax_compilation_cache_dir
    return pathlib.Path(cache) / TRACED if cache else None


@functools.cache
def code_version() -> str:
    """A digest of quadcos's source files and the libraries' versions: what traces a program."""
    digest = hashlib.sha256()
    package = pathlib.Path(__file__).resolve().parent.parent  # quadcos/
    for path in sorted(package.rglob("*.py")):
        digest.update(str(path.relative_to(package)).encode())
        digest.update(path.read_bytes())
    for library in LIBRARIES:
        try:
            digest.update(f"{library}={importlib.metadata.version(library)}".encode())
        except importlib.metadata.PackageNotFoundError:
            digest.update(f"{library}=none".encode())
    return digest.hexdigest()


def env_fingerprint(env: Any, data: tuple[str, ...] = ()) -> str:
    """A digest of what an env's programs close over: its resolved config but for the dotted
    fields `data` (what its programs take as data), its compiled MuJoCo model (robot, ground,
    solver) and its terrain (class, source file, fields)."""
    config = env.config.to_dict()
    for name in data:
        *parents, leaf = name.split(".")
        functools.reduce(lambda node, key: node[key], parents, config).pop(leaf, None)
    digest = hashlib.sha256(json.dumps(config, sort_keys=True, default=str).encode())
    model = np.zeros(mujoco.mj_sizeModel(env.mj_model), np.uint8)
    mujoco.mj_saveModel(env.mj_model, None, model)
    digest.update(model.tobytes())
    terrain = type(env.terrain)
    digest.update(f"{terrain.__module__}.{terrain.__qualname__}".encode())
    source = inspect.getsourcefile(terrain)
    if source:
        digest.update(pathlib.Path(source).read_bytes())
    for name, value in sorted(vars(env.terrain).items()):
        digest.update(name.encode())
        digest.update(
            np.asarray(value).tobytes() if isinstance(value, np.ndarray) else repr(value).encode()
        )
    return digest.hexdigest()


def trainer_fingerprint(
    env: Any, eval_env: Any, programs: dict[str, Any], one_device: bool
) -> str | None:
    """What a trainer's programs close over: its envs' fingerprints (but for the config fields
    of an env's `gait_fields`, which the trainer passes as data) and `programs`, the trainer
    config's fields its programs read (`training.config.program_fields`); None where
    they are traced in every process: an env not quadcos's, several devices, MJX-Warp (its
    kernels load as a program is traced) or the compilation cache off."""
    envs = (env, eval_env or env)
    if traced_directory() is None or not one_device:
        return None
    if not all(hasattr(e, "mj_model") and getattr(e, "impl", None) == "jax" for e in envs):
        return None
    parts = [env_fingerprint(e, getattr(e, "gait_fields", ())) for e in envs]
    parts.append(json.dumps(programs, sort_keys=True, default=str))
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


class Program:
    """`jax.jit(fn, donate_argnums=...)` whose trace is kept on disk: `lower(*args).compile()`
    and calls as a jitted function's (any arguments of the same structure, shapes and dtypes as
    the first ones)."""

    def __init__(self, fn: Callable[..., Any], name: str, fingerprint: str, donate: bool = False):
        self._fn, self._name, self._fingerprint, self._donate = fn, name, fingerprint, donate
        self._compiled: Callable[..., Any] | None = None
        self._loaded: dict[str, tuple[export.Exported, Any] | None] = {}  # key -> read from disk

    def __call__(self, *args: Any) -> Any:
        if any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree.leaves(args)) or (
            self._compiled is None and _tracing()
        ):
            return self._staged(*args)
        if self._compiled is None:
            self._compiled = self.lower(*args).compile()
        return self._compiled(*args)

    def _staged(self, *args: Any) -> Any:
        """The program inside another trace (`jax.eval_shape`): its kept trace where there is
        one (nothing traced again), else `fn` staged there."""
        leaves, _, _, key = self._signature(args)
        loaded = self._load(key)
        if loaded is None:
            return jax.jit(self._fn)(*args)
        exported, out_tree = loaded
        return jax.tree.unflatten(out_tree, exported.call(*leaves))

    def lower(self, *args: Any) -> Any:
        leaves, in_tree, avals, key = self._signature(args)
        try:
            exported, out_tree = self._load(key) or self._trace(key, in_tree, avals)
        except (ValueError, NotImplementedError, TypeError) as error:
            # what jax.export refuses (a host callback, say) is traced as any jitted program
            logger.debug("program %s not kept traced: %s", self._name, error)
            return jax.jit(self._fn, donate_argnums=(0,) if self._donate else ()).lower(*args)
        donate = tuple(range(len(leaves))) if self._donate else ()

        def call(*flat: Any) -> Any:
            return exported.call(*flat)

        call.__name__ = self._name  # the program's name in profiles: jit(train_chunk)
        return _Lowered(jax.jit(call, donate_argnums=donate).lower(*avals), out_tree)

    def _signature(self, args: tuple) -> tuple[list[Any], Any, list[jax.ShapeDtypeStruct], str]:
        """The arguments' leaves, tree and shapes, and the key of the program traced for them."""
        leaves, in_tree = jax.tree.flatten(args)
        avals = [jax.ShapeDtypeStruct(leaf.shape, leaf.dtype) for leaf in leaves]
        key = hashlib.sha256(
            "\n".join(
                [self._name, self._fingerprint, code_version(), jax.default_backend()]
                # (MJX's static arrays print as objects at an address: the model, fingerprinted,
                # fixes them)
                + [re.sub(r" at 0x[0-9a-f]+", "", str(in_tree))]
                + [f"{aval.shape}{aval.dtype}" for aval in avals]
            ).encode()
        ).hexdigest()[:32]
        return leaves, in_tree, avals, key

    def _load(self, key: str) -> tuple[export.Exported, Any] | None:
        """The kept trace of `key`, read from disk once (the memory check's `jax.eval_shape`
        and the compile both use it); None where there is none or it is unreadable."""
        if key not in self._loaded:
            self._loaded[key] = self._read(key)
        return self._loaded[key]

    def _read(self, key: str) -> tuple[export.Exported, Any] | None:
        folder = traced_directory()
        path = folder and folder / f"{self._name}-{key}"
        if path is None or not path.exists():
            return None
        try:
            exported_bytes, out_tree = pickle.loads(path.read_bytes())
            return export.deserialize(exported_bytes), out_tree
        except Exception as error:  # noqa: BLE001 (a damaged or foreign file: traced again)
            logger.debug("traced program %s unreadable (%s): tracing it", path, error)
            return None

    def _trace(
        self, key: str, in_tree: Any, avals: list[jax.ShapeDtypeStruct]
    ) -> tuple[export.Exported, Any]:
        box = {}

        def flat(*leaves: Any) -> list[Any]:
            results, box["out_tree"] = jax.tree.flatten(
                self._fn(*jax.tree.unflatten(in_tree, leaves))
            )
            return results

        flat.__name__ = self._name
        exported = export.export(jax.jit(flat))(*avals)
        folder = traced_directory()
        if folder is not None:
            folder.mkdir(parents=True, exist_ok=True)
            files.atomic_write_bytes(
                folder / f"{self._name}-{key}", pickle.dumps((exported.serialize(), box["out_tree"]))
            )
        return exported, box["out_tree"]


def _tracing() -> bool:
    """Whether a JAX trace is active: an operation on a constant gives a tracer there."""
    return isinstance(jnp.zeros(()) + 0, jax.core.Tracer)


class _Lowered:
    """A loaded program lowered for its arguments: `compile()` gives the callable on pytrees."""

    def __init__(self, lowered: Any, out_tree: Any):
        self._lowered, self._out_tree = lowered, out_tree

    def compile(self) -> Callable[..., Any]:
        compiled, out_tree = self._lowered.compile(), self._out_tree
        return lambda *args: jax.tree.unflatten(out_tree, compiled(*jax.tree.leaves(args)))
