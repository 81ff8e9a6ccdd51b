"""Fixed oscillator parameters on flat ground: standing still vs oscillator.FIXED_TROT.

    python experiments/fixed_trot/measure.py experiments/fixed_trot/result.json

8 robots each, 25 s (500 control steps at the default 20 Hz): falls, speed, |yaw|, and the mean
per-step value of every reward term of Eq. 13.
"""

import json
import pathlib
import sys

import jax
import jax.numpy as jnp
import numpy as np

import quadcos
from quadcos.equations import oscillator

ROBOTS, STEPS = 8, 500
GAITS = {
    "standing": oscillator.RhythmParameters(0.0, 0.0, 1.0, 0.0, 0.0),
    "fixed_trot": oscillator.FIXED_TROT,
}


def main() -> None:
    env = quadcos.make_env("flat")
    results = {}
    for name, params in GAITS.items():
        action = jnp.broadcast_to(env.action_for(params), (ROBOTS, 5))
        state = jax.vmap(env.reset)(jax.random.split(jax.random.PRNGKey(0), ROBOTS))

        def body(state, _, action=action):
            state = jax.vmap(env.step)(state, action)
            return state, (state.done, state.obs[:, 4], state.reward, state.metrics)

        final, (done, yaw, reward, metrics) = jax.jit(
            lambda s, body=body: jax.lax.scan(body, s, None, length=STEPS)
        )(state)
        results[name] = {
            "params": [float(p) for p in params],
            "fall_rate": float(np.asarray(done).any(0).mean()),
            "forward_speed_m_per_s": float(np.asarray(final.pipeline_state.qpos[:, 0]).mean() / (STEPS * env.dt)),
            "max_abs_yaw_rad": float(np.abs(np.asarray(yaw)).max()),
            "reward_per_step": float(np.asarray(reward).mean()),
            "terms_per_step": {k: float(np.asarray(v).mean()) for k, v in metrics.items() if k.startswith("reward/")},
        }
    text = json.dumps({"robots": ROBOTS, "seconds": STEPS * env.dt, "results": results}, indent=2)
    pathlib.Path(sys.argv[1]).write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
