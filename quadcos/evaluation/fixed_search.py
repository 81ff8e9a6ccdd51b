"""The best fixed rhythm parameters (Fig. 15's baseline): a search over (A_k, A_h, T, φ1, φ3)."""

import functools
import math
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from quadcos import terrain as terrain_lib
from quadcos.equations import oscillator
from quadcos.evaluation.metrics import episode_values
from quadcos.evaluation.rollout import FORMAT_VERSION, rollout
from quadcos.evaluation.sources import FIXED_PREFIX, PARAMETER_NAMES, build_env, fixed_source

SEARCH_FORMAT = "quadcos.fixed_search"
# What a speed floor holds to: the candidate's robots' mean forward speed, or its slowest robot's.
SPEED_FLOOR_OF = {"mean": "mean_forward_speed", "slowest": "slowest_forward_speed"}
# What an attitude bound holds to: the candidate's robots' mean episode peaks (rad).
ATTITUDE = ("mean_max_abs_roll", "mean_max_abs_pitch_error")


def search_fixed(
    terrain: terrain_lib.Terrain | str = "flat",
    *,
    num_candidates: int = 256,
    robots_per_candidate: int = 4,
    rounds: int = 3,
    elite: int = 8,
    seconds: float = 20.0,
    seed: int = 0,
    top: int = 10,
    include_trot: bool = True,
    symmetric: bool = False,
    min_speed: float = 0.0,
    min_speed_of: str = "mean",
    max_attitude: float = 0.0,
    confirm_robots: int = 0,
    env_overrides: Mapping[str, Any] | None = None,
    progress: Callable[[int, int], None] | None = None,
    on_round: Callable[[dict[str, Any]], None] | None = None,
) -> dict[str, Any]:
    """Searches constant rhythm parameters (A_k, A_h, T, φ1, φ3) for the best fixed gait.

    Each round evaluates `num_candidates` parameter sets on `robots_per_candidate` robots each, all
    in one batch (the same compiled rollout every round). Round 1 draws candidates uniformly from
    the §3.3 ranges (`oscillator.parameter_bounds`), with `oscillator.FIXED_TROT` as candidate 0
    when `include_trot` (False: nothing known to walk is given); `symmetric` keeps every
    candidate on φ3 = φ1 − π (wrapped into its range), where the two diagonal leg pairs move
    alike half a cycle apart — mirror-symmetric gaits, which do not turn by construction. Each
    later round keeps the `elite` best so far and draws the rest around them (Gaussian, std 10 %
    of each range in round 2, halved every round after). A candidate's score is its robots' mean
    episode reward (Eq. 13 summed over the episode) when none of them fell and their forward
    speed reaches `min_speed` (m/s; 0: any) — their mean's, or with `min_speed_of="slowest"` every
    robot's (under domain randomisation: the gait holds its speed on every robot it was drawn for,
    not only on average) — and, with `max_attitude` > 0 (rad), their mean peak roll and pitch
    error (`ATTITUDE`) are within it — else −inf: the ranking is the paper's reward among gaits
    with zero falls (and that speed and attitude); `ranking_key` orders the rest. On a lane
    terrain every candidate runs on the same lanes (`candidate_lanes`: for `random:` courses, from
    the gentlest to the steepest), so that no candidate is ranked up for the easier course it was
    given.

    `confirm_robots` > 0 adds a confirmation after the rounds: the best distinct candidates, as
    many as the batch holds on that many robots each, run once more (new draws of the terrain's
    spawns and of any randomisation) and are ranked by that run alone — the clean ones by score,
    then the rest by fewer falls (`confirmation_key`) — so that the gait kept is the one that held
    on many robots, not the one a few robots favoured once among thousands of tries.

    `on_round` is called after each round with its entry of "rounds"; a true return ends them.

    Returns:
      {"format", "ranking": the `top` best candidates (parameters, `policy` spec for --policy,
      score, fall_rate, mean_forward_speed, mean_max_abs_yaw, mean_lateral_drift, ...; with
      `confirm_robots`, the confirmed ones, "round" one past the last),
      "rounds": per round its wall time, candidates' mean fall rate, how many never fell, the
      best score and that candidate's speed; "confirmation" (with `confirm_robots`: robots,
      candidates, how many never fell, wall time; else None); "setup"}.
    """
    bounds = {"min_speed": min_speed, "min_speed_of": min_speed_of, "max_attitude": max_attitude}
    _check_arguments(num_candidates, robots_per_candidate, rounds, seconds, confirm_robots,
                     **bounds)
    num_envs = num_candidates * robots_per_candidate
    search = _Search(terrain, env_overrides, num_envs, seconds, seed, bounds)
    env = search.env
    started = time.monotonic()
    evaluated, rounds_log = search.run_rounds(
        rounds, elite, num_candidates, include_trot, symmetric, progress, on_round, started
    )
    ranked = sorted(evaluated, key=search.rank_key, reverse=True)
    confirmation = None
    if confirm_robots:
        ranked, confirmation = search.confirm(ranked, confirm_robots, len(rounds_log), started)
    return {
        "format": SEARCH_FORMAT,
        "format_version": FORMAT_VERSION,
        "ranking": [_ranking_entry(c) for c in ranked[:top]],
        "rounds": rounds_log,
        "confirmation": confirmation,
        "num_without_falls": sum(math.isfinite(c["score"]) for c in evaluated),
        "num_evaluated": len(evaluated),
        "setup": {
            "terrain": env.terrain.spec,
            "num_candidates": num_candidates,
            "robots_per_candidate": robots_per_candidate,
            "lanes": candidate_lanes(env.terrain.num_lanes, robots_per_candidate).tolist(),
            "rounds": rounds,
            "elite": elite,
            "seconds": search.num_steps * env.dt,
            "seed": seed,
            "include_trot": include_trot,
            "symmetric": symmetric,
            **bounds,
            "confirm_robots": confirm_robots,
            "env": env.config.to_dict() | {"terrain": env.terrain.spec},
            "wall_time_s": time.monotonic() - started,
        },
    }


