"""Why ANYmal C does not walk: how high it stands under each physics, and how far constant gaits go.

    MENAGERIE_ROOT=/work/shared/menagerie python experiments/robots/physics/anymal_probe.py \
        --out experiments/robots/physics/anymal_probe.json

- hold: the home pose held for 3 s from 2 mm above the ground, at the preset's step (2.5 ms) and
  4 / 8 solver iterations, in C MuJoCo and MJX-JAX, elliptic and pyramidal cones, with the MJCF's
  joint friction loss and without it: the base height at the end as a fraction of the kinematic
  standing height.
- gaits: `--gaits` constant actions drawn uniformly from [-1, 1]^5 (§3.3's ranges around the
  fixed trot), each one 10-s episode in C MuJoCo with the converged solver
  (`quadcos.sim2sim`'s reference physics): whether it stood, and how far it went.
"""

import argparse
import json
import pathlib

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

from quadcos import robot as robot_lib
from quadcos import terrain
from quadcos.deploy import host_robot
from quadcos.env.layout import Layout

ROBOT = "menagerie:anybotics_anymal_c"
MJCF_FRICTIONLOSS = 0.1  # N m, anymal_c.xml's joint default (the preset replaces it with 0)
HOLD_SECONDS = 3.0
GAIT_SECONDS = 10.0


def hold(engine: str, cone: str, frictionloss: bool) -> float:
    """Base height / standing height after HOLD_SECONDS holding the home pose."""
    robot = robot_lib.load(ROBOT)
    spec = robot.spec()
    terrain.get("flat").attach(spec)
    spec.option.timestep, spec.option.iterations, spec.option.ls_iterations = 0.0025, 4, 8
    spec.option.cone = getattr(mujoco.mjtCone, f"mjCONE_{cone.upper()}")
    for joint in spec.joints:
        if joint.type == mujoco.mjtJoint.mjJNT_HINGE:
            joint.frictionloss = MJCF_FRICTIONLOSS if frictionloss else 0.0
    model = spec.compile()
    data = mujoco.MjData(model)
    layout = Layout.of(robot.description, model, xp=np)
    data.qpos[layout.joint_qpos] = layout.home
    data.qpos[layout.position[2]] = layout.standing_height + 0.002
    steps = round(HOLD_SECONDS / model.opt.timestep)
    if engine == "mujoco":
        for _ in range(steps):
            data.ctrl[:] = layout.controls(layout.home, data)
            mujoco.mj_step(model, data)
        height = data.qpos[layout.position[2]]
    else:
        device_model = mjx.put_model(model, impl="jax")
        jax_layout = Layout.of(robot.description, model, xp=jnp)
        home = jnp.asarray(layout.home)

        def step(state, _):
            state = state.replace(ctrl=jax_layout.controls(home, state))
            return mjx.step(device_model, state), None

        run = jax.jit(lambda state: jax.lax.scan(step, state, None, length=steps)[0])
        height = run(mjx.put_data(model, data, impl="jax")).qpos[layout.position[2]]
    return float(height) / layout.standing_height


def gaits(count: int, seed: int) -> list[dict]:
    config = host_robot.env_config({"robot": ROBOT, "action_filter_tau": 0.0})
    host = host_robot.HostRobot("flat", config)
    rng = np.random.default_rng(seed)
    found = []
    for index in range(count):
        action = rng.uniform(-1.0, 1.0, host.action_size)
        host.reset((seed, index))
        fell = False
        for _ in range(round(GAIT_SECONDS / host.dt)):
            if host.step(action).fell:
                fell = True
                break
        found.append(
            {
                "parameters": [float(value) for value in host.rhythm_parameters()],
                "stood": not fell,
                "distance_m": float(host.data.qpos[host.layout.position[0]]),
            }
        )
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gaits", type=int, default=300)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=pathlib.Path, required=True)
    args = parser.parse_args()
    holds = []
    for engine in ("mujoco", "mjx-jax"):
        for cone in ("elliptic", "pyramidal"):
            for frictionloss in (True, False):
                row = {"engine": engine, "cone": cone, "frictionloss": frictionloss}
                row["height_fraction"] = round(hold(engine, cone, frictionloss), 3)
                print(json.dumps(row), flush=True)
                holds.append(row)
    found = gaits(args.gaits, args.seed)
    standing = [gait for gait in found if gait["stood"]]
    summary = {
        "gaits": len(found),
        "stood_10s": len(standing),
        "max_forward_m_of_those": max((gait["distance_m"] for gait in standing), default=None),
    }
    print(json.dumps(summary), flush=True)
    result = {"hold": holds, "gait_summary": summary, "gaits": found}
    args.out.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
