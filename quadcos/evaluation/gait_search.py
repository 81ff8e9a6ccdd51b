"""The first phase of a from-scratch run: find a gait, then let SAC learn from it.

With `env.action_centre="search"`, a run knows no walking gait. `quadcos.training.run` (given
`find_gait`, as `python -m quadcos.train` gives it) first searches constant rhythm parameters
(A_k, A_h, T, φ1, φ3) with `evaluation.search_fixed` — round 1 uniform over §3.3's ranges, no
hand-set trot among the candidates, later rounds around the best — scored by the run's own reward
(Eq. 13) on the run's own terrain. The best candidate without falls (with `gait_search.confirm_robots`: the best of a
rerun of the finalists on more robots) becomes the action centre (what SAC's zero action
commands), and the search's wall time starts the run's clock, so a time to walk counts it.

Candidates act from the first step, with the command filter off, as the found gait will in
training: there it is the action centre, where the filtered command starts. With the filter on,
a candidate would ramp in from the fixed trot over its first ~0.25 s instead, a start training
does not have: ANYmal C's best gait so found walks 1.3 m/s after the ramp, and without it
shuffles at 0.33 m/s and falls within 2-13 s (experiments/robots).
"""

import logging
from typing import Any

import ml_collections

from quadcos._util.overrides import flatten
from quadcos.equations import oscillator

logger = logging.getLogger("quadcos.train")


class NoGaitFound(RuntimeError):
    """No candidate of the search finished its episodes without a fall."""


def find_gait(config: ml_collections.ConfigDict) -> dict[str, Any]:
    """Runs the search for a run config ({"env", "sac"}) whose action centre is "search".

    Returns:
      The search result of `evaluation.search_fixed` plus "action_centre": the best candidate as
      an `env.action_centre` string.

    Raises:
      NoGaitFound: every candidate fell at least once.
    """
    from quadcos.evaluation import (
        fixed_search,  # heavy: builds envs; only a from-scratch run needs it
    )

    search = config.sac.gait_search
    overrides = flatten(config.env.to_dict())
    for key in ("terrain", "spawn_x_max", "action_centre"):
        overrides.pop(key)
    overrides["action_filter_tau"] = 0.0  # act from the first step, as the centre will
    overrides["action_scale"] = 1.0  # every candidate of §3.3's ranges in reach
    logger.info(
        "gait search: %d candidates x %d robots x %g s, %d rounds, on %s",
        search.num_candidates,
        search.robots_per_candidate,
        search.seconds,
        search.rounds,
        config.env.terrain,
    )

    budget = search.max_fraction * config.sac.max_seconds or None  # s, from the search's start
    floor = f" at >= {search.min_speed:g} m/s" if search.min_speed > 0 else ""
    if floor and search.min_speed_of == "slowest":
        floor += " on every robot"

    def report(entry: dict[str, Any]) -> None:
        best = entry["best_score"]
        logger.info(
            "gait search round %d/%d (%.0f s): %d of %d candidates never fell%s; best %s at %.2f m/s",
            entry["round"],
            search.rounds,
            entry["wall_time_s"],
            entry["num_without_falls"],
            search.num_candidates,
            floor,
            "none" if best is None else f"{best:,.0f}",
            entry["best_forward_speed"],
        )

    result = fixed_search.search_fixed(
        config.env.terrain,
        num_candidates=search.num_candidates,
        robots_per_candidate=search.robots_per_candidate,
        rounds=search.rounds,
        elite=search.elite,
        seconds=search.seconds,
        seed=config.sac.seed,
        include_trot=False,
        symmetric=bool(search.symmetric),
        min_speed=float(search.min_speed),
        min_speed_of=search.min_speed_of,
        confirm_robots=search.confirm_robots,
        env_overrides=overrides,
        on_round=report,
        time_budget_s=budget,
    )
    if budget is not None and result["setup"]["rounds_run"] < search.rounds:
        logger.warning(
            "gait search: stopped after round %d of %d: another would end past %.0f s, %g of the"
            " run's %g s (sac.gait_search.max_fraction, sac.max_seconds)",
            result["setup"]["rounds_run"],
            search.rounds,
            budget,
            search.max_fraction,
            config.sac.max_seconds,
        )
    best = result["ranking"][0]
    if result["num_without_falls"] == 0:
        raise NoGaitFound(
            f"the gait search found no candidate without falls{floor} in"
            f" {result['setup']['rounds_run']} rounds of {search.num_candidates}; raise"
            " config.sac.gait_search.rounds or .num_candidates"
            + (" or lower .min_speed" if floor else "")
        )
    confirmation = result["confirmation"]
    if confirmation is not None:
        logger.info(
            "gait search confirmation (%.0f s): %d of the %d best candidates never fell%s on %d"
            " robots each",
            confirmation["wall_time_s"],
            confirmation["num_without_falls"],
            confirmation["candidates"],
            floor,
            confirmation["robots"],
        )
    centre = oscillator.centre_spec(best["parameters"].values())
    logger.info(
        "gait search: action centre %s (%.2f m/s, %.1f %% falls) after %.0f s",
        centre,
        best["mean_forward_speed"],
        100 * best["fall_rate"],
        result["setup"]["wall_time_s"],
    )
    return result | {"action_centre": centre}

