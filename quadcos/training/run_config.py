"""A saved run's config, migrated to this version of quadcos: the one place that reads it back.

A run directory's `config.json` (and a policy directory's `policy.json`, under "config") holds
the trainer config under "config" and the env config under "run_info.env". Runs made before an
option existed lack it; they were trained with `LEGACY_VALUES[option]`, which may differ from
today's default. `--resume` (`quadcos.train`) and `quadcos.evaluate` both rebuild a run's config
through `migrate`, so a resumed run trains in the env that its evaluation runs in.
"""

import json
import os
import pathlib
from collections.abc import Mapping
from typing import Any

from quadcos import env as env_lib
from quadcos._util.overrides import flat_keys, flatten
from quadcos.training import config as training_config

# Options added after runs were committed, with the value those earlier runs were trained with.
LEGACY_VALUES: dict[str, Any] = {
    # The command filter came later; before it, parameters changed at once.
    "env.action_filter_tau": 0.0,
    # Before the trot-centred action map, the zero action was the middle of each range.
    "env.action_centre": "midpoint",
    # Before random spawns, every robot started at the spawn point.
    "env.spawn_x_max": 0.0,
    # The first runs that paid r_s only for movement judged each step's own speed.
    "env.survival_speed_tau": 0.0,
    # Before the solver probe, a robot without a preset kept its MJCF's physics.
    "env.solver_probe": False,
    # Before exploration could start from the action centre, SAC was Brax's.
    "sac.actor_warmup_steps": 0,
    "sac.init_alpha": 1.0,
    "sac.init_std": None,
    "sac.policy_output_scale": 1.0,
    "sac.prefill_actions": "uniform",
    "sac.target_entropy": None,
    # Before the delayed actor and LayerNorm critics, SAC was Brax's.
    "sac.policy_delay": 1,
    "sac.critic_layer_norm": False,
    # Before the search's time budget, it ran every round.
    "sac.gait_search.max_fraction": 0.0,
}


# Options renamed since runs were committed: old key -> today's.
RENAMED: dict[str, str] = {"env.mjcf_path": "env.robot"}


def known_keys() -> set[str]:
    """Every dotted key of a run config: env.* and sac.*."""
    return {f"env.{key}" for key in flat_keys(env_lib.default_config())} | {
        f"sac.{key}" for key in flat_keys(training_config.default_config())
    }


def migrate(saved: Mapping[str, Any]) -> dict[str, Any]:
    """The complete flattened run config ({"env.terrain": ..., "sac.num_envs": ...}) of a saved
    `config.json`'s content: what it holds, and for options it lacks, `LEGACY_VALUES` (today's
    default for an option without a legacy value: one whose default has never changed).

    Raises:
      ValueError: not a quadcos run config, or options this version of quadcos does not know.
    """
    try:
        tree = {"env": dict(saved["run_info"]["env"]), "sac": dict(saved["config"])}
    except (KeyError, TypeError, ValueError):
        raise ValueError(
            "not a quadcos run config: it lacks the trainer config (config) or the env config"
            " (run_info.env)"
        ) from None
    flat = flatten(tree)
    for old, new in RENAMED.items():
        if old in flat:
            value = flat.pop(old)
            if value != "":  # "" was the default: the paper's robot, today's default too
                flat[new] = value
    if unknown := sorted(set(flat) - known_keys()):
        raise ValueError(
            f"the run was made with options this quadcos does not know: {', '.join(unknown)}"
        )
    return {key: value for key, value in LEGACY_VALUES.items() if key not in flat} | flat


def load_run_config(path: str | os.PathLike[str]) -> dict[str, Any]:
    """`migrate` of a run directory's config.json (or of the file at `path`).

    Raises:
      FileNotFoundError: no config.json there.
      ValueError: it is not a quadcos run config (see `migrate`).
    """
    path = pathlib.Path(path)
    if path.is_dir():
        path = path / "config.json"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    try:
        saved = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        raise ValueError(f"{path} is not a quadcos run config ({error})") from None
    try:
        return migrate(saved)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None


def env_overrides(run_config: Mapping[str, Any]) -> dict[str, Any]:
    """The env part of a flattened run config, as dotted env overrides (`make_env(**...)`)."""
    return {
        key.removeprefix("env."): value
        for key, value in run_config.items()
        if key.startswith("env.")
    }


def gait_of(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The gait a run started from, as env overrides (dotted, "env." included): its action
    centre and feed-forward (`QuadrupedEnv.gait_fields`: the fields a gait search sets), read
    from a run directory's config.json or a policy directory's policy.json.

    Raises:
      FileNotFoundError: neither file there.
      ValueError: not a quadcos run config, or one whose gait was never found ("search").
    """
    path = pathlib.Path(path)
    if not path.is_dir():
        raise FileNotFoundError(f"{path}: no such run or policy directory")
    if (path / "policy.json").is_file() and not (path / "config.json").is_file():
        try:
            saved = json.loads((path / "policy.json").read_text())["config"]
            config = migrate(saved)
        except (OSError, ValueError, KeyError, TypeError) as error:
            raise ValueError(f"{path}/policy.json holds no quadcos run config ({error})") from None
    else:
        config = load_run_config(path)
    keys = (f"env.{field}" for field in env_lib.QuadrupedEnv.gait_fields)
    gait = {key: config[key] for key in keys if key in config}  # (others: their defaults)
    if gait["env.action_centre"] == "search":
        raise ValueError(f"{path}: its run never found a gait (action_centre is still 'search')")
    return gait

