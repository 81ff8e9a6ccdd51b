"""Quiet imports of third-party modules that print to stdout.

mujoco-mjx prints "Failed to import warp: No module named 'warp'" (and the same for mujoco_warp)
to stdout on import when the optional warp-lang is absent. quadcos runs MJX's JAX implementation,
so the notice says nothing; printed to stdout it corrupts what a command prints there (the JSON of
`python -m quadcos.train --print_config`).
"""

import contextlib
import io
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
