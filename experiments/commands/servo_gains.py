"""How the position servos' stiffness decides whether constant rhythms walk a robot, in C MuJoCo:
the same random rhythms (A_k, A_h, T, φ1, φ3 drawn uniformly) under each servo gain, at each
friction, nothing randomised; per gain, how many rhythms survive every friction and walk.

    MENAGERIE_ROOT=DIR python experiments/commands/servo_gains.py --rhythms=240 \
        --out=experiments/commands/anybotics_anymal_c_servo_gains.json

A rhythm walks where it survives `--seconds` at every friction at ≥ `--walk_speed` m/s; its
attitude is the largest |pitch| or |roll| after the first 2 s. Gains: `kp:kd` (N m/rad, N m s/rad;
`mjcf` the MJCF's own), set through `env.servo_kp` / `env.servo_kd`. `--refine=G` then climbs
from each gain's two fastest survivors for G generations of 6 mutants (each value moved by
N(0, 6 % of its range)), keeping the best of: slowest speed − falls − 2 × attitude above
`--refine_level` rad: how fast constant rhythms can walk the robot under that gain.

`--rhythm A_k,A_h,T,φ1,φ3 ...` runs the rhythms given instead of random ones (e.g. a gait an MJX
search kept: does it walk C MuJoCo?); `--period_min` lowers the env's period floor for them.
"""

import argparse
import json
import math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from quadcos.deploy import host_robot

SETTLE_S = 2.0  # s: the attitude is taken after the drop from the spawn height
LOW = np.array([0.1, -0.5, 0.25, -math.pi, -math.pi])  # A_k rad, A_h rad, T s, φ1, φ3 rad
HIGH = np.array([0.5, 0.5, 0.8, math.pi, math.pi])


def walk(args: argparse.Namespace, gain: str, rhythm: list[float], friction: float) -> dict:
    """One episode of the constant rhythm at one friction under one servo gain."""
    overrides = {
        "robot": args.robot,
        "solver_iterations": args.iterations,
        "ls_iterations": args.iterations,
    }
    if args.period_min is not None:
        overrides["period_min"] = args.period_min
    if gain != "mjcf":
        kp, kd = (float(v) for v in gain.split(":"))
        overrides |= {"servo_kp": kp, "servo_kd": kd}
    pilot = host_robot.Pilot.load("fixed:" + ",".join(f"{v:.6g}" for v in rhythm), overrides)
    robot = host_robot.HostRobot("flat", pilot.config, physics="training")
    robot.model.geom_friction[:, 0] = friction
    act, obs = pilot.actor(), robot.reset(0)
    x0, attitude, steps = float(robot.data.qpos[0]), 0.0, round(args.seconds / robot.dt)
    for step in range(1, steps + 1):
        result = robot.step(act(obs))
        obs = result.obs
        if step * robot.dt > SETTLE_S:
            attitude = max(attitude, abs(result.body.pitch), abs(result.body.roll))
        if result.fell:
            break
    seconds = step * robot.dt
    return {
        "fell": bool(result.fell),
        "speed": (float(robot.data.qpos[0]) - x0) / seconds,
        "attitude": attitude,
    }


def under_gain(args: argparse.Namespace, gain: str, rhythm: list[float]) -> dict:
    """The rhythm at every friction: falls, slowest speed, largest attitude."""
    episodes = [walk(args, gain, rhythm, friction) for friction in args.frictions]
    return {
        "falls": sum(e["fell"] for e in episodes),
        "min_speed": min(e["speed"] for e in episodes),
        "attitude": max(e["attitude"] for e in episodes),
        "speeds": [round(e["speed"], 3) for e in episodes],  # at each friction
    }


def rhythm_row(args: argparse.Namespace, rhythm: list[float]) -> dict:
    """The rhythm under every gain: survived every friction, slowest speed, largest attitude."""
    row = {"rhythm": [round(v, 4) for v in rhythm]}
    for gain in args.gains:
        result = under_gain(args, gain, rhythm)
        row[gain] = {"survived": result.pop("falls") == 0} | result
    return row


def refine(args, pool, gain: str, start: list[float], rng: np.random.Generator) -> dict:
    """`args.refine` generations of hill climbing from `start` under `gain` (module docstring)."""

    def score(result: dict) -> float:
        over = max(0.0, result["attitude"] - args.refine_level)
        return result["min_speed"] - result["falls"] - 2.0 * over

    best = {"rhythm": start} | under_gain(args, gain, start)
    for _ in range(args.refine):
        kids = [
            list(np.clip(rng.normal(best["rhythm"], 0.06 * (HIGH - LOW)), LOW, HIGH))
            for _ in range(6)
        ]
        results = pool.map(under_gain, [args] * len(kids), [gain] * len(kids), kids)
        for kid, result in zip(kids, results, strict=True):
            if score(result) > score(best):
                best = {"rhythm": kid} | result
    return {
        "start": [round(v, 4) for v in start],
        "rhythm": [round(v, 4) for v in best["rhythm"]],
    } | {key: round(best[key], 3) for key in ("falls", "min_speed", "attitude")}


