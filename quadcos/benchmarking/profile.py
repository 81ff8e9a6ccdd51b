"""`python -m quadcos.benchmarking.profile DIR`: where a profiled run's time goes.

    python -m quadcos.bench --only train --train_rows 4096x8192x1 --profile_dir prof/
    python -m quadcos.benchmarking.profile prof/4096x8192x1 --top 15

Reads the Perfetto trace that `jax.profiler.trace(..., create_perfetto_trace=True)` wrote under DIR
(the newest `perfetto_trace.json.gz`) and sums the duration of the complete events ("X") of each
timeline — a device's op or kernel lines (`/device:GPU:N`), the host's XLA threads and Python —
by name and by kind (Warp kernels, SAC's dense layers, collectives, copies, other fusions). Per
timeline: its busy seconds against the trace's span, and the heaviest names. The busy share of a
device's timeline is how much of the wall time the GPU computed; the rest it waited on the host.
`--gaps`: where it waited — the device's idle gaps by length, and the idle time by what the
host's busiest thread was doing in each gap (its innermost event) and by the kernels either side.
"""

import argparse
import bisect
import collections
import dataclasses
import gzip
import json
import pathlib
import sys
from collections.abc import Sequence
from typing import Any

from quadcos._util import cli

_PROG = "quadcos.benchmarking.profile"
# Kinds of op or kernel, by a piece of the lower-cased name; the first that matches.
KINDS = (
    ("warp (physics)", ("warp", "mujoco", "mjx", "_kernel", "custom-call", "custom_call")),
    (
        "collective",
        ("all-reduce", "allreduce", "all-gather", "allgather", "nccl", "reduce-scatter"),
    ),
    ("matmul", ("gemm", "dot", "cublas", "matmul", "triton")),
    ("copy", ("copy", "memcpy", "memset", "transpose")),
    ("fusion", ("fusion",)),
)


@dataclasses.dataclass(frozen=True)
class Timeline:
    """One thread of the trace: its process and thread names, busy time and heaviest names."""

    process: str
    thread: str
    busy_s: float
    events: int
    by_name: dict[str, float]
    by_kind: dict[str, float]


def kind_of(name: str) -> str:
    lowered = name.lower()
    for kind, pieces in KINDS:
        if any(piece in lowered for piece in pieces):
            return kind
    return "other"


def trace_file(folder: pathlib.Path) -> pathlib.Path:
    """The newest Perfetto trace under `folder` (or `folder` itself, a .json.gz)."""
    if folder.is_file():
        return folder
    found = sorted(folder.rglob("perfetto_trace.json.gz"), key=lambda path: path.stat().st_mtime)
    if not found:
        raise cli.UsageError(f"{folder}: no perfetto_trace.json.gz under it (jax.profiler.trace)")
    return found[-1]


def read_events(path: pathlib.Path) -> list[dict[str, Any]]:
    try:
        with gzip.open(path, "rt") as stream:
            data = json.load(stream)
    except (OSError, ValueError, EOFError) as error:
        raise cli.UsageError(f"{path}: not a readable trace ({error})") from None
    return data["traceEvents"] if isinstance(data, dict) else data


def names(events: Sequence[dict[str, Any]]) -> tuple[dict[Any, str], dict[tuple[Any, Any], str]]:
    """The trace's process names by pid and thread names by (pid, tid), from its metadata."""
    processes, threads = {}, {}
    for event in events:
        if event.get("ph") == "M" and event.get("name") == "process_name":
            processes[event["pid"]] = event["args"]["name"]
        elif event.get("ph") == "M" and event.get("name") == "thread_name":
            threads[(event["pid"], event["tid"])] = event["args"]["name"]
    return processes, threads


