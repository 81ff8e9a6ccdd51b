"""The drive's turn cap (`commands.turn_max`) on a command policy and its gait in C MuJoCo: random
commands at fixed frictions, with the cap and without (0), the drive's loops as the policy trained.

    MENAGERIE_ROOT=DIR python experiments/commands/turn_cap.py \
        --policy=experiments/policies/anybotics_anymal_c_command --caps 0 0.4 \
        --out=experiments/commands/anybotics_anymal_c_turn_cap.json

Each row: `--episodes` episodes of 20 s (`quadcos.sim2sim`'s engine, the training solver
iterations, every geom's sliding friction set to one value), for the policy and for its gait
(`gait:DIR`, the zero action): survival and `speed_tracking_rms` / `yaw_rate_tracking_rms`.
`open_loop`: the gait's mean yaw rate turning on the spot (v* 0, ω* `--turns`) with the drive's
loops open and no cap, over the last 8 s of 12 (two episodes), at each friction.
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from quadcos.deploy import engines, host_robot

KEYS = ("success_rate", "speed_tracking_rms", "yaw_rate_tracking_rms")


def measure(policy: str, friction: float, cap: float, episodes: int) -> dict:
    """One row: `policy` at `friction` with the drive's turn capped at `cap` rad/s (0: none)."""
    result = engines.evaluate(
        policy,
        "flat",
        engine="mujoco",
        episodes=episodes,
        physics="training",
        commands="random",
        friction=friction,
        env_overrides={"commands.turn_max": cap},
    )
    summary = result.summary
    return {"policy": policy, "friction": friction, "turn_max": cap} | {k: summary[k] for k in KEYS}


def yaw_rate(policy: str, friction: float, turn: float, seconds: float = 12.0) -> float:
    """rad/s: `policy`'s mean yaw rate over the last 2/3 of two episodes asked to turn on the spot
    at `turn` rad/s, the drive's loops open and its turn uncapped."""
    open_loop = {"commands.heading_gain": 0.0, "commands.speed_gain_rate": 0.0}
    pilot = host_robot.Pilot.load(policy, open_loop | {"commands.turn_max": 0.0})
    robot = host_robot.HostRobot(
        "flat", pilot.config, physics="training", commands=f"0,{turn}@{seconds}", friction=friction
    )
    act, steps, rates = pilot.actor(), round(seconds / robot.dt), []
    for seed in range(2):
        obs, yaws = robot.reset(seed), []
        for _ in range(steps):
            result = robot.step(act(obs))
            obs = result.obs
            yaws.append(result.body.yaw)
        yaws = np.unwrap(yaws)[steps // 3 :]
        rates.append((yaws[-1] - yaws[0]) / ((len(yaws) - 1) * robot.dt))
    return float(np.mean(rates))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--policy", required=True)
    parser.add_argument("--frictions", type=float, nargs="+", default=[0.4, 0.8, 1.5])
    parser.add_argument("--caps", type=float, nargs="+", default=[0.0, 0.4])
    parser.add_argument("--episodes", type=int, default=16)
    parser.add_argument("--turns", type=float, nargs="+", default=[0.4, 0.8])
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    rows = []
    for policy in (args.policy, f"gait:{args.policy}"):
        for friction in args.frictions:
            for cap in args.caps:
                rows.append(measure(policy, friction, cap, args.episodes))
                print(json.dumps(rows[-1]), flush=True)
    gait = f"gait:{args.policy}"
    open_loop = [
        {"friction": friction, "yaw_rate_command": turn, "yaw_rate": yaw_rate(gait, friction, turn)}
        for friction in args.frictions
        for turn in args.turns
    ]
    print(json.dumps(open_loop), flush=True)
    record = {
        "command": "python " + " ".join(sys.argv),
        "episodes": args.episodes,
        "rows": rows,
        "open_loop": open_loop,
    }
    Path(args.out).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
