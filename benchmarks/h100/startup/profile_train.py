"""Where a `quadcos.train` process's seconds go on its main thread, and in its exit handlers:
cProfile of `quadcos.train.main(ARGS)`, then of the `atexit` handlers, each summed by function
(the 40 largest cumulative times) into PREFIX.main.txt / PREFIX.atexit.txt.

    python benchmarks/h100/startup/profile_train.py PREFIX ARGS...

Prints the seconds from process start to main's return and to the handlers' end; what the
process takes after that (freeing the device, the interpreter's own teardown) is the difference
to the process's wall time as its caller measures it."""

import atexit
import cProfile
import io
import pstats
import sys
import time

from quadcos import train
from quadcos._util import provenance


def _write(profile: cProfile.Profile, path: str) -> None:
    text = io.StringIO()
    pstats.Stats(profile, stream=text).sort_stats("cumulative").print_stats(40)
    with open(path, "w") as out:
        out.write(text.getvalue())


def main() -> int:
    prefix, args = sys.argv[1], sys.argv[2:]
    start = provenance.process_start()
    profile = cProfile.Profile()
    status = profile.runcall(train.main, args)
    main_done = time.monotonic() - start
    _write(profile, f"{prefix}.main.txt")
    exit_profile = cProfile.Profile()
    exit_profile.runcall(atexit._run_exitfuncs)
    handlers_done = time.monotonic() - start
    _write(exit_profile, f"{prefix}.atexit.txt")
    print(f"main returned at {main_done:.2f} s, exit handlers done at {handlers_done:.2f} s",
          file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
