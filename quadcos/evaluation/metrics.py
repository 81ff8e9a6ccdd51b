"""What an evaluation reports per episode and over all of them: success, falls, speed, drift,
attitude, the slope estimate's error, the reward (Eq. 13) with its terms and, from a
`GaitEpisodeStats`, gait quality: command tracking, foot slip, cost of transport and torque."""

import math
from collections.abc import Mapping, Sequence
from typing import Any

import jax
import numpy as np

from quadcos.equations import reward
from quadcos.evaluation.rollout import GRAVITY, EpisodeStats, GaitEpisodeStats


def episode_values(stats: EpisodeStats, dt: float, num_steps: int) -> list[dict[str, Any]]:
    """Per-episode values from host EpisodeStats; times in s, lengths in m, angles in rad; with
    `GaitEpisodeStats`, the gait quality of `gait_values` too."""
    episodes = []
    for i in range(len(stats.steps)):
        steps = int(stats.steps[i])
        seconds = steps * dt
        distance = float(stats.x[i] - stats.start_x[i])
        fell, finished = bool(stats.fell[i]), bool(stats.finished[i])
        episodes.append(
            {
                "index": i,
                "lane": int(stats.lane[i]),
                "success": None,  # filled by evaluate (depends on the terrain)
                "fell": fell,
                "fall_time_s": seconds if fell else None,
                "finished_course": finished,
                "finish_time_s": seconds if finished else None,
                "seconds": seconds,
                "timed_out": steps >= num_steps and not fell and not finished,
                "distance": distance,
                "forward_speed": distance / seconds if steps else 0.0,
                "lateral_drift": float(abs(stats.y[i] - stats.start_y[i])),
                "max_lateral_deviation": float(stats.max_lateral_deviation[i]),
                "max_abs_roll": float(stats.max_abs_roll[i]),
                "max_abs_yaw": float(stats.max_abs_yaw[i]),
                "max_abs_pitch_error": float(stats.max_abs_pitch_error[i]),
                "slope_error_rms": math.sqrt(float(stats.slope_sq_error[i]) / steps)
                if steps
                else None,
                "episode_reward": float(stats.episode_reward[i]),
                "reward_terms": {k: float(v[i]) for k, v in stats.reward_terms.items()},
                "final_x": float(stats.x[i]),
                "final_y": float(stats.y[i]),
                **(gait_values(stats, i) if isinstance(stats, GaitEpisodeStats) else {}),
            }
        )
    return episodes


def _ratio(numerator: float, denominator: float) -> float | None:
    """numerator / denominator where that is finite and the denominator > 0, else None."""
    value = numerator / denominator if denominator > 0 else math.nan
    return value if math.isfinite(value) else None


def gait_values(stats: GaitEpisodeStats, i: int) -> dict[str, Any]:
    """Episode i's gait quality: `speed_tracking_rms` (m/s) and `yaw_rate_tracking_rms` (rad/s)
    of the speed and yaw rate averaged over each of its closed tracking windows
    (`quadcos.env.tracking.TRACKING_WINDOW_S`; None without commands or a closed window), `foot_slip_m_per_s` (the mean, over its steps with a
    foot in contact at both ends, of the horizontal speed of the feet in contact),
    `cost_of_transport` (Σ|τ·q̇|·dt / (m g · horizontal distance travelled)) and
    `peak_joint_torque_ratio` (the largest |τ| / torque limit of any leg joint at any step; None
    where no joint has a finite limit). None where a value is undefined (no step, no distance)."""
    tracking = stats.tracking
    steps, windows = int(stats.steps[i]), int(tracking.windows[i])
    return {
        "speed_tracking_rms": _rms(tracking.speed_sq_error[i], windows)
        if stats.commanded
        else None,
        "yaw_rate_tracking_rms": _rms(tracking.yaw_rate_sq_error[i], windows)
        if stats.commanded
        else None,
        "foot_slip_m_per_s": _ratio(float(stats.slip_sum[i]), int(stats.slip_steps[i])),
        "cost_of_transport": _ratio(
            float(stats.energy[i]), stats.mass * GRAVITY * float(stats.path[i])
        ),
        "peak_joint_torque_ratio": _ratio(float(stats.peak_torque_ratio[i]), 1.0 if steps else 0),
    }


def _rms(sum_of_squares: Any, count: int) -> float | None:
    return _ratio(math.sqrt(max(float(sum_of_squares), 0.0)), math.sqrt(count))


