"""The on-disk caches that make a second start fast: JAX's persistent compilation cache and
Warp's kernel cache, both on by default under one per-user directory.

`QUADCOS_CACHE_DIR` moves them (default `~/.cache/quadcos`); `QUADCOS_CACHE_DIR=off` turns both
off. `JAX_COMPILATION_CACHE_DIR` / `WARP_CACHE_PATH`, when set, win for their own cache.
"""

import os
import pathlib

import jax

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
    """"cold" (no cache, or an empty one), else "warm": what this process starts from."""
    directory = pathlib.Path(jax_dir) if jax_dir else None
    warm = directory is not None and directory.is_dir() and any(directory.iterdir())
    return "warm" if warm else "cold"