def score_gaits(
    terrain: terrain_lib.Terrain | str,
    gaits: np.ndarray,
    *,
    robots: int,
    seconds: float,
    seed: int = 0,
    env_overrides: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """Each of `gaits` (n, 5: A_k, A_h, T, φ1, φ3) on `robots` robots for `seconds`, as a search
    scores a candidate in its first round (no speed floor, no attitude bound): one entry per gait
    (mean episode reward, fall rate, speeds, mean peak yaw, roll and pitch error, ...)."""
    gaits = np.asarray(gaits, np.float64).reshape(-1, 5)
    bounds = {"min_speed": 0.0, "min_speed_of": "mean", "max_attitude": 0.0}
    search = _Search(terrain, env_overrides, len(gaits) * robots, seconds, seed, bounds)
    return search.score(gaits, robots, 0, lambda done, total: None)


def _check_arguments(
    num_candidates: int,
    robots_per_candidate: int,
    rounds: int,
    seconds: float,
    confirm_robots: int,
    min_speed: float,
    min_speed_of: str,
    max_attitude: float,
) -> None:
    if num_candidates < 1 or robots_per_candidate < 1 or rounds < 1:
        raise ValueError("num_candidates, robots_per_candidate and rounds must be >= 1")
    if not (math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"seconds must be finite and > 0; got {seconds}")
    if not (math.isfinite(min_speed) and min_speed >= 0):
        raise ValueError(f"min_speed must be finite and >= 0 m/s; got {min_speed}")
    if min_speed_of not in SPEED_FLOOR_OF:
        raise ValueError(
            f"min_speed_of must be one of {sorted(SPEED_FLOOR_OF)}; got {min_speed_of!r}"
        )
    if not (math.isfinite(max_attitude) and max_attitude >= 0):
        raise ValueError(f"max_attitude must be finite and >= 0 rad (0: off); got {max_attitude}")
    num_envs = num_candidates * robots_per_candidate
    if confirm_robots < 0 or (confirm_robots and num_envs % confirm_robots):
        raise ValueError(
            f"confirm_robots must be 0 or divide num_candidates x robots_per_candidate = {num_envs}"
            f"; got {confirm_robots}"
        )


class _Search:
    """The batch every round of a search runs in: one env, one compiled rollout of
    `num_envs` robots for `seconds`, and how candidates are ranked."""

    def __init__(
        self,
        terrain: terrain_lib.Terrain | str,
        env_overrides: Mapping[str, Any] | None,
        num_envs: int,
        seconds: float,
        seed: int,
        bounds: Mapping[str, Any],
    ):
        self.source = fixed_source(oscillator.FIXED_TROT, name="search")
        self.env = build_env(self.source, terrain, env_overrides)
        self.num_envs, self.seed = num_envs, seed
        self.num_steps = math.ceil(seconds / self.env.dt - 1e-9)
        self.bounds = oscillator.parameter_bounds(self.env.config.period_min)
        # Candidates stay strictly inside the box (0.1 % of each range from its ends), so that
        # the best can be an action centre (`env.action_centre` needs a span on both sides).
        lower, upper = self.bounds
        inner = 1e-3 * (upper - lower)
        self.inner_bounds = (lower + inner, upper - inner)
        self.rank_key = functools.partial(ranking_key, **bounds)
        self.confirmation_key = functools.partial(confirmation_key, **bounds)
        self.eligible_key = functools.partial(eligible, **bounds)

    def draw(
        self,
        rng: np.random.Generator,
        round_index: int,
        elites: list[dict[str, Any]],
        num_candidates: int,
        include_trot: bool,
        symmetric: bool,
    ) -> np.ndarray:
        """A round's candidates, (num_candidates, 5), inside the inner box: round 1 uniform
        over the box (`FIXED_TROT` first with `include_trot`); later rounds the `elites` (the
        best so far) and Gaussian draws around them, std 10 % of each range in round 2, halved
        every round after. `symmetric`: φ3 = φ1 − π."""
        lower, upper = self.bounds
        if round_index == 0:
            candidates = rng.uniform(lower, upper, size=(num_candidates, 5))
            if include_trot:
                candidates[0] = np.asarray(oscillator.FIXED_TROT)
        else:
            parameters = np.array([c["parameters_array"] for c in elites[:num_candidates]])
            std = 0.1 * (upper - lower) / 2 ** (round_index - 1)
            parents = parameters[rng.integers(len(parameters), size=num_candidates)]
            candidates = np.clip(parents + rng.normal(size=parents.shape) * std, lower, upper)
            candidates[: len(parameters)] = parameters
        candidates = np.clip(candidates, *self.inner_bounds)
        if symmetric:  # after the clip: φ3 = φ1 − π holds exactly, inside the inner box
            low, high = self.inner_bounds
            candidates[:, 4] = _wrap(candidates[:, 3] - np.pi, low[4], high[4])
        return candidates

    def run_rounds(
        self,
        rounds: int,
        elite: int,
        num_candidates: int,
        include_trot: bool,
        symmetric: bool,
        progress: Callable[[int, int], None] | None,
        on_round: Callable[[dict[str, Any]], None] | None,
        started: float,
    ) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
        """The search's rounds (`search_fixed`), each on `num_candidates` candidates of
        `num_envs // num_candidates` robots: every candidate scored, and each round's entry of
        "rounds" (wall times from `started`), up to the one `on_round` ends them after."""
        rng = np.random.default_rng(self.seed)
        robots = self.num_envs // num_candidates
        evaluated: list[dict[str, Any]] = []
        rounds_log: list[dict[str, Any]] = []
        for round_index in range(rounds):
            ranked = sorted(evaluated, key=self.rank_key, reverse=True)
            candidates = self.draw(
                rng, round_index, ranked[:elite], num_candidates, include_trot, symmetric
            )
            round_progress = _round_progress(progress, round_index, rounds)
            evaluated += self.score(candidates, robots, round_index, round_progress)
            this_round = evaluated[-num_candidates:]
            rounds_log.append(_round_entry(round_index + 1, this_round, self.rank_key, started))
            if on_round is not None and on_round(rounds_log[-1]):
                break
        return evaluated, rounds_log

    def score(
        self,
        candidates: np.ndarray,
        robots: int,
        round_index: int,
        on_progress: Callable[[int, int], None],
    ) -> list[dict[str, Any]]:
        """Runs `candidates` on `robots` robots each (the batch padded with the first's) and
        scores them (`_candidate_entry`)."""
        env, num_envs, num_steps = self.env, self.num_envs, self.num_steps
        per_robot = np.repeat(candidates, robots, axis=0)
        pad = num_envs - len(per_robot)
        per_robot = np.concatenate([per_robot, np.repeat(candidates[:1], pad, axis=0)])
        result = rollout(
            env,
            self.source,
            num_envs=num_envs,
            num_steps=num_steps,
            seed=self.seed + round_index,
            act_params=per_robot.astype(np.float32),
            progress=on_progress,
            lanes=np.resize(candidate_lanes(env.terrain.num_lanes, robots), num_envs),
        )
        episodes = episode_values(result.stats, env.dt, num_steps)
        return [
            _candidate_entry(
                params, episodes[c * robots : (c + 1) * robots], round_index + 1, self.eligible_key
            )
            for c, params in enumerate(candidates)
        ]


    def confirm(
        self, ranked: list[dict[str, Any]], robots: int, rounds: int, started: float
    ) -> tuple[list[dict[str, Any]], dict[str, Any]]:
        """The best distinct candidates of `ranked` (as many as the batch holds) run once more
        on `robots` robots each: their ranking by that run, and the confirmation's entry."""
        finalists = _distinct(ranked, self.num_envs // robots)
        confirmed = sorted(
            self.score(finalists, robots, rounds, lambda done, total: None),
            key=self.confirmation_key,
            reverse=True,
        )
        return confirmed, {
            "robots": robots,
            "candidates": len(finalists),
            "num_without_falls": sum(math.isfinite(c["score"]) for c in confirmed),
            "wall_time_s": time.monotonic() - started,
        }


def _round_progress(
    progress: Callable[[int, int], None] | None, round_index: int, rounds: int
) -> Callable[[int, int], None]:
    """A round's progress (robot steps done, of all) as progress of the whole search."""

    def round_progress(done: int, total: int) -> None:
        if progress is not None:
            progress(round_index * total + done, rounds * total)

    return round_progress


def _round_entry(
    round_number: int,
    this_round: list[dict[str, Any]],
    rank_key: Callable[[Mapping[str, Any]], tuple[float, ...]],
    started: float,
) -> dict[str, Any]:
    """A round's line of the search's "rounds"."""
    best = max(this_round, key=rank_key)
    return {
        "round": round_number,
        "wall_time_s": time.monotonic() - started,
        "fall_rate": float(np.mean([c["fall_rate"] for c in this_round])),
        "num_without_falls": sum(math.isfinite(c["score"]) for c in this_round),
        "best_score": best["score"] if math.isfinite(best["score"]) else None,
        "best_forward_speed": best["mean_forward_speed"],
    }


def _ranking_entry(candidate: Mapping[str, Any]) -> dict[str, Any]:
    """A ranked candidate as the search returns it (JSON: no array, a score of None for −inf)."""
    return {key: value for key, value in candidate.items() if key != "parameters_array"} | {
        "score": candidate["score"] if math.isfinite(candidate["score"]) else None
    }


def ranking_key(
    candidate: Mapping[str, Any],
    min_speed: float = 0.0,
    min_speed_of: str = "mean",
    max_attitude: float = 0.0,
) -> tuple[float, ...]:
    """How a search orders its candidates (descending): by score; with a speed floor or an
    attitude bound, the candidates they rule out (score −inf) follow by fewer falls, then by how
    little they exceed the bound, then by the speed the floor holds to (`SPEED_FLOOR_OF`) up to
    the floor, so that the next round's elite breed towards both."""
    if min_speed == 0 and max_attitude == 0:
        return (candidate["score"],)
    speed = min(candidate[SPEED_FLOOR_OF[min_speed_of]], min_speed) if min_speed else 0.0
    return (
        candidate["score"],
        -candidate["fall_rate"],
        -_attitude_excess(candidate, max_attitude),
        speed,
    )


def confirmation_key(
    candidate: Mapping[str, Any],
    min_speed: float = 0.0,
    min_speed_of: str = "mean",
    max_attitude: float = 0.0,
) -> tuple[float, ...]:
    """How a confirmation orders its candidates (descending): the clean ones by score, then the
    rest by fewer falls, then by how little they exceed the attitude bound, then by the speed the
    floor holds to (up to the floor; any speed without one), so that a gait none of whose
    finalists held everywhere is the one that fell least."""
    speed = candidate[SPEED_FLOOR_OF[min_speed_of]]
    return (
        candidate["score"],
        -candidate["fall_rate"],
        -_attitude_excess(candidate, max_attitude),
        min(speed, min_speed) if min_speed else speed,
    )


def _attitude_excess(candidate: Mapping[str, Any], max_attitude: float) -> float:
    """How far (rad) the candidate's worse mean peak (`ATTITUDE`) lies beyond `max_attitude`
    (0 within it, and without a bound)."""
    if max_attitude == 0:
        return 0.0
    return max(0.0, max(candidate[key] for key in ATTITUDE) - max_attitude)


def eligible(
    entry: Mapping[str, Any], min_speed: float, min_speed_of: str, max_attitude: float = 0.0
) -> bool:
    """Whether a scored candidate is ranked: none of its robots fell, the speed floor held and
    its attitude is within the bound."""
    speed = entry[SPEED_FLOOR_OF[min_speed_of]]
    return (
        entry["fall_rate"] == 0.0
        and (min_speed == 0 or speed >= min_speed)
        and _attitude_excess(entry, max_attitude) == 0
    )


def _candidate_entry(
    params: np.ndarray,
    episodes: list[dict[str, Any]],
    round_number: int,
    eligible: Callable[[Mapping[str, Any]], bool],
) -> dict[str, Any]:
    """One candidate's result from its robots' episodes: score = mean episode reward when
    `eligible`, else −inf."""
    speeds = [e["forward_speed"] for e in episodes]
    mean_reward = float(np.mean([e["episode_reward"] for e in episodes]))
    entry = {
        "round": round_number,
        "parameters": dict(zip(PARAMETER_NAMES, map(float, params))),
        "parameters_array": params,
        "policy": FIXED_PREFIX + ",".join(f"{float(p):.6g}" for p in params),
        "mean_episode_reward": mean_reward,
        "fall_rate": float(np.mean([e["fell"] for e in episodes])),
        "mean_forward_speed": float(np.mean(speeds)),
        "slowest_forward_speed": float(np.min(speeds)),
        "mean_max_abs_yaw": float(np.mean([e["max_abs_yaw"] for e in episodes])),
        "mean_max_abs_roll": float(np.mean([e["max_abs_roll"] for e in episodes])),
        "mean_max_abs_pitch_error": float(np.mean([e["max_abs_pitch_error"] for e in episodes])),
        "mean_lateral_drift": float(np.mean([e["lateral_drift"] for e in episodes])),
    }
    return {"score": mean_reward if eligible(entry) else -math.inf} | entry


def _distinct(ranked: list[dict[str, Any]], count: int) -> np.ndarray:
    """The parameters of the first `count` distinct candidates of a ranking (elites recur)."""
    seen: dict[tuple[float, ...], np.ndarray] = {}
    for candidate in ranked:
        seen.setdefault(
            tuple(candidate["parameters_array"].tolist()), candidate["parameters_array"]
        )
        if len(seen) == count:
            break
    return np.array(list(seen.values()))


def candidate_lanes(num_lanes: int, robots_per_candidate: int) -> np.ndarray:
    """The lanes of one candidate's robots: spread evenly from the first lane to the last (lane 0
    for all on a terrain without lanes)."""
    return np.rint(np.linspace(0, num_lanes - 1, robots_per_candidate)).astype(np.int32)


def _wrap(phase: np.ndarray, low: float, high: float) -> np.ndarray:
    """Shifts phases that left [low, high] by one cycle back in (the range spans two cycles)."""
    return np.where(
        phase < low, phase + 2 * np.pi, np.where(phase > high, phase - 2 * np.pi, phase)
    )
