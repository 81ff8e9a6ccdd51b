"""MuJoCo's solver iterations a physics step of robots standing against robots walking the fixed
trot, in C MuJoCo (CPU), from the bench's reset states (flat, the paper robot).

    python benchmarks/h200/gait/solver_iterations.py [ROBOTS] [ENV_STEPS]

Standing: the reset states stepped with their reset controls (the physics section). Walking: the
env stepped under the zero action (the gait section's motion), and after each env step one C
MuJoCo step of each robot's state. Prints, per env step, the mean over robots and the slowest
robot's iterations (a batch's solver runs until its slowest world is done).
"""

import sys

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

from quadcos.benchmarking import physics
from quadcos.benchmarking.settings import make_bench_env


def main(robots: int = 32, env_steps: int = 30) -> None:
    env = make_bench_env("flat", "gpu", "jax")
    model = env.mj_model
    states = physics.make_batch_reset(env)(robots)

    def host_data(batch: mjx.Data, index: int) -> mujoco.MjData:
        data = mujoco.MjData(model)
        mjx.get_data_into(data, model, jax.tree.map(lambda x: x[index], batch))
        return data

    standing = [host_data(states.pipeline_state, i) for i in range(robots)]
    standing_iterations = np.zeros((env_steps, env.substeps, robots))
    for step in range(env_steps):
        for substep in range(env.substeps):
            for i, data in enumerate(standing):
                mujoco.mj_step(model, data)
                standing_iterations[step, substep, i] = data.solver_niter[0]
    env_step = jax.jit(jax.vmap(env.step))
    zero = jnp.zeros((robots, env.action_size))
    walking_iterations = np.zeros((env_steps, robots))
    for step in range(env_steps):
        states = env_step(states, zero)
        for i in range(robots):
            data = host_data(states.pipeline_state, i)
            mujoco.mj_step(model, data)
            walking_iterations[step, i] = data.solver_niter[0]
    print(f"{robots} robots, flat, solver iterations a physics step (cap {model.opt.iterations})")
    print("env step | standing: mean | slowest | walking: mean | slowest")
    for step in range(env_steps):
        print(
            f"{step + 1} | {standing_iterations[step].mean():.2f} |"
            f" {standing_iterations[step].max(axis=1).max():.0f} |"
            f" {walking_iterations[step].mean():.2f} | {walking_iterations[step].max():.0f}"
        )
    print(
        f"all | {standing_iterations.mean():.2f} | {standing_iterations.max(axis=2).mean():.2f} |"
        f" {walking_iterations.mean():.2f} | {walking_iterations.max(axis=1).mean():.2f}"
    )


if __name__ == "__main__":
    main(*(int(arg) for arg in sys.argv[1:]))
