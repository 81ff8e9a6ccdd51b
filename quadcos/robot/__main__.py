"""`python -m quadcos.robot describe --robot=SPEC`: what quadcos derives from a robot's MJCF.

    python -m quadcos.robot describe --robot=quad12
    MENAGERIE_ROOT=../shared/menagerie python -m quadcos.robot describe --robot=menagerie:unitree_go1
    python -m quadcos.robot describe --probe --robot=path/to/robot.xml

Prints the description as JSON on stdout: the legs (labelled by where their hips sit) with their
joints by role, feet, signs and lengths; the home pose; the standing height; the torso box of the
fall check; the mass; the actuators and gains; the physics of its preset. With --probe, the
physics a training run would measure for it (`quadcos.env.solver_probe`: the cheapest step,
iterations and cone that simulate it as its own options do; a line per candidate and the choice on
stderr), under "physics" with the probe's measurements. A robot quadcos cannot drive exits with
status 2 and one line on stderr.
"""

import argparse
import json
import sys
from collections.abc import Sequence

from quadcos import env as env_lib
from quadcos._util import cli
from quadcos.env import solver_probe
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
    parser.add_argument(
        "--probe",
        action="store_true",
        help="measure the physics a training run would choose for it (a short MJX run)",
    )
    try:
        args = parser.parse_args(argv)
        summary = load(args.robot).summary()
        if args.probe:
            summary["physics"] |= _probed(args.robot)
    except (ValueError, FileNotFoundError, OSError, ImportError) as error:
        cli.print_error("quadcos.robot", error)
        return cli.EXIT_USAGE
    print(json.dumps(summary, indent=2))
    return cli.EXIT_OK


def _probed(robot: str) -> dict:
    """The physics `solver_probe` chooses for `robot` in the default env, and its record."""
    config = env_lib.default_config()
    config.robot = robot
    result = solver_probe.probe(config, log=lambda line: print(line, file=sys.stderr))
    print(result.message, file=sys.stderr)
    chosen = result.chosen
    return {
        "dt_s": chosen.physics_dt,
        "solver_iterations": chosen.solver_iterations,
        "ls_iterations": chosen.ls_iterations,
        "cone": chosen.cone,
        "probe": result.record(),
    }


if __name__ == "__main__":
    sys.exit(main())
