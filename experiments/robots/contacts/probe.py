"""Contacts and constraint rows a policy's robot makes on heightfield courses, in C MuJoCo.

    MENAGERIE_ROOT=DIR python experiments/robots/contacts/probe.py --policy=POLICY \
        --terrain=TERRAIN [--terrain=...] --episodes=4 --seconds=20 [--hfield_contacts=N] --out=OUT.json

Runs the policy (deterministic) in `quadcos.deploy.host_robot.HostRobot` with the training solver
settings (`physics="training"`: the iterations and step MJX runs) and records, over every physics
step, the largest number of contacts (`ncon`) and constraint rows (`nefc`), beside the rows MJX-Warp
is given per world (`quadcos.env.backends.warp_sizes`: `njmax`, with the robot preset's heightfield
contacts or `--hfield_contacts`). nefc > njmax means MJX-Warp would drop constraints there ("nefc
overflow").
"""

import argparse
import json
from pathlib import Path

import mujoco

from quadcos.deploy import host_robot
from quadcos.env import backends


def probe(
    policy: str, terrain: str, episodes: int, seconds: float, hfield_contacts: int = 0
) -> dict:
    pilot = host_robot.load_pilot(policy)
    host = host_robot.HostRobot(terrain, pilot.config, physics="training")
    act = pilot.actor()
    sizes = host.config.copy_and_resolve_references()  # the resolved env config
    if hfield_contacts:
        sizes.warp.hfield_contacts = hfield_contacts
    rows = backends.warp_sizes(sizes, host.model)["njmax"]
    ncon_max, nefc_max, over, steps = 0, 0, 0, 0
    step = mujoco.mj_step

    def counting_step(model, data):  # each physics step of HostRobot.step
        nonlocal ncon_max, nefc_max, over, steps
        step(model, data)
        ncon_max, nefc_max = max(ncon_max, data.ncon), max(nefc_max, data.nefc)
        over += data.nefc > rows
        steps += 1

    mujoco.mj_step = counting_step
    try:
        for seed in range(episodes):
            host_robot.run_episode(host, act, seed, round(seconds / host.dt))
    finally:
        mujoco.mj_step = step
    return {
        "policy": policy,
        "terrain": terrain,
        "robot": pilot.config.robot,
        "episodes": episodes,
        "physics_steps": steps,
        "hfield_contacts": int(sizes.warp.hfield_contacts),
        "njmax": rows,
        "max_ncon": int(ncon_max),
        "max_nefc": int(nefc_max),
        "steps_over_njmax": int(over),
        "share_over_njmax": float(over / max(steps, 1)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--policy", required=True)
    parser.add_argument("--terrain", action="append", required=True)
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument(
        "--hfield_contacts", type=int, default=0, help="rows for this many contacts (0: preset's)"
    )
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    results = []
    for terrain in args.terrain:
        result = probe(args.policy, terrain, args.episodes, args.seconds, args.hfield_contacts)
        print(json.dumps(result), flush=True)
        results.append(result)
    Path(args.out).write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
