"""quadcos: cosine-oscillator rhythm control learned by SAC, on thousands of MJX quadrupeds.

Zhang et al. 2023, "Adaptive Locomotion Learning for Quadruped Robots by Combining DRL with a
Cosine Oscillator Based Rhythm Controller" (Appl. Sci. 13, 11045), as a JAX library.

Layers, lowest first (each imports only those below it; tests/test_layers.py checks):
`_util`, `equations`, `robot`, `terrain`, `viz`, `env`, `training`, `evaluation`, `deploy`,
`benchmarking`, then the command lines `train`, `evaluate`, `bench`, `play`, `sim2sim`,
`export`. Modules that moved into the layers keep their old names (`quadcos.oscillator` is
`quadcos.equations.oscillator`).
"""

import importlib
import importlib.abc
import importlib.util
import sys

from quadcos.env import QuadrupedEnv, default_config, make_env

# Old module names -> where they live now; `import quadcos.oscillator` and
# `from quadcos import oscillator` give the very same module object.
MOVED_MODULES = {
    "quadcos.backends": "quadcos.env.backends",
    "quadcos.caches": "quadcos._util.caches",
    "quadcos.cli": "quadcos._util.cli",
    "quadcos.constants": "quadcos.robot.constants",
    "quadcos.courses": "quadcos.terrain.courses",
    "quadcos.env_config": "quadcos.env.config",
    "quadcos.episodes": "quadcos.env.episodes",
    "quadcos.gait_search": "quadcos.evaluation.gait_search",
    "quadcos.ground": "quadcos.terrain.ground",
    "quadcos.numpy_policy": "quadcos.deploy.numpy_policy",
    "quadcos.numpy_twins": "quadcos.deploy.twins",
    "quadcos.oscillator": "quadcos.equations.oscillator",
    "quadcos.overrides": "quadcos._util.overrides",
    "quadcos.plots": "quadcos.viz.plots",
    "quadcos.provenance": "quadcos._util.provenance",
    "quadcos.quiet": "quadcos._util.quiet",
    "quadcos.randomization": "quadcos.env.randomization",
    "quadcos.reward": "quadcos.equations.reward",
    "quadcos.run_dirs": "quadcos.training.run_dirs",
    "quadcos.runs": "quadcos.training.run_config",
    "quadcos.slope": "quadcos.equations.slope",
    "quadcos.terrain_spec": "quadcos.terrain.external",
    "quadcos.training.files": "quadcos._util.files",
    "quadcos.video": "quadcos.viz.video",
}


class _MovedModuleLoader(importlib.abc.Loader):
    def __init__(self, target: str):
        self.target = target

    def create_module(self, spec):
        module = importlib.import_module(self.target)
        self.target_spec = module.__spec__
        return module

    def exec_module(self, module) -> None:
        """The target module ran when it was imported; give back its own spec, which the import
        system replaced by the old name's."""
        module.__spec__ = self.target_spec
        module.__loader__ = self.target_spec.loader


class _MovedModuleFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname, path, target=None):
        if fullname not in MOVED_MODULES:
            return None
        return importlib.util.spec_from_loader(fullname, _MovedModuleLoader(MOVED_MODULES[fullname]))


if not any(isinstance(finder, _MovedModuleFinder) for finder in sys.meta_path):
    sys.meta_path.append(_MovedModuleFinder())


def load_policy(path):
    """A trained policy from a run or policy directory: `.act(obs) -> action` (deterministic)."""
    from quadcos.training import load_policy as _load_policy

    return _load_policy(path)


def evaluate_policy(policy, terrain=None, *, episodes=64, seconds=20.0, seed=0, **env_overrides):
    """Deterministic episodes of `policy` (a run or policy directory, "fixed:trot",
    "fixed:A_k,A_h,T,phi1,phi3" or an `evaluation.ActionSource`) on `terrain` (a spec or Terrain;
    default: the policy's training terrain), all at once. Env overrides as in `make_env`.

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
    )


__all__ = ["QuadrupedEnv", "default_config", "evaluate_policy", "load_policy", "make_env"]
