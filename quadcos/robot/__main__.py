"""`python -m quadcos.robot describe --robot=SPEC`: what quadcos derives from a robot's MJCF.

    python -m quadcos.robot describe --robot=quad12
    MENAGERIE_ROOT=../shared/menagerie python -m quadcos.robot describe --robot=menagerie:unitree_go1

Prints the description as JSON on stdout: the legs (labelled by where their hips sit) with their
joints by role, feet, signs and lengths; the home pose; the standing height; the torso box of the
fall check; the mass; the actuators and gains; the physics of its preset. A robot quadcos cannot
drive exits with status 2 and one line on stderr.
"""

import argparse
import json
import sys
from collections.abc import Sequence

from quadcos._util import cli
from quadcos.robot.loading import load


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status."""
    parser = cli.raising(
        argparse.ArgumentParser(
            prog="python -m quadcos.robot",
            description=__doc__,
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
    )
    parser.add_argument("command", choices=("describe",), help="describe: the derived description")
    parser.add_argument(
        "--robot",
        default="quadcos",
        help="quadcos (default), quad12, an MJCF path, menagerie:NAME or a registered name",
    )
    try:
        args = parser.parse_args(argv)
        robot = load(args.robot)
    except (ValueError, FileNotFoundError, OSError, ImportError) as error:
        cli.print_error("quadcos.robot", error)
        return cli.EXIT_USAGE
    print(json.dumps(robot.summary(), indent=2))
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
