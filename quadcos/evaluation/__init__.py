"""Batched deterministic evaluation of a trained policy or fixed rhythm parameters.

  sources       what acts: a --policy parsed once (`PolicySpec`), its env config (`env_config`,
                for both engines) and the MJX rollout's `ActionSource`
  rollout       the one batched deterministic rollout (`rollout.rollout`), per-episode statistics
  metrics       per-episode values and aggregates: success, falls, speed, attitude, reward
  traces        one episode's time series (`--trace`) and rendering it to video
  report        `evaluate` (the mjx engine of `quadcos.deploy.engines.evaluate`) -> `Evaluation`
                (the `--out` JSON), `write_json`
  fixed_search  the best fixed rhythm parameters (Fig. 15's baseline)

`python -m quadcos.evaluate` is the command line over these.
"""

from quadcos.evaluation.fixed_search import search_fixed
from quadcos.evaluation.metrics import aggregate, episode_values, per_course
from quadcos.evaluation.report import Evaluation, course_table, evaluate, write_json
from quadcos.evaluation.rollout import EpisodeStats, Rollout
from quadcos.evaluation.sources import (
    ActionSource,
    PolicySpec,
    build_env,
    env_config,
    fixed_source,
    parse_fixed,
    policy_source,
    resolve_source,
)
from quadcos.evaluation.traces import TRACE_SERIES, render_trace, trace_dict

__all__ = [
    "TRACE_SERIES",
    "ActionSource",
    "EpisodeStats",
    "Evaluation",
    "PolicySpec",
    "Rollout",
    "aggregate",
    "build_env",
    "course_table",
    "env_config",
    "episode_values",
    "evaluate",
    "fixed_source",
    "parse_fixed",
    "per_course",
    "policy_source",
    "render_trace",
    "resolve_source",
    "search_fixed",
    "trace_dict",
    "write_json",
]