def timelines(events: Sequence[dict[str, Any]]) -> tuple[float, list[Timeline]]:
    """The trace's span in seconds and its timelines, busiest first. Nested events of a thread
    (a module and its ops) are counted once: only events that start after the previous one on
    that thread ended add to its busy time; every event counts towards its name and kind."""
    processes, threads = names(events)
    complete = sorted(
        (event for event in events if event.get("ph") == "X" and "dur" in event),
        key=lambda event: event["ts"],
    )
    if not complete:
        return 0.0, []
    span_us = max(e["ts"] + e["dur"] for e in complete) - min(e["ts"] for e in complete)
    grouped: dict[tuple[Any, Any], list[dict[str, Any]]] = collections.defaultdict(list)
    for event in complete:
        grouped[(event["pid"], event["tid"])].append(event)
    found = []
    for (pid, tid), group in grouped.items():
        busy_us, end_us = 0.0, -float("inf")
        by_name: dict[str, float] = collections.Counter()
        by_kind: dict[str, float] = collections.Counter()
        for event in group:
            start, stop = event["ts"], event["ts"] + event["dur"]
            if stop > end_us:
                busy_us += stop - max(start, end_us)
                end_us = stop
            by_name[event["name"]] += event["dur"] / 1e6
            by_kind[kind_of(event["name"])] += event["dur"] / 1e6
        found.append(
            Timeline(
                process=processes.get(pid, str(pid)),
                thread=threads.get((pid, tid), str(tid)),
                busy_s=busy_us / 1e6,
                events=len(group),
                by_name=dict(by_name),
                by_kind=dict(by_kind),
            )
        )
    return span_us / 1e6, sorted(found, key=lambda timeline: -timeline.busy_s)


def report(span_s: float, found: Sequence[Timeline], top: int) -> str:
    """Markdown: every timeline's busy share, then the heaviest kinds and names of the busiest
    device timelines (or of the busiest timelines where no device was traced)."""
    lines = [
        f"trace span {span_s:.3f} s",
        "",
        "| process | thread | events | busy s | busy / span |",
        "|---|---|---:|---:|---:|",
    ]
    for timeline in found:
        share = timeline.busy_s / span_s if span_s else 0.0
        lines.append(
            f"| {timeline.process} | {timeline.thread} | {timeline.events}"
            f" | {timeline.busy_s:.3f} | {share:.2f} |"
        )
    devices = [t for t in found if t.process.startswith("/device:")] or list(found)
    for timeline in devices[:3]:
        total = sum(timeline.by_name.values()) or 1.0
        lines += ["", f"**{timeline.process} / {timeline.thread}**", ""]
        lines += ["| kind or name | s | share |", "|---|---:|---:|"]
        for kind, seconds in sorted(timeline.by_kind.items(), key=lambda item: -item[1]):
            lines.append(f"| kind: {kind} | {seconds:.4f} | {seconds / total:.2f} |")
        heaviest = sorted(timeline.by_name.items(), key=lambda item: -item[1])[:top]
        for name, seconds in heaviest:
            lines.append(f"| {name[:80]} | {seconds:.4f} | {seconds / total:.2f} |")
    return "\n".join(lines)


# Upper bounds (µs) of the idle-gap length classes.
GAP_CLASSES_US = (2.0, 5.0, 10.0, 50.0, 200.0, 1000.0, float("inf"))


@dataclasses.dataclass(frozen=True)
class Idle:
    """A device timeline's idle gaps: counts and seconds per length class (`GAP_CLASSES_US`), and
    the seconds of the gaps of at least `min_gap_us` by the host's innermost event at each gap's
    middle ("(host idle)" where it had none) and by the device's names either side."""

    process: str
    host_thread: str
    counts: tuple[int, ...]
    seconds: tuple[float, ...]
    by_host: dict[str, float]
    by_neighbours: dict[str, float]


def _complete(events: Sequence[dict[str, Any]]) -> dict[tuple[Any, Any], list[dict[str, Any]]]:
    grouped: dict[tuple[Any, Any], list[dict[str, Any]]] = collections.defaultdict(list)
    for event in events:
        if event.get("ph") == "X" and "dur" in event:
            grouped[(event["pid"], event["tid"])].append(event)
    for group in grouped.values():
        group.sort(key=lambda event: event["ts"])
    return grouped


def _innermost(group: Sequence[dict[str, Any]], starts: Sequence[float], at: float) -> str:
    """The name of the latest-starting event of `group` (sorted by start) that spans `at`."""
    index = bisect.bisect_right(starts, at) - 1
    for event in reversed(group[max(index - 5_000, 0) : index + 1]):
        if event["ts"] + event["dur"] >= at:
            return event["name"]
    return "(host idle)"