def summary(args: argparse.Namespace, rows: list[dict]) -> dict:
    """Per gain: rhythms surviving, walking, walking level; the three fastest survivors."""
    per_gain = {}
    for gain in args.gains:
        survived = [r for r in rows if r[gain]["survived"]]
        walking = [r for r in survived if r[gain]["min_speed"] >= args.walk_speed]
        level = [r for r in walking if r[gain]["attitude"] <= args.level]
        fastest = sorted(survived, key=lambda r: -r[gain]["min_speed"])[:3]
        per_gain[gain] = {
            "survived": len(survived),
            "walking": len(walking),
            "walking_level": len(level),
            "fastest": [
                {"rhythm": r["rhythm"]}
                | {k: round(v, 3) for k, v in r[gain].items() if k not in ("survived", "speeds")}
                for r in fastest
            ],
        }
    return per_gain


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--robot", default="menagerie:anybotics_anymal_c")
    parser.add_argument("--gains", nargs="+", default=["mjcf", "300:4", "500:6"])
    parser.add_argument("--frictions", type=float, nargs="+", default=[0.4, 0.8, 1.5])
    parser.add_argument("--rhythms", type=int, default=240)
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--iterations", type=int, default=20, help="solver and line search")
    parser.add_argument("--walk_speed", type=float, default=0.1, help="m/s at every friction")
    parser.add_argument("--level", type=float, default=0.15, help="rad: largest |pitch|, |roll|")
    parser.add_argument("--refine", type=int, default=0, help="generations of hill climbing")
    parser.add_argument("--refine_level", type=float, default=0.25, help="rad, see --refine")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--rhythm", nargs="+", help="A_k,A_h,T,phi1,phi3: these, not random ones")
    parser.add_argument("--period_min", type=float, help="s: the env's period floor")
    parser.add_argument("--out")
    args = parser.parse_args()
    for gain in args.gains:
        if gain != "mjcf" and len(gain.split(":")) != 2:
            parser.error(f"bad gain {gain!r}: kp:kd (N m/rad, N m s/rad) or mjcf")
    rng = np.random.default_rng(args.seed)
    rhythms = [list(rng.uniform(LOW, HIGH)) for _ in range(args.rhythms)]
    if args.rhythm:
        rhythms = [[float(v) for v in spec.split(",")] for spec in args.rhythm]
        args.rhythms = len(rhythms)
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(rhythm_row, [args] * len(rhythms), rhythms))
        gains = summary(args, rows)
        for gain, row in gains.items():
            starts = [fast["rhythm"] for fast in row["fastest"][:2]] if args.refine else []
            row["refined"] = [refine(args, pool, gain, start, rng) for start in starts]
    given = f" --rhythm {' '.join(args.rhythm)}" if args.rhythm else f" --rhythms={args.rhythms}"
    record = {
        "command": "python experiments/commands/servo_gains.py"
        + f"{given} --refine={args.refine} --seed={args.seed} --seconds={args.seconds:g}"
        + (f" --period_min={args.period_min:g}" if args.period_min is not None else ""),
        "setup": {
            "robot": args.robot,
            "frictions": args.frictions,
            "seconds": args.seconds,
            "solver_iterations": args.iterations,
            "walk_speed": args.walk_speed,
            "level_rad": args.level,
            "rhythm_low": LOW.round(4).tolist(),
            "rhythm_high": HIGH.round(4).tolist(),
            "rhythms": args.rhythms,
            "period_min": args.period_min,
            "refine_level_rad": args.refine_level,
            "seed": args.seed,
        },
        "gains": gains,
        **({"rows": rows} if args.rhythm else {}),  # the given rhythms, each under every gain
    }
    for gain, row in record["gains"].items():
        print(
            f"{gain}: {row['survived']} of {args.rhythms} rhythms survive every friction,"
            f" {row['walking']} walk ≥ {args.walk_speed} m/s, {row['walking_level']} of those"
            f" within {args.level} rad; refined: "
            + ", ".join(
                f"{r['min_speed']:.2f} m/s at {r['attitude']:.2f} rad" for r in row["refined"]
            )
        )
    if args.out:
        Path(args.out).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
