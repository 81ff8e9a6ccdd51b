"""What the host loop does between compiled chunks besides training: the metrics window, the
run's wall clock, time budget and start-up times, stopping on SIGINT/SIGTERM and the progress
line."""

import json
import logging
import math
import pathlib
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any, TextIO

from quadcos._util import compile_clock, files

logger = logging.getLogger(__name__)


class Window:
    """Chunk metrics and training time since the last metrics row."""

    def __init__(self):
        self._sums: dict[str, float] = {}
        self._chunks = 0
        self._steps = 0
        self._seconds = 0.0

    def add(self, chunk_metrics: dict[str, Any], steps: int, seconds: float):
        for name, value in chunk_metrics.items():
            self._sums[name] = self._sums.get(name, 0.0) + float(value)
        self._chunks += 1
        self._steps += steps
        self._seconds += seconds

    def means(self) -> dict[str, float]:
        return {f"train/{name}": total / self._chunks for name, total in self._sums.items()}

    def steps_per_second(self) -> float:
        return self._steps / self._seconds if self._seconds > 0 else 0.0


class Clock:
    """Wall time of the run in seconds, continued across resumes."""

    def __init__(self, offset: float):
        self._start = time.monotonic() - offset

    def __call__(self) -> float:
        return time.monotonic() - self._start


def run_age(restored_s: float | None, started_at: float | None) -> float:
    """Seconds the run has lasted when its clock starts: a resumed run's recorded time, else the
    time since `started_at`."""
    if restored_s is not None:
        return restored_s
    return 0.0 if started_at is None else time.monotonic() - started_at


def deadline(max_seconds: float, started_at: float | None) -> float | None:
    """The `time.monotonic()` at which a run with a time budget of `max_seconds` (0: none) from
    `started_at` (default: now) ends."""
    if not max_seconds:
        return None
    return (time.monotonic() if started_at is None else started_at) + max_seconds


def actor_start_step(config: Any, gradient_steps: int, step: int) -> int | None:
    """The env step from which SAC's actor learns (trainer `config`: its `actor_warmup_steps`,
    `updates_per_step`, `num_envs`), the next chunk starting at `step` after `gradient_steps`
    updates; None where the critics' warm-up is behind it."""
    left = config.actor_warmup_steps - gradient_steps
    if left <= 0:
        return None
    return step + -(-left // config.updates_per_step) * config.num_envs


def warn_if_the_actor_starts_too_late(
    config: Any, gradient_steps: int, step: int, env_steps_per_s: float, deadline: float | None
) -> bool:
    """Warns, and says so, where at `env_steps_per_s` the critics' warm-up outlasts the time
    budget ending at `deadline` (`time.monotonic()`), so that no policy of the run would learn."""
    start = actor_start_step(config, gradient_steps, step)
    if deadline is None or start is None or env_steps_per_s <= 0:
        return False
    needed, left = (start - step) / env_steps_per_s, deadline - time.monotonic()
    if needed > left:
        logger.warning(
            "at %s env steps/s the actor learns from env step %s, in about %.0f s, past the time"
            " budget (sac.max_seconds %g) that ends in %.0f s: every policy would hold the"
            " actor's initial weights; give it more time or fewer warm-up updates"
            " (sac.actor_warmup_steps)",
            f"{env_steps_per_s:,.0f}",
            f"{start:,}",
            needed,
            config.max_seconds,
            max(left, 0.0),
        )
    return needed > left


class WarmUpWatch:
    """Until SAC's actor learns, and once: warns where at the wall pace from the first chunk's end
    (evaluations and checkpoints included) the critics' warm-up outlasts the time budget ending
    at `deadline` (None: no budget, nothing to watch)."""

    def __init__(self, config: Any, deadline: float | None):
        self._config, self._deadline = config, deadline
        self._watching = deadline is not None
        self._first: tuple[int, float] | None = None  # (env step, time) at the first chunk's end

    def after_chunk(self, step: int, gradient_steps: Callable[[], int]) -> None:
        """After the chunk that ended at env step `step`; `gradient_steps` reads the state's."""
        if not self._watching:
            return
        now = time.monotonic()
        if self._first is None:
            self._first = (step, now)
            return
        updates = gradient_steps()
        pace = (step - self._first[0]) / max(now - self._first[1], 1e-9)
        late = warn_if_the_actor_starts_too_late(self._config, updates, step, pace, self._deadline)
        self._watching = not late and actor_start_step(self._config, updates, step) is not None


def budget_spent(
    deadline: float | None,
    now: float,
    *,
    chunk_s: float,
    evaluation_s: float,
    save_s: float,
    evaluating_now: bool,
    saving_now: bool,
) -> bool:
    """Whether a run with a time budget ending at `deadline` (None: no budget) ends with the chunk
    that just ended: when what is due now (this chunk's evaluation, `evaluating_now`, and
    checkpoint, `saving_now`), another chunk and then the final evaluation and checkpoint would
    end past it, so that the final evaluation, `policy_best` and the checkpoint come within it.
    Each part counts as long as it last took: `chunk_s`, `evaluation_s` (with writing
    `policy_best`), `save_s`."""
    if deadline is None:
        return False
    due_now = evaluating_now * evaluation_s + saving_now * save_s
    return now + due_now + chunk_s + evaluation_s + save_s >= deadline


class StartUp:
    """Seconds from a run's start (`started_at`, a `time.monotonic()`; None: now) to each event
    of its start-up, in the order they happened: where the time to the first training step goes
    (imports, gait search, env, compiled programs, prefill), and of each event's share how much
    JAX spent tracing, lowering and compiling or loading programs (`compile_clock`). `save`
    writes both to `path`, if one is set: {"seconds": {event: s}, "compile": {event: {...}}}."""

    FILE = "startup.json"

    def __init__(self, started_at: float | None = None):
        self._start = time.monotonic() if started_at is None else started_at
        self.seconds: dict[str, float] = {}
        self.compile: dict[str, dict[str, float]] = {}
        self.path: pathlib.Path | None = None
        compile_clock.start()
        self._compile_before = compile_clock.totals()

    def mark(self, event: str) -> None:
        self.seconds[event] = round(time.monotonic() - self._start, 3)
        self.compile[event] = compile_clock.since(self._compile_before)
        self._compile_before = compile_clock.totals()

    def save(self) -> None:
        if self.path is not None:
            record = {"seconds": self.seconds, "compile": self.compile}
            files.atomic_write_text(self.path, json.dumps(record, indent=1) + "\n")


class SignalStop:
    """Turns SIGINT/SIGTERM into a request to stop after the current chunk.

    A second SIGINT raises KeyboardInterrupt at once. Handlers can only be
    installed from the main thread; elsewhere signals keep their handlers.
    """

    def __init__(self):
        self.signal_name: str | None = None
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> "SignalStop":
        if threading.current_thread() is threading.main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc_info) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)

    def _handle(self, signum: int, frame: Any) -> None:
        del frame
        if self.signal_name is not None and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self.signal_name = signal.Signals(signum).name
        logger.warning(
            "%s received: stopping after the current chunk (SIGINT again aborts)",
            self.signal_name,
        )


