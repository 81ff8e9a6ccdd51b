"""`python -m quadcos.export --policy DIR --out policy.npz` (or `policy.onnx`): a trained policy as
a JAX-free file, its format from the extension (.npz for NumPy, .onnx for ONNX Runtime).

The formats and the library behind them: `quadcos.deploy.export`.
"""

import argparse
from collections.abc import Sequence

from quadcos._util import cli
from quadcos.deploy.export import export_policy
from quadcos.evaluation import PolicySpec

_PROG = "quadcos.export"


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status (2 with one line on stderr for bad input)."""
    parser = argparse.ArgumentParser(prog=f"python -m {_PROG}", description=__doc__)
    parser.add_argument("--policy", required=True, help="run or policy directory")
    parser.add_argument("--out", required=True, help="the .npz or .onnx to write")
    parser.add_argument(
        "--robot", help="check that the policy drives this robot (its env config names it)"
    )
    try:
        args = cli.raising(parser).parse_args(argv)
        out = export_policy(PolicySpec.parse(args.policy), args.out, args.robot)
    except (FileNotFoundError, ValueError, OSError, ImportError) as error:
        cli.print_error(_PROG, error)
        return cli.EXIT_USAGE
    print(f"{args.policy} -> {out}")
    return cli.EXIT_OK


if __name__ == "__main__":
    cli.exit_process(main())