def idle_gaps(events: Sequence[dict[str, Any]], min_gap_us: float = 10.0) -> list[Idle]:
    """The idle gaps of every device timeline (`/device:`), against the host thread with the most
    events (the one that runs the program's thunks and callbacks)."""
    processes, threads = names(events)
    grouped = _complete(events)
    hosts = [key for key in grouped if not processes.get(key[0], "").startswith("/device:")]
    host = max(hosts, key=lambda key: len(grouped[key]), default=None)
    host_events = grouped[host] if host is not None else []
    host_starts = [event["ts"] for event in host_events]
    found = []
    for key, group in grouped.items():
        if not processes.get(key[0], "").startswith("/device:") or len(group) < 2:
            continue
        counts = [0] * len(GAP_CLASSES_US)
        seconds = [0.0] * len(GAP_CLASSES_US)
        by_host: dict[str, float] = collections.Counter()
        by_neighbours: dict[str, float] = collections.Counter()
        end, previous = group[0]["ts"] + group[0]["dur"], group[0]["name"]
        for event in group[1:]:
            gap = event["ts"] - end
            if gap > 0:
                index = bisect.bisect_left(GAP_CLASSES_US, gap)
                counts[index] += 1
                seconds[index] += gap / 1e6
                if gap >= min_gap_us:
                    by_host[_innermost(host_events, host_starts, end + gap / 2)] += gap / 1e6
                    by_neighbours[f"{previous[:50]} → {event['name'][:50]}"] += gap / 1e6
            if event["ts"] + event["dur"] >= end:
                end, previous = event["ts"] + event["dur"], event["name"]
        found.append(
            Idle(
                process=processes.get(key[0], str(key[0])),
                host_thread=threads.get(host, str(host)) if host is not None else "-",
                counts=tuple(counts),
                seconds=tuple(seconds),
                by_host=dict(by_host),
                by_neighbours=dict(by_neighbours),
            )
        )
    return found


def idle_report(found: Sequence[Idle], top: int, min_gap_us: float = 10.0) -> str:
    """Markdown: per device timeline, its gaps by length, then the heaviest host states and
    neighbours of the gaps of at least `min_gap_us`."""
    lines = []
    for idle in found:
        lines += ["", f"**idle gaps of {idle.process}**", ""]
        lines += ["| gap length (µs) | gaps | idle s |", "|---|---:|---:|"]
        lower = 0.0
        for upper, count, seconds in zip(GAP_CLASSES_US, idle.counts, idle.seconds):
            lines.append(f"| {lower:g}–{upper:g} | {count} | {seconds:.4f} |")
            lower = upper
        for title, table in (
            (f"host thread {idle.host_thread}'s innermost event", idle.by_host),
            ("device names before → after", idle.by_neighbours),
        ):
            lines += ["", f"| gaps ≥ {min_gap_us:g} µs by {title} | idle s |", "|---|---:|"]
            for name, seconds in sorted(table.items(), key=lambda item: -item[1])[:top]:
                lines.append(f"| {name[:110]} | {seconds:.4f} |")
    return "\n".join(lines)


def summarize(folder: pathlib.Path, top: int = 15, gaps: bool = False) -> str:
    events = read_events(trace_file(folder))
    span_s, found = timelines(events)
    text = report(span_s, found, top)
    return text + "\n" + idle_report(idle_gaps(events), top) if gaps else text


def main(argv: Sequence[str] | None = None) -> int:
    parser = cli.raising(argparse.ArgumentParser(prog=f"python -m {_PROG}", description=__doc__))
    parser.add_argument("folder", type=pathlib.Path, help="a jax.profiler.trace folder or trace")
    parser.add_argument("--top", type=int, default=15, help="names listed per device timeline")
    parser.add_argument(
        "--gaps",
        action="store_true",
        help="also the device's idle gaps and the host's state in them",
    )
    try:
        args = parser.parse_args(argv)
        print(summarize(args.folder, args.top, args.gaps))
    except cli.UsageError as error:
        cli.print_error(_PROG, error)
        return cli.EXIT_USAGE
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
