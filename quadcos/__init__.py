"""quadcos: cosine-oscillator rhythm control learned by SAC, on thousands of MJX quadrupeds.

Zhang et al. 2023, "Adaptive Locomotion Learning for Quadruped Robots by Combining DRL with a
Cosine Oscillator Based Rhythm Controller" (Appl. Sci. 13, 11045), as a JAX library.

Layers, lowest first (each imports only those below it; tests/test_layers.py checks):
`_util`, `equations`, `robot`, `terrain`, `viz`, `env`, `training`, `evaluation`, `deploy`,
`benchmarking`, then the command lines `train`, `evaluate`, `bench`, `play`, `sim2sim`,
`export`. `quadcos.oscillator` (`quadcos.equations.oscillator`), `quadcos.terrain` and
`quadcos.courses` (`quadcos.terrain.courses`) are the modules a library example reaches for first.
"""

from quadcos import terrain
from quadcos.env import QuadrupedEnv, default_config, make_env
from quadcos.equations import oscillator
from quadcos.terrain import courses


def load_policy(path):
    """A trained policy from a run or policy directory: `.act(obs) -> action` (deterministic)."""
    from quadcos.training import load_policy as _load_policy

    return _load_policy(path)


def evaluate_policy(
    policy, terrain=None, *, episodes=64, seconds=20.0, seed=0, commands=None, **env_overrides
):
    """Deterministic episodes of `policy` (a run or policy directory, "fixed:trot",
    "fixed:A_k,A_h,T,phi1,phi3" or an `evaluation.ActionSource`) on `terrain` (a spec or Terrain;
    default: the policy's training terrain), all at once. `commands`: the velocity commands a
    policy trained with them follows ("random" or a schedule "v,ω@s;...", as `--commands`; None:
    its own). Env overrides as in `make_env`.

    Returns a `quadcos.evaluation.Evaluation`: `.success`, `.falls`, `.speed`, `.summary`,
    `.episodes`, `.trace`, `.to_json()`, `.save_video(path)`.
    """
    from quadcos import evaluation

    return evaluation.evaluate(
        policy,
        terrain,
        num_envs=episodes,
        seconds=seconds,
        seed=seed,
        env_overrides=env_overrides,
        commands=commands,
    )


__all__ = [
    "QuadrupedEnv",
    "courses",
    "default_config",
    "evaluate_policy",
    "load_policy",
    "make_env",
    "oscillator",
    "terrain",
]
