"""What the command lines share: a user error is one line on stderr and exit status 2."""

import argparse
import contextlib
import gc
import logging
import sys
from collections.abc import Iterator
from typing import NoReturn

EXIT_OK = 0
EXIT_FAILURE = 1  # the work itself failed (e.g. a non-finite loss, a failed measurement)
EXIT_USAGE = 2  # bad flags, values, paths or specs; reported before anything is written


class UsageError(ValueError):
    """A user error on the command line: reported as one line, exit status 2."""


def _raise_usage_error(message: str):
    raise UsageError(message)


def raising(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """`parser`, raising UsageError where argparse would print its usage and exit."""
    parser.error = _raise_usage_error
    return parser


def print_error(prog: str, error: BaseException) -> None:
    """`<prog>: error: <message>` on stderr, on one line even when the message (e.g. MuJoCo's
    XML parser's) has several."""
    lines = (line.strip() for line in str(error).splitlines())
    print(f"{prog}: error: {'; '.join(filter(None, lines))}", file=sys.stderr)


def exit_process(status: int) -> NoReturn:
    """Ends a command's process with `status`, without collecting its objects first: JAX's
    caches of traced programs make that collection take seconds (3 s of a smoke run's 36 on two
    cores), and the process's memory goes back to the system anyway. For `__main__` only: a
    program that goes on after the command (a test, a notebook) keeps its collector."""
    gc.freeze()
    sys.exit(status)


class _Formatter(logging.Formatter):
    def __init__(self, prog: str):
        super().__init__()
        self.prog = prog

    def format(self, record: logging.LogRecord) -> str:
        level = "" if record.levelno < logging.WARNING else f"{record.levelname.lower()}: "
        return f"{self.prog}: {level}{record.getMessage()}"


@contextlib.contextmanager
def logging_to_stderr(prog: str, level: int = logging.INFO) -> Iterator[None]:
    """quadcos's log records at `level` and above as "<prog>: [warning: ]..." lines on stderr."""
    package_logger = logging.getLogger("quadcos")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_Formatter(prog))
    saved = package_logger.level, package_logger.propagate
    package_logger.addHandler(handler)
    package_logger.setLevel(level)
    package_logger.propagate = False
    try:
        yield
    finally:
        package_logger.removeHandler(handler)
        package_logger.level, package_logger.propagate = saved
