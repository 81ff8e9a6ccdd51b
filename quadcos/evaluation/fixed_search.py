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
    not only on average) — else −inf: the ranking is the paper's reward among gaits with zero
    falls (and that speed); `ranking_key` orders the rest. On a lane terrain every candidate runs
    on the same lanes (`candidate_lanes`: for `random:` courses, from the gentlest to the
    steepest), so that no candidate is ranked up for the easier course it was given.

    `confirm_robots` > 0 adds a confirmation after the rounds: the best distinct candidates, as
    many as the batch holds on that many robots each, run once more (new draws of the terrain's
    spawns and of any randomisation) and are ranked by that run alone — the clean ones by score,
    then the rest by fewer falls (`confirmation_key`) — so that the gait kept is the one that held
    on many robots, not the one a few robots favoured once among thousands of tries.

    `on_round` is called after each round with its entry of "rounds".

    Returns:
      {"format", "ranking": the `top` best candidates (parameters, `policy` spec for --policy,
      score, fall_rate, mean_forward_speed, mean_max_abs_yaw, mean_lateral_drift, ...; with
      `confirm_robots`, the confirmed ones, "round" one past the last),
      "rounds": per round its wall time, candidates' mean fall rate, how many never fell, the
      best score and that candidate's speed; "confirmation" (with `confirm_robots`: robots,
      candidates, how many never fell, wall time; else None); "setup"}.
    """
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
    num_envs = num_candidates * robots_per_candidate
    if confirm_robots < 0 or (confirm_robots and num_envs % confirm_robots):
        raise ValueError(
            f"confirm_robots must be 0 or divide num_candidates x robots_per_candidate = {num_envs}"
            f"; got {confirm_robots}"
        )
    source = fixed_source(oscillator.FIXED_TROT, name="search")
    env = build_env(source, terrain, env_overrides)
    num_steps = math.ceil(seconds / env.dt - 1e-9)
    lower, upper = oscillator.parameter_bounds(env.config.period_min)
    # Candidates stay strictly inside the box (0.1 % of each range from its ends), so that the
    # best can be an action centre (`env.action_centre` needs a span on both sides).
    inner = 1e-3 * (upper - lower)
    rng = np.random.default_rng(seed)
    rank_key = functools.partial(ranking_key, min_speed=min_speed, min_speed_of=min_speed_of)
    floor_key = functools.partial(_eligible, min_speed=min_speed, min_speed_of=min_speed_of)

    def score(
        candidates: np.ndarray,
        robots: int,
        round_index: int,
        on_progress: Callable[[int, int], None],
    ) -> list[dict[str, Any]]:
        """Runs `candidates` on `robots` robots each (the batch padded with the first's) and
        scores them (`_candidate_entry`)."""
        per_robot = np.repeat(candidates, robots, axis=0)
        pad = num_envs - len(per_robot)
        per_robot = np.concatenate([per_robot, np.repeat(candidates[:1], pad, axis=0)])
        result = rollout(
            env,
            source,
            num_envs=num_envs,
            num_steps=num_steps,
            seed=seed + round_index,
            act_params=per_robot.astype(np.float32),
            progress=on_progress,
            lanes=np.resize(candidate_lanes(env.terrain.num_lanes, robots), num_envs),
        )
        episodes = episode_values(result.stats, env.dt, num_steps)
        return [
            _candidate_entry(
                params, episodes[c * robots : (c + 1) * robots], round_index + 1, floor_key
            )
            for c, params in enumerate(candidates)
        ]

    evaluated: list[dict[str, Any]] = []
    rounds_log: list[dict[str, Any]] = []
    started = time.monotonic()
    for round_index in range(rounds):
        if round_index == 0:
            candidates = rng.uniform(lower, upper, size=(num_candidates, 5))
            if include_trot:
                candidates[0] = np.asarray(oscillator.FIXED_TROT)
        else:
            ranked = sorted(evaluated, key=rank_key, reverse=True)
            elites = np.array([c["parameters_array"] for c in ranked[: min(elite, num_candidates)]])
            std = 0.1 * (upper - lower) / 2 ** (round_index - 1)
            parents = elites[rng.integers(len(elites), size=num_candidates)]
            candidates = np.clip(parents + rng.normal(size=parents.shape) * std, lower, upper)
            candidates[: len(elites)] = elites
        candidates = np.clip(candidates, lower + inner, upper - inner)
        if symmetric:  # after the clip: φ3 = φ1 − π holds exactly, inside the inner box
            candidates[:, 4] = _wrap(
                candidates[:, 3] - np.pi, lower[4] + inner[4], upper[4] - inner[4]
            )

        def round_progress(done: int, total: int, round_index: int = round_index) -> None:
            if progress is not None:
                progress(round_index * total + done, rounds * total)

        evaluated += score(candidates, robots_per_candidate, round_index, round_progress)
        this_round = evaluated[-len(candidates) :]
        best = max(this_round, key=rank_key)
        rounds_log.append(
            {
                "round": round_index + 1,
                "wall_time_s": time.monotonic() - started,
                "fall_rate": float(np.mean([c["fall_rate"] for c in this_round])),
                "num_without_falls": sum(math.isfinite(c["score"]) for c in this_round),
                "best_score": best["score"] if math.isfinite(best["score"]) else None,
                "best_forward_speed": best["mean_forward_speed"],
            }
        )
        if on_round is not None:
            on_round(rounds_log[-1])
    ranked = sorted(evaluated, key=rank_key, reverse=True)
    confirmation = None
    if confirm_robots:
        finalists = _distinct(ranked, num_envs // confirm_robots)
        ranked = sorted(
            score(finalists, confirm_robots, rounds, lambda done, total: None),
            key=functools.partial(confirmation_key, min_speed=min_speed, min_speed_of=min_speed_of),
            reverse=True,
        )
        confirmation = {
            "robots": confirm_robots,
            "candidates": len(finalists),
            "num_without_falls": sum(math.isfinite(c["score"]) for c in ranked),
            "wall_time_s": time.monotonic() - started,
        }
    ranking = [
        {key: value for key, value in c.items() if key != "parameters_array"}
        | {"score": c["score"] if math.isfinite(c["score"]) else None}
        for c in ranked[:top]
    ]
    return {
        "format": SEARCH_FORMAT,
        "format_version": FORMAT_VERSION,
        "ranking": ranking,
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
            "seconds": num_steps * env.dt,
            "seed": seed,
            "include_trot": include_trot,
            "symmetric": symmetric,
            "min_speed": min_speed,
            "min_speed_of": min_speed_of,
            "confirm_robots": confirm_robots,
            "env": env.config.to_dict() | {"terrain": env.terrain.spec},
            "wall_time_s": time.monotonic() - started,
        },
    }


def ranking_key(
    candidate: Mapping[str, Any], min_speed: float = 0.0, min_speed_of: str = "mean"
) -> tuple[float, ...]:
    """How a search orders its candidates (descending): by score; with a speed floor, the
    candidates it rules out (score −inf) follow by fewer falls, then by the speed the floor holds
    to (`SPEED_FLOOR_OF`) up to the floor, so that the next round's elite breed towards it."""
    if min_speed == 0:
        return (candidate["score"],)
    speed = min(candidate[SPEED_FLOOR_OF[min_speed_of]], min_speed)
    return candidate["score"], -candidate["fall_rate"], speed


def confirmation_key(
    candidate: Mapping[str, Any], min_speed: float = 0.0, min_speed_of: str = "mean"
) -> tuple[float, ...]:
    """How a confirmation orders its candidates (descending): the clean ones by score, then the
    rest by fewer falls, then by the speed the floor holds to (up to the floor; any speed without
    one), so that a gait none of whose finalists held everywhere is the one that fell least."""
    speed = candidate[SPEED_FLOOR_OF[min_speed_of]]
    return (
        candidate["score"],
        -candidate["fall_rate"],
        min(speed, min_speed) if min_speed else speed,
    )


def _eligible(entry: Mapping[str, Any], min_speed: float, min_speed_of: str) -> bool:
    """Whether a scored candidate is ranked: none of its robots fell, and the speed floor held."""
    speed = entry[SPEED_FLOOR_OF[min_speed_of]]
    return entry["fall_rate"] == 0.0 and (min_speed == 0 or speed >= min_speed)


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
