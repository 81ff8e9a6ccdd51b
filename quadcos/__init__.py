"""quadcos: cosine-oscillator rhythm control learned by SAC, on thousands of MJX quadrupeds.

Zhang et al. 2023, "Adaptive Locomotion Learning for Quadruped Robots by Combining DRL with a
Cosine Oscillator Based Rhythm Controller" (Appl. Sci. 13, 11045), as a JAX library.
"""

from quadcos.env import QuadrupedEnv, default_config, make_env


def load_policy(path):
    """A trained policy from a run or policy directory: `.act(obs) -> action` (deterministic)."""
    from quadcos.training import load_policy as _load_policy

    return _load_policy(path)


__all__ = ["QuadrupedEnv", "default_config", "load_policy", "make_env"]