class Progress:
    """One redrawn status line on a terminal, one line per row otherwise; its ETA is the sooner of
    num_timesteps at the current rate and the time budget's `deadline` (`time.monotonic()`)."""

    _REDRAW_SECONDS = 0.2

    def __init__(
        self,
        total_steps: int,
        enabled: bool,
        bar: bool = True,
        stream: TextIO | None = None,
        deadline: float | None = None,
    ):
        self._total = total_steps
        self._deadline = deadline
        self._stream = sys.stderr if stream is None else stream
        self._enabled = enabled
        self._tty = enabled and bar and self._stream.isatty()
        self._last_redraw = -math.inf

    def update(self, step: int, steps_per_second: float, history: list[dict[str, Any]]) -> None:
        now = time.monotonic()
        if not self._tty or now - self._last_redraw < self._REDRAW_SECONDS:
            return
        self._last_redraw = now
        fraction = min(step / self._total, 1.0)
        bar = "#" * int(24 * fraction)
        self._stream.write(
            f"\r[{bar:<24}] {step:,}/{max(step, self._total):,} env steps"
            f"  {steps_per_second:,.0f}/s"
            f"  eval reward {_last_reward(history)}"
            f"  ETA {self._eta(step, steps_per_second)}\033[K"
        )
        self._stream.flush()

    def log_row(self, row: dict[str, Any]) -> None:
        if not self._enabled or self._tty:
            return
        steps_per_second = row.get("env_steps_per_s", 0.0)
        # Env metrics that a generic Brax env may not log.
        extras = "".join(
            f"  {label} {row[key]:.3g}{unit}"
            for key, label, unit in (
                ("eval/forward_speed", "speed", " m/s"),
                ("eval/fall_rate", "fall rate", ""),
                ("eval/speed_tracking_rms", "speed RMS", " m/s"),
                ("eval/yaw_rate_tracking_rms", "yaw-rate RMS", " rad/s"),
                ("eval/mean_max_abs_roll", "roll", " rad"),
            )
            if key in row
        )
        end = max(row["step"], self._total)  # the last chunk may end past num_timesteps
        self._stream.write(
            f"step {row['step']:,}/{end:,}"
            f"  {steps_per_second:,.0f} env steps/s"
            f"  eval reward {_last_reward([row])}{extras}"
            f"  ETA {self._eta(row['step'], steps_per_second)}\n"
        )
        self._stream.flush()

    def _eta(self, step: int, steps_per_second: float) -> str:
        seconds = max(self._total - step, 0) / steps_per_second if steps_per_second > 0 else None
        if self._deadline is not None:
            left = max(self._deadline - time.monotonic(), 0.0)
            seconds = left if seconds is None else min(seconds, left)
        if seconds is None:
            return "-"
        seconds = int(seconds)
        return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"

    def close(self) -> None:
        if self._tty:
            self._stream.write("\n")
            self._stream.flush()


def _last_reward(history: list[dict[str, Any]]) -> str:
    if not history:
        return "-"
    return f"{history[-1]['eval/episode_reward']:.4g}"


