"""A command policy's survival at fixed frictions in C MuJoCo: every geom's sliding friction set
to one value (as the randomisation draws it), nothing else randomised, random commands or one
schedule (`--commands`, `quadcos.sim2sim`'s spec).

    MENAGERIE_ROOT=DIR python experiments/commands/friction_probe.py --policy=RUN/policy_best \
        --frictions 0 1.0 1.5 --episodes=8 --out=experiments/commands/anymal_friction.json
    ... --frictions 1.5 --commands 0,0@10 0.2,0@10 0.4,0@10 --out=...   # a row per schedule

A friction of 0 keeps the MJCF's own. Physics (`--physics`, `quadcos.sim2sim`'s): the solver
iterations the policy trained with ("training", the default), the MJCF's own ("reference":
converged) or "N/M". Each episode: `--seconds` of control steps from
`HostRobot.reset(seed)`, ended by a fall.
"""

import argparse
import json
from pathlib import Path

import numpy as np

from quadcos.deploy import host_robot

FIRST_FALLS = 10  # falls a row records (its survival counts them all)


def survival(
    pilot: host_robot.Pilot,
    friction: float,
    commands: str,
    episodes: int,
    seconds: float,
    physics: str = "training",
) -> dict:
    """The share of `episodes` that did not fall, the mean seconds walked, and the first
    `FIRST_FALLS` falls' episode, second and command (v*, ω*) then, at `friction`."""
    robot = host_robot.HostRobot(
        "flat", pilot.config, physics=physics, commands=commands, friction=friction
    )
    feet = robot.layout.foot_geoms
    act, steps, walked, falls = pilot.actor(), round(seconds / robot.dt), [], []
    for seed in range(episodes):
        obs, step = robot.reset(seed), 0
        while step < steps:
            velocity = robot.commands.velocity if robot.commands else ()  # (v*, ω*) of this step
            result = robot.step(act(obs))
            obs, step = result.obs, step + 1
            if result.fell:
                if len(falls) < FIRST_FALLS:
                    command = [round(float(c), 3) for c in velocity]
                    second = round(step * robot.dt, 2)
                    falls.append({"episode": seed, "second": second, "command": command})
                break
        walked.append(step * robot.dt)
    return {
        "friction": float(robot.model.geom_friction[feet[0], 0]),
        "commands": commands,
        "episodes": episodes,
        "survival": float(np.mean([w >= steps * robot.dt - 1e-9 for w in walked])),
        "mean_seconds": float(np.mean(walked)),
        "first_falls": falls,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--policy", required=True)
    parser.add_argument("--frictions", type=float, nargs="+", default=[0.0, 1.0, 1.5])
    parser.add_argument("--commands", nargs="+", default=["random"])
    parser.add_argument("--episodes", type=int, default=8)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--physics", default="training")
    parser.add_argument("--out")
    args = parser.parse_args()
    pilot = host_robot.Pilot.load(args.policy)
    rows = [
        survival(pilot, friction, commands, args.episodes, args.seconds, args.physics)
        for commands in args.commands
        for friction in args.frictions
    ]
    for row in rows:
        print(
            f"friction {row['friction']:.2f}, {row['commands']}: survival"
            f" {row['survival']:.3f} of {row['episodes']}, {row['mean_seconds']:.1f} s walked"
            " on average"
        )
        for fall in row["first_falls"]:
            v, w = fall["command"] or (float("nan"),) * 2
            when = f"episode {fall['episode']} at {fall['second']} s"
            print(f"  fell: {when}, v* {v:.2f}, ω* {w:+.2f}")
    if args.out:
        record = {
            "policy": args.policy,
            "physics": args.physics,
            "seconds": args.seconds,
            "rows": rows,
        }
        Path(args.out).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
