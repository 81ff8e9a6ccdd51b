"""The first phase of a from-scratch run: find a gait, then let SAC learn from it.

With `env.action_centre="search"`, a run knows no walking gait. `quadcos.training.run` (given
`find_gait`, as `python -m quadcos.train` gives it) first searches constant rhythm parameters
(A_k, A_h, T, φ1, φ3) with `evaluation.search_fixed` — round 1 uniform over §3.3's ranges, no
hand-set trot among the candidates, later rounds around the best — scored by the run's own reward
(Eq. 13) on the run's own terrain (with `gait_search.min_speed` / `.max_attitude`, only among
candidates that reach that speed and stay that level). The best candidate without falls (with
`gait_search.confirm_robots`: the best of a rerun of the finalists on more robots) becomes the
action centre (what SAC's zero action commands), and the search's wall time starts the run's
clock, so a time to walk counts it.

Candidates act from the first step, with the command filter off, as the found gait will in
training: there it is the action centre, where the filtered command starts. With the filter on,
a candidate would ramp in from the fixed trot over its first ~0.25 s instead, a start training
does not have: ANYmal C's best gait so found walks 1.3 m/s after the ramp, and without it
shuffles at 0.33 m/s and falls within 2-13 s (experiments/robots).
"""

import logging
from collections.abc import Callable
from typing import Any

import ml_collections

from quadcos._util.overrides import flatten
from quadcos.equations import oscillator

logger = logging.getLogger("quadcos.train")


class NoGaitFound(RuntimeError):
    """No candidate of the search finished its episodes without a fall (at the speed floor,
    where the search has one)."""


def find_gait(config: ml_collections.ConfigDict) -> dict[str, Any]:
    """Runs the search for a run config ({"env", "sac"}) whose action centre is "search".

    Returns:
      The search result of `evaluation.search_fixed` plus "action_centre": the best candidate as
      an `env.action_centre` string.

    Raises:
      NoGaitFound: every candidate fell at least once or missed the speed floor (one beyond the
        attitude bound is kept where none is within it, with a warning).
    """
    from quadcos.evaluation import (
        fixed_search,  # heavy: builds envs; only a from-scratch run needs it
    )

    search = config.sac.gait_search
    overrides = candidate_overrides(config)
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
    speed_floor = floor
    if search.max_attitude > 0:
        floor += f" within {search.max_attitude:g} rad of roll and pitch error"
    report = _round_report(search, floor, budget)
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
        max_attitude=float(search.max_attitude),
        confirm_robots=search.confirm_robots,
        env_overrides=overrides,
        on_round=report,
    )
    best = result["ranking"][0]
    if result["num_without_falls"] == 0:
        # The attitude bound is a preference: with no candidate within it, the most level one
        # that never fell (at the speed floor; the ranking orders by falls, then by excess).
        floor_only = (float(search.min_speed), search.min_speed_of)
        standing = [
            c for c in result["ranking"] if fixed_search.eligible(c, *floor_only)
        ] if search.max_attitude > 0 else []
        if not standing:
            raise NoGaitFound(
                f"the gait search found no candidate without falls{speed_floor} in"
                f" {len(result['rounds'])} rounds of {search.num_candidates}; raise"
                " config.sac.gait_search.rounds or .num_candidates"
                + (" or lower .min_speed" if search.min_speed > 0 else "")
            )
        best = standing[0]
        logger.warning(
            "gait search: no gait within %g rad of roll and pitch error; kept the most level one"
            " that never fell (roll %.3f rad, pitch error %.3f rad)",
            search.max_attitude,
            best["mean_max_abs_roll"],
            best["mean_max_abs_pitch_error"],
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
        "gait search: action centre %s (%.2f m/s, %.1f %% falls, roll %.3f rad, pitch error"
        " %.3f rad) after %.0f s",
        centre,
        best["mean_forward_speed"],
        100 * best["fall_rate"],
        best["mean_max_abs_roll"],
        best["mean_max_abs_pitch_error"],
        result["setup"]["wall_time_s"],
    )
    return result | {"action_centre": centre}



def candidate_overrides(config: ml_collections.ConfigDict) -> dict[str, Any]:
    """The env overrides the search of a run config ({"env", "sac"}) runs its candidates under:
    the run's env but for its terrain, spawns and centre, acting from the first step as the
    centre will (no command filter), every candidate of §3.3's ranges in reach (action scale 1,
    no parameter held)."""
    overrides = flatten(config.env.to_dict())
    for key in ("terrain", "spawn_x_max", "action_centre"):
        overrides.pop(key)
    return overrides | {"action_filter_tau": 0.0, "action_scale": 1.0, "held_rhythm": ""}


def _round_report(
    search: ml_collections.ConfigDict, floor: str, budget: float | None
) -> Callable[[dict[str, Any]], bool]:
    """The search's `on_round`: logs each round; True (the rounds end) where another round, and
    the confirmation after it, would end past `budget` (s from the search's start; None: none)."""
    ends = []  # each round's end, s from the search's start

    def report(entry: dict[str, Any]) -> bool:
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
        ends.append(entry["wall_time_s"])
        after = 1 if search.confirm_robots else 0
        stop = budget is not None and entry["round"] < search.rounds
        if stop and out_of_time(ends, budget, after):
            logger.warning(
                "gait search: stopped after round %d of %d: another would end past %.0f s"
                " (sac.gait_search.max_fraction of sac.max_seconds)",
                entry["round"],
                search.rounds,
                budget,
            )
            return True
        return False

    return report


def out_of_time(ends: list[float], budget_s: float, after_rounds: int) -> bool:
    """Whether one more round and `after_rounds` after it, each as long as the last of the rounds
    ending at `ends` (s from the search's start), would end past `budget_s`."""
    last = ends[-1] - (ends[-2] if len(ends) > 1 else 0.0)
    return ends[-1] + (1 + after_rounds) * last > budget_s
