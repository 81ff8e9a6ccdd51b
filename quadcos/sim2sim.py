"""Sim-to-sim: the env's controller path in C MuJoCo (`mujoco.mj_step` on an `MjData`), no JAX in
the loop.

    python -m quadcos.sim2sim --policy=experiments/policies/slope5 --terrain=s4 --episodes=64 \\
        --seconds=30 --out=s4_mujoco.json
    python -m quadcos.sim2sim --policy=fixed:trot --terrain=flat --out=trot_mujoco.json
    python -m quadcos.export --policy=experiments/policies/flat --out=flat.onnx
    python -m quadcos.sim2sim --policy=flat.onnx --obs_noise=0.01 --latency_ms=20 --out=onnx.json

`--policy` takes a run or policy directory, `gait:DIRECTORY` (its zero action), an exported .npz,
an exported .onnx (run with ONNX Runtime) or `fixed:...`. `--obs_noise` adds N(0, std²) to each observation value the policy
sees; `--latency_ms` delays each action by that many ms, rounded to whole physics steps (below a
control step: the previous action for the first round(latency / physics_dt) substeps of each
control step, as the MJX env's randomised latency); `--friction` sets every geom's sliding
friction (MuJoCo takes the larger of two at a contact), as the env's randomisation draws one.
All three are recorded in the setup.
`--physics=reference` (default) solves contacts with the MJCF's own solver iterations (converged:
the physics a policy must transfer to); `--physics=training` with the iterations it trained with;
`--physics=N/M` with N solver and M line-search iterations. `--commands=SPEC` (a policy trained
with velocity commands): `random` (its training distribution, NumPy's draws) or a schedule
`v,w@s;...`; the JSON then reports `speed_tracking_rms` and `yaw_rate_tracking_rms`.
`--out` is an evaluation JSON in `quadcos.evaluate`'s format (aggregates, "setup" with `"engine": "mujoco"`,
per-episode values), so the two compare key by key; it is
`python -m quadcos.evaluate --engine=mujoco` with the deployment faults and the solver choice.
Env options: `--env.KEY=VALUE`, as in `quadcos.evaluate`. The library: `quadcos.deploy.engines`
(`evaluate(..., engine="mujoco")`); the robot loop: `quadcos.deploy.host_robot`.
"""

import argparse
import logging
import math
import pathlib
import sys
from collections.abc import Sequence

from quadcos import evaluation
from quadcos._util import cli
from quadcos.deploy import engines

_PROG = "quadcos.sim2sim"


def _parser() -> argparse.ArgumentParser:
    parser = engines.host_parser(f"python -m {_PROG}", __doc__)
    parser.add_argument("--episodes", type=int, default=64, help="episodes, one after another")
    parser.add_argument("--seconds", type=float, default=20.0, help="time limit of an episode, s")
    parser.add_argument(
        "--obs_noise", type=float, default=0.0, help="std of noise on each observation value"
    )
    parser.add_argument(
        "--latency_ms", type=float, default=0.0, help="control latency, ms (whole physics steps)"
    )
    parser.add_argument(
        "--friction", type=float, default=0.0,
        help="every geom's sliding friction, as the env's randomisation sets it (0: the MJCF's)",
    )
    parser.add_argument("--out", help="evaluation JSON to write (none: the summary line only)")
    parser.add_argument("--no_progress", action="store_true", help="no progress on stderr")
    return parser


def _print_progress(done: int, total: int) -> None:
    print(f"sim2sim: episode {done}/{total}", file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status (2, one line on stderr, for bad input)."""
    with cli.logging_to_stderr(_PROG, logging.WARNING):
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    try:
        args, overrides = engines.parse_command(_parser(), argv)
        if args.policy is None:
            raise cli.UsageError("--policy is required")
        out = None if args.out is None else pathlib.Path(args.out)
        if out is not None and (out.suffix != ".json" or not out.absolute().parent.is_dir()):
            raise ValueError(f"--out must be a .json file in an existing directory; got {out}")
        checked = ("--obs_noise", args.obs_noise), ("--latency_ms", args.latency_ms)
        for flag, value in (*checked, ("--friction", args.friction)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{flag} must be >= 0 and finite; got {value}")
        result = engines.evaluate(
            args.policy,
            args.terrain,
            engine="mujoco",
            episodes=args.episodes,
            seconds=args.seconds,
            seed=args.seed,
            env_overrides=overrides,
            obs_noise=args.obs_noise,
            latency_s=args.latency_ms / 1000.0,
            physics=args.physics,
            commands=args.commands,
            friction=args.friction,
            progress=None if args.no_progress else _print_progress,
        )
    except (ValueError, FileNotFoundError) as error:
        cli.print_error(_PROG, error)
        return cli.EXIT_USAGE
    if out is not None:
        evaluation.write_json(out, result.to_json())
    print(engines.summary_line(result.summary, "mujoco", out))
    return cli.EXIT_OK


if __name__ == "__main__":
    cli.exit_process(main())
