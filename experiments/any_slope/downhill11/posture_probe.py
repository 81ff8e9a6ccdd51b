"""Do hip offsets let a constant rhythm walk down 11°? `FIXED_TROT` with constant front and hind
hip offsets (`env.posture_bound=0.6`, each offset 0, 0.15, ..., 0.6 rad) on the course of this
directory's README (`sections:0@1,-11@4,0@2`: crest at x = 3 m, foot at x ≈ 6.9 m), 4 robots per
pair, 20 s, CPU (JAX physics). Prints falls and the torso's x at the fall or at the end.

    python experiments/any_slope/downhill11/posture_probe.py > experiments/any_slope/downhill11/posture_probe.txt
"""

import itertools
import time

import jax
import jax.numpy as jnp
import numpy as np

from quadcos import env as env_lib
from quadcos.equations import oscillator

COURSE = "sections:0@1,-11@4,0@2"
BOUND = 0.6  # rad
LEVELS = (0.0, 0.25, 0.5, 0.75, 1.0)  # posture actions: offsets LEVEL × BOUND
ROBOTS = 4
STEPS = 400  # 20 s

env = env_lib.make_env(COURSE, posture_bound=BOUND)
pairs = list(itertools.product(LEVELS, LEVELS))
trot = env.action_for(oscillator.FIXED_TROT)
actions = jnp.stack([trot.at[5].set(f).at[6].set(h) for f, h in pairs for _ in range(ROBOTS)])
state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), actions.shape[0]))
step = jax.jit(jax.vmap(env.step))
fell = np.zeros(actions.shape[0], bool)
x_fall = np.full(actions.shape[0], np.nan)
start = time.time()
for _ in range(STEPS):
    state = step(state, actions)
    done = np.asarray(state.done) > 0
    x = np.asarray(state.pipeline_state.qpos[:, 0])
    x_fall[done & ~fell] = x[done & ~fell]
    fell |= done
x_end = np.where(fell, x_fall, np.asarray(state.pipeline_state.qpos[:, 0]))
print(f"{COURSE}, FIXED_TROT + hip offsets, {ROBOTS} robots x {STEPS * env.dt:g} s, {time.time() - start:.0f} s")
for i, (front, hind) in enumerate(pairs):
    rows = slice(i * ROBOTS, (i + 1) * ROBOTS)
    print(
        f"front {front * BOUND:+.2f} rad, hind {hind * BOUND:+.2f} rad: falls {fell[rows].sum()}/{ROBOTS},"
        f" x at the fall or the end {np.round(x_end[rows], 1).tolist()}"
    )
