"""Quiet imports of third-party modules that print to stdout, and Warp's module-load lines.

mujoco-mjx prints "Failed to import warp: No module named 'warp'" (and the same for mujoco_warp)
to stdout on import when the optional warp-lang is absent. quadcos runs MJX's JAX implementation,
so the notice says nothing; printed to stdout it corrupts what a command prints there (the JSON of
`python -m quadcos.train --print_config`).
"""

import contextlib
import io
import os
import re
import sys
from collections.abc import Iterator

_WARP_ABSENT = re.compile(r"Failed to import (mujoco_)?warp: No module named '(warp|mujoco_warp)'")


@contextlib.contextmanager
def warp_absence_unprinted() -> Iterator[None]:
    """Drops the "warp is absent" notices printed inside the block; anything else printed there
    (a warp that is installed but broken, for one) goes to stderr. Exceptions pass through."""
    captured = io.StringIO()
    try:
        with contextlib.redirect_stdout(captured):
            yield
    finally:
        for line in captured.getvalue().splitlines():
            if not _WARP_ABSENT.fullmatch(line.strip()):
                print(line, file=sys.stderr)


VERBOSE_ENV = "QUADCOS_VERBOSE"  # "1": Warp prints its module-load lines (the CLIs' --verbose)


def quiet_warp(verbose: bool = False) -> None:
    """Silences Warp's line per kernel module loaded ("Module ... load on device 'cuda:0' took
    ... ms (cached)", ~36 a process) and its start-up banner (Warp's info level: `log_level`
    where Warp has it, 1.19 among them; `quiet` before) unless `verbose` or
    `QUADCOS_VERBOSE=1`. `verbose` sets `QUADCOS_VERBOSE`, so that later calls
    (`quadcos.env.backends.resolve_impl`, before Warp loads a module) and child processes keep
    it. Nothing without warp-lang."""
    if verbose:
        os.environ[VERBOSE_ENV] = "1"
    try:
        import warp  # noqa: PLC0415 — only where it is installed
    except ImportError:
        return
    quiet = os.environ.get(VERBOSE_ENV, "") != "1"
    if hasattr(warp.config, "log_level"):  # warp-lang 1.1x: levels; `config.quiet` is ignored
        warp.config.log_level = warp.LOG_WARNING if quiet else warp.LOG_INFO
    else:
        warp.config.quiet = quiet