def gait_aggregate(stats: GaitEpisodeStats) -> dict[str, Any]:
    """Gait quality over all episodes, every step of every episode pooled: the tracking RMS
    (sqrt(Σ squared window errors / Σ windows); None without commands), the foot slip (Σ / Σ steps with
    contact), the cost of transport (Σ energy / (m g Σ distance) over the episodes that did not
    fall: a fall moves nothing, and one whose physics blew up before it ended outweighs a thousand
    walks); `peak_joint_torque_ratio`: the mean of the episodes' peaks. Episodes with a non-finite
    value are left out of it."""

    def pooled(values: Any, counts: Any, keep: Any = True) -> tuple[float, float]:
        values, counts = np.asarray(values, dtype=float), np.asarray(counts, dtype=float)
        kept = np.isfinite(values) & keep
        return float(values[kept].sum()), float(counts[kept].sum())

    tracking = stats.tracking
    peaks = np.asarray(stats.peak_torque_ratio, dtype=float)
    peaks = peaks[np.isfinite(peaks) & (np.asarray(stats.steps) > 0)]
    energy, distance = pooled(stats.energy, stats.path, ~np.asarray(stats.fell, dtype=bool))
    return {
        "speed_tracking_rms": _rms(*pooled(tracking.speed_sq_error, tracking.windows))
        if stats.commanded
        else None,
        "yaw_rate_tracking_rms": _rms(*pooled(tracking.yaw_rate_sq_error, tracking.windows))
        if stats.commanded
        else None,
        "foot_slip_m_per_s": _ratio(*pooled(stats.slip_sum, stats.slip_steps)),
        "cost_of_transport": _ratio(energy, stats.mass * GRAVITY * distance),
        "peak_joint_torque_ratio": float(peaks.mean()) if peaks.size else None,
    }


def aggregate(episodes: Sequence[Mapping[str, Any]], stats: EpisodeStats) -> dict[str, Any]:
    """Aggregates over episodes (means of per-episode values unless said otherwise).

    An episode whose physics diverged (a non-finite position: the env ended it as a fall; the
    rollout makes a blow-up that stayed finite NaN) is counted in `diverged_rate` and in the
    rates, and left out of the means of values it made non-finite, so that one blown-up robot does not turn a thousand episodes' speed into NaN.
    `slope_error_rms` pools every step of every episode with a finite error: sqrt(Σ squared errors
    / Σ steps). A mean over no finite value is NaN (null in JSON).
    """

    def finite_mean(values: Sequence[float]) -> float:
        values = np.asarray(values, dtype=float)
        values = values[np.isfinite(values)]
        return float(values.mean()) if values.size else math.nan

    def mean(key: str) -> float:
        return finite_mean([float(e[key]) for e in episodes])

    speeds = np.array([e["forward_speed"] for e in episodes], dtype=float)
    finite_speeds = speeds[np.isfinite(speeds)]
    squared = np.asarray(stats.slope_sq_error, dtype=float)
    pooled = np.isfinite(squared)
    total_steps = int(np.sum(np.asarray(stats.steps)[pooled]))
    return {
        "num_episodes": len(episodes),
        "success_rate": mean("success"),
        "fall_rate": mean("fell"),
        "diverged_rate": float(np.mean([not math.isfinite(e["distance"]) for e in episodes])),
        "course_completion_rate": mean("finished_course"),
        "mean_forward_speed": mean("forward_speed"),
        "std_forward_speed": float(finite_speeds.std()) if finite_speeds.size else math.nan,
        "mean_distance": mean("distance"),
        "mean_seconds": mean("seconds"),
        "mean_max_abs_roll": mean("max_abs_roll"),
        "mean_max_abs_yaw": mean("max_abs_yaw"),
        "mean_max_abs_pitch_error": mean("max_abs_pitch_error"),
        "mean_lateral_drift": mean("lateral_drift"),
        "mean_max_lateral_deviation": mean("max_lateral_deviation"),
        "slope_error_rms": math.sqrt(float(np.sum(squared[pooled])) / total_steps)
        if total_steps
        else None,
        "mean_episode_reward": mean("episode_reward"),
        "mean_reward_terms": {
            term: finite_mean([e["reward_terms"][term] for e in episodes])
            for term in reward.TERM_NAMES
        },
        **(gait_aggregate(stats) if isinstance(stats, GaitEpisodeStats) else {}),
    }


def per_course(
    episodes: Sequence[Mapping[str, Any]], stats: EpisodeStats, lane_names: Sequence[str]
) -> dict[str, Any]:
    """Aggregates per lane of a lane terrain ({name: aggregate}) and over the courses: the mean and
    the worst course's success rate, and how many lanes the terrain has (`lanes`: more than
    `courses` holds where fewer episodes than lanes ran)."""
    courses = {}
    for lane, name in enumerate(lane_names):
        picked = [e for e in episodes if e["lane"] == lane]
        if picked:
            mask = np.asarray(stats.lane) == lane
            subset = jax.tree.map(lambda array: np.asarray(array)[mask], stats)
            courses[name] = aggregate(picked, subset)
    rates = {name: course["success_rate"] for name, course in courses.items()}
    worst = min(rates, key=rates.get)
    return {
        "courses": courses,
        "lanes": len(lane_names),
        "mean_course_success_rate": float(np.mean(list(rates.values()))),
        "worst_course": worst,
        "worst_course_success_rate": rates[worst],
    }
