"""`policy_best/`: the policy of a run's best training-time evaluation (`keep_best_policy`)."""

import math
from pathlib import Path
from typing import Any

from quadcos.training import policy as policy_lib
from quadcos.training import sac

# The training-time evaluation metrics that rank a run's policies for `keep_best_policy`: the
# episode reward, or (`best_policy_by` "tracking" or "gait", robots that follow commands) their
# tracking, against fixed targets or against the run's step-0 evaluation (its gait).
_BEST_BY = "eval/episode_reward"
_FALLS = "eval/fall_rate"
TRACKING = ("eval/speed_tracking_rms", "eval/yaw_rate_tracking_rms")
ATTITUDE = ("eval/mean_max_abs_roll", "eval/mean_max_abs_pitch_error")  # rad
RANKS = ("reward", "tracking", "gait")  # what `best_policy_by` may name
TRACKED = ("tracking", "gait")  # the ranks that need robots that follow commands


def rank(
    row: dict[str, Any],
    max_fall_rate: float,
    by: str = "reward",
    targets: tuple[float, float] | dict[str, float] = (0.10, 0.15),
    max_attitude: float = 0.0,
) -> tuple[bool, float]:
    """How an evaluation row ranks for `policy_best` (higher is better): whether it falls in at
    most `max_fall_rate` of its episodes (and, `max_attitude` > 0, rolls and pitches off the
    slope by at most `max_attitude` rad, mean of the episodes' peaks; a row that measured neither
    counts as within), then its episode reward (`by` "reward"), or (`by` "tracking") minus its
    worse tracking relative to `targets` (m/s, rad/s): −max(speed RMS / targets[0], yaw-rate RMS
    / targets[1]), > −1 where both are within their targets; `targets` may name the row's keys
    instead ({key: target}: the worst of those ratios). NaN where the row has no such
    evaluation."""
    if by == "reward":
        value = row.get(_BEST_BY, math.nan)
    else:
        if not isinstance(targets, dict):
            targets = dict(zip(TRACKING, targets))
        ratios = [_value(row, key) / target for key, target in targets.items()]
        value = -max(ratios) if all(math.isfinite(r) for r in ratios) else math.nan
    level = max_attitude <= 0 or all(row.get(key, 0.0) <= max_attitude for key in ATTITUDE)
    return row.get(_FALLS, 0.0) <= max_fall_rate and level, value


def _value(row: dict[str, Any], key: str) -> float:
    """A row's value of `key`; NaN where it has none (a resumed run's metrics.jsonl keeps NaN
    as null)."""
    value = row.get(key)
    return math.nan if value is None else value


def cells(row: dict[str, Any]) -> dict[str, float]:
    """A commanded evaluation's tracking RMS: pooled, and under each condition it measured
    (`randomization.eval_conditions`: `eval/<condition>/speed_tracking_rms`, ...); NaN where a
    condition closed no tracking window."""
    ends = tuple("/" + key.removeprefix("eval/") for key in TRACKING)
    return {key: _value(row, key) for key in row if key.startswith("eval/") and key.endswith(ends)}


def condition_falls(row: dict[str, Any]) -> dict[str, float]:
    """An evaluation's fall rate under each condition it measured (none: {})."""
    return {
        key: _value(row, key)
        for key in row
        if key.startswith("eval/") and key.endswith("/fall_rate") and key != _FALLS
    }


class BestPolicy:
    """The policy of the best training-time evaluation of a run (`keep_best_policy`).

    An evaluation whose fall rate is at most `max_fall_rate` (and whose attitude is within
    `max_attitude`, where > 0: `rank`) beats every one beyond them; among
    evaluations on the same side, the higher episode reward wins (`max_fall_rate` 1: reward alone),
    or with `by` "tracking" the better command tracking (`rank`), or with `by` "gait" the tracking
    rank with the run's step-0 evaluation's own tracking RMS as the targets: the policy that
    improves most on the gait it started from in the worse of the two (the step-0 row scores −1;
    a row before it, none). Where the evaluations measured conditions
    (`randomization.eval_conditions`), every condition's speed and yaw-rate RMS is a target too,
    and a row that falls in more of a condition's episodes than step 0 is beyond the bounds: the
    policy must beat its gait in each.
    `offer` saves the state's policy to `directory` when its evaluation beats every earlier one of
    the run (rows before a resume included), its step, reward and fall rate added to the saved
    config under "best_of_run" (with `written_at_s`, the run's wall time at the write, if given).
    """

    def __init__(
        self,
        directory: Path,
        spec: policy_lib.PolicySpec,
        run_info: dict[str, Any],
        history: list[dict[str, Any]],
        max_fall_rate: float = 1.0,
        by: str = "reward",
        targets: tuple[float, float] = (0.10, 0.15),
        max_attitude: float = 0.0,
    ):
        self.directory = directory
        self._spec = spec
        self._run_info = run_info
        self._by, self._max_fall_rate, self._targets = by, max_fall_rate, targets
        self._max_attitude = max_attitude
        if by == "gait":
            self._targets = None  # the step-0 evaluation's tracking, once seen
            self._gait_falls: dict[str, float] = {}
        ranked = (self._rank(row) for row in history)
        self.rank = max((r for r in ranked if math.isfinite(r[1])), default=None)

    def _rank(self, row: dict[str, Any]) -> tuple[bool, float]:
        if self._by != "gait":
            return rank(row, self._max_fall_rate, self._by, self._targets, self._max_attitude)
        if row.get("step") == 0 and all(_value(row, key) > 0 for key in TRACKING):
            self._targets = {k: v for k, v in cells(row).items() if v > 0}  # NaN: no windows
            self._gait_falls = condition_falls(row)
        if self._targets is None:
            within = rank(row, self._max_fall_rate, max_attitude=self._max_attitude)[0]
            return within, math.nan
        within, value = rank(
            row, self._max_fall_rate, "tracking", self._targets, self._max_attitude
        )
        falls = condition_falls(row)
        no_more = all(falls.get(key, math.inf) <= gait for key, gait in self._gait_falls.items())
        return within and no_more, value

    @property
    def score(self) -> float:
        """The best evaluation's reward, or its tracking score (`rank`)."""
        return -math.inf if self.rank is None else self.rank[1]

    def describe(self) -> str:
        """The best evaluation's rank in words, for a progress line."""
        if self.rank is None:
            return "none yet"
        if self._by == "reward":
            return f"episode reward {self.score:,.0f}"
        of = "its step-0 gait's" if self._by == "gait" else "the targets"
        return f"tracking {-self.score:.3f} of {of} in the worse of speed and yaw rate"

    def offer(
        self,
        state: sac.TrainingState | policy_lib.PolicyPart,
        row: dict[str, Any],
        written_at_s: float | None = None,
    ) -> bool:
        """Saves the policy if `row` (its evaluation) is the best so far; True if it did."""
        ranked = self._rank(row)
        if not math.isfinite(ranked[1]) or (self.rank is not None and not ranked > self.rank):
            return False
        self.rank = ranked
        best_of_run = {"step": int(row["step"])} | {
            key: float(row[key]) for key in (_BEST_BY, *TRACKING, *ATTITUDE) if key in row
        }
        best_of_run[_FALLS] = float(row.get(_FALLS, 0.0))
        if written_at_s is not None:
            best_of_run["written_at_s"] = round(written_at_s, 3)
        config = {**self._run_info, "best_of_run": best_of_run}
        policy_lib.save_policy(
            self.directory, policy_lib.Policy.from_training_state(state, self._spec, config)
        )
        return True
