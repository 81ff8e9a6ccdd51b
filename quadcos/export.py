"""`python -m quadcos.export --policy DIR --out policy.npz` (or `policy.onnx`): a trained policy as
a JAX-free file, its format from the extension (.npz for NumPy, .onnx for ONNX Runtime).

The formats and the library behind them: `quadcos.deploy.export`.
"""

import argparse
import sys
from collections.abc import Sequence

from quadcos.deploy.export import export_policy


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status (2 with one line on stderr for bad input)."""
    parser = argparse.ArgumentParser(prog="python -m quadcos.export", description=__doc__)
    parser.add_argument("--policy", required=True, help="run or policy directory")
    parser.add_argument("--out", required=True, help="the .npz or .onnx to write")
    parser.add_argument(
        "--robot", help="check that the policy drives this robot (its env config names it)"
    )
    args = parser.parse_args(argv)
    try:
        out = export_policy(args.policy, args.out, args.robot)
    except (FileNotFoundError, ValueError, OSError, ImportError) as error:
        print(f"quadcos.export: error: {error}", file=sys.stderr)
        return 2
    print(f"{args.policy} -> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
