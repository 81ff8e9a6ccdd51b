"""How much exploration noise the fixed trot survives, with and without the command filter.

    python experiments/noise_tolerance/measure.py experiments/noise_tolerance/result.json

48 robots per cell on flat, 10 s (200 control steps at 20 Hz): the action is the fixed trot
(oscillator.FIXED_TROT) plus fresh Gaussian noise of the given std at every control step (in the
action's [-1, 1] units, the same place SAC's exploration noise enters), for several time
constants of the env's low-pass command filter (`action_filter_tau`, 0 = off).
"""

import json
import pathlib
import sys

import jax
import jax.numpy as jnp
import numpy as np

import quadcos
from quadcos.equations import oscillator

ROBOTS, STEPS = 48, 200
TAUS = (0.0, 0.1, 0.25, 0.5)  # s
NOISE_STDS = (0.0, 0.03, 0.06, 0.12)


def measure(tau: float) -> list[dict]:
    env = quadcos.make_env("flat", action_filter_tau=tau)
    trot = env.action_for(oscillator.FIXED_TROT)

    @jax.jit
    def rollout(noise_std):
        state = jax.vmap(env.reset)(jax.random.split(jax.random.PRNGKey(0), ROBOTS))

        def body(carry, key):
            state, alive = carry
            noise = noise_std * jax.random.normal(key, (ROBOTS, env.action_size))
            state = jax.vmap(env.step)(state, jnp.clip(trot + noise, -1, 1))
            reward = jnp.where(alive, state.reward, 0.0)
            alive = alive & (state.done == 0)
            return (state, alive), (reward, jnp.abs(state.obs[:, 4]))

        keys = jax.random.split(jax.random.PRNGKey(1), STEPS)
        (final, alive), (reward, abs_yaw) = jax.lax.scan(
            body, (state, jnp.ones(ROBOTS, bool)), keys
        )
        speed = final.pipeline_state.qpos[:, 0] / (STEPS * env.dt)
        return reward.sum(0), alive, speed, abs_yaw.max(0)

    rows = []
    for noise_std in NOISE_STDS:
        episode_reward, alive, speed, max_abs_yaw = (np.asarray(x) for x in rollout(noise_std))
        rows.append({
            "action_filter_tau_s": tau,
            "noise_std": noise_std,
            "fall_rate": float(1 - alive.mean()),
            "mean_episode_reward": float(episode_reward.mean()),
            "mean_forward_speed_m_per_s": float(speed.mean()),
            "median_max_abs_yaw_rad": float(np.median(max_abs_yaw)),
        })
        print(json.dumps(rows[-1]), flush=True)
    return rows


def main() -> None:
    rows = [row for tau in TAUS for row in measure(tau)]
    result = {"robots": ROBOTS, "seconds": STEPS * 0.05, "terrain": "flat", "rows": rows}
    pathlib.Path(sys.argv[1]).write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
