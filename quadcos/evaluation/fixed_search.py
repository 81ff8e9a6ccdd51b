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
    alike half a cycle apart — mirror-symmetric gaits, which do not turn by construction. Each later round keeps the `elite` best so far and draws the rest around them (Gaussian, std
    10 % of each range in round 2, halved every round after). A candidate's score is its robots'
    mean episode reward (Eq. 13 summed over the episode) when none of them fell and their forward
    speed reaches `min_speed` (m/s; 0: any) — their mean's, or with `min_speed_of="slowest"` every
    robot's (under domain randomisation: the gait holds its speed on every robot it was drawn for,
    not only on average) — else −inf: the ranking is the paper's reward
    among gaits with zero falls (and that speed); `ranking_key` orders the rest. On a lane
    terrain every candidate runs on the same lanes (`candidate_lanes`: for `random:` courses, from the gentlest to the
    steepest), so that no candidate is ranked up for the easier course it was given.

    `on_round` is called after each round with its entry of "rounds".

    Returns:
      {"format", "ranking": the `top` best candidates (parameters, `policy` spec for --policy,
      score, fall_rate, mean_forward_speed, mean_max_abs_yaw, mean_lateral_drift, ...),
      "rounds": per round its wall time, candidates' mean fall rate, how many never fell, the
      best score and that candidate's speed; "setup"}.
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
    source = fixed_source(oscillator.FIXED_TROT, name="search")
    env = build_env(source, terrain, env_overrides)
    num_steps = math.ceil(seconds / env.dt - 1e-9)
    lower, upper = oscillator.parameter_bounds(env.config.period_min)
    # Candidates stay strictly inside the box (0.1 % of each range from its ends), so that the
    # best can be an action centre (`env.action_centre` needs a span on both sides).
    inner = 1e-3 * (upper - lower)
    rng = np.random.default_rng(seed)
    rank_key = functools.partial(ranking_key, min_speed=min_speed, min_speed_of=min_speed_of)
    num_envs = num_candidates * robots_per_candidate
    lanes = np.tile(candidate_lanes(env.terrain.num_lanes, robots_per_candidate), num_candidates)
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
        per_robot = np.repeat(candidates, robots_per_candidate, axis=0).astype(np.float32)

        def round_progress(done: int, total: int, round_index: int = round_index) -> None:
            if progress is not None:
                progress(round_index * total + done, rounds * total)

        result = rollout(
            env,
            source,
            num_envs=num_envs,
            num_steps=num_steps,
            seed=seed + round_index,
            act_params=per_robot,
            progress=round_progress,
            lanes=lanes,
        )
        episodes = episode_values(result.stats, env.dt, num_steps)
        for c, params in enumerate(candidates):
            group = episodes[c * robots_per_candidate : (c + 1) * robots_per_candidate]
            fall_rate = float(np.mean([e["fell"] for e in group]))
            mean_reward = float(np.mean([e["episode_reward"] for e in group]))
            speeds = [e["forward_speed"] for e in group]
            candidate = {
                "mean_forward_speed": float(np.mean(speeds)),
                "slowest_forward_speed": float(np.min(speeds)),
            }
            floor_speed = candidate[SPEED_FLOOR_OF[min_speed_of]]
            eligible = fall_rate == 0.0 and (min_speed == 0 or floor_speed >= min_speed)
            evaluated.append(
                {
                    "round": round_index + 1,
                    "parameters": dict(zip(PARAMETER_NAMES, map(float, params))),
                    "parameters_array": params,
                    "policy": FIXED_PREFIX + ",".join(f"{float(p):.6g}" for p in params),
                    "score": mean_reward if eligible else -math.inf,
                    "mean_episode_reward": mean_reward,
                    "fall_rate": fall_rate,
                    **candidate,
                    "mean_max_abs_yaw": float(np.mean([e["max_abs_yaw"] for e in group])),
                    "mean_max_abs_roll": float(np.mean([e["max_abs_roll"] for e in group])),
                    "mean_lateral_drift": float(np.mean([e["lateral_drift"] for e in group])),
                }
            )
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
        "num_without_falls": sum(math.isfinite(c["score"]) for c in evaluated),
        "num_evaluated": len(evaluated),
        "setup": {
            "terrain": env.terrain.spec,
            "num_candidates": num_candidates,
            "robots_per_candidate": robots_per_candidate,
            "lanes": lanes[:robots_per_candidate].tolist(),
            "rounds": rounds,
            "elite": elite,
            "seconds": num_steps * env.dt,
            "seed": seed,
            "include_trot": include_trot,
            "symmetric": symmetric,
            "min_speed": min_speed,
            "min_speed_of": min_speed_of,
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


def candidate_lanes(num_lanes: int, robots_per_candidate: int) -> np.ndarray:
    """The lanes of one candidate's robots: spread evenly from the first lane to the last (lane 0
    for all on a terrain without lanes)."""
    return np.rint(np.linspace(0, num_lanes - 1, robots_per_candidate)).astype(np.int32)


def _wrap(phase: np.ndarray, low: float, high: float) -> np.ndarray:
    """Shifts phases that left [low, high] by one cycle back in (the range spans two cycles)."""
    return np.where(
        phase < low, phase + 2 * np.pi, np.where(phase > high, phase - 2 * np.pi, phase)
    )
