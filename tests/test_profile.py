"""`quadcos.benchmarking.profile`: a jax.profiler trace summed per timeline, name and kind."""

import gzip
import json
import pathlib
import subprocess
import sys

import jax
import jax.numpy as jnp
import pytest

from quadcos.benchmarking import profile


def _events():
    meta = [
        {"ph": "M", "name": "process_name", "pid": 1, "args": {"name": "/device:GPU:0"}},
        {"ph": "M", "name": "thread_name", "pid": 1, "tid": 7, "args": {"name": "XLA Ops"}},
    ]
    ops = [  # a module holding two ops, then a gap, then an all-reduce
        {"ph": "X", "pid": 1, "tid": 7, "ts": 0, "dur": 100, "name": "jit__train_chunk"},
        {"ph": "X", "pid": 1, "tid": 7, "ts": 10, "dur": 40, "name": "mjx_warp_step_kernel"},
        {"ph": "X", "pid": 1, "tid": 7, "ts": 50, "dur": 30, "name": "gemm_fusion.3"},
        {"ph": "X", "pid": 1, "tid": 7, "ts": 300, "dur": 100, "name": "all-reduce.1"},
    ]
    return meta + ops


def test_busy_time_counts_nested_events_once_and_kinds_name_the_work():
    span_s, found = profile.timelines(_events())
    assert span_s == pytest.approx(400e-6)
    (ops,) = found
    assert (ops.process, ops.thread, ops.events) == ("/device:GPU:0", "XLA Ops", 4)
    assert ops.busy_s == pytest.approx(200e-6)  # the module's 100 µs and the all-reduce's 100
    assert ops.by_kind["warp (physics)"] == pytest.approx(40e-6)
    assert ops.by_kind["matmul"] == pytest.approx(30e-6)
    assert ops.by_kind["collective"] == pytest.approx(100e-6)
    text = profile.report(span_s, found, top=2)
    assert "| /device:GPU:0 | XLA Ops | 4 | 0.000 | 0.50 |" in text
    assert "all-reduce.1" in text and "gemm_fusion.3" not in text  # only the top 2 names


def test_a_real_trace_is_read(tmp_path):
    step = jax.jit(lambda x: jnp.sin(x) @ x.T)
    x = jnp.ones((64, 64))
    step(x).block_until_ready()
    with jax.profiler.trace(str(tmp_path), create_perfetto_trace=True):
        for _ in range(3):
            step(x).block_until_ready()
    span_s, found = profile.timelines(profile.read_events(profile.trace_file(tmp_path)))
    assert span_s > 0 and any(timeline.thread == "python" for timeline in found)
    assert "busy / span" in profile.summarize(tmp_path)


def test_a_folder_without_a_trace_is_refused_in_one_line(tmp_path, capsys):
    (tmp_path / "bad.json.gz").write_bytes(gzip.compress(b"not json"))
    assert profile.main([str(tmp_path)]) == 2
    assert "no perfetto_trace.json.gz" in capsys.readouterr().err
    assert profile.main([str(tmp_path / "bad.json.gz")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a readable trace" in err[0]


def test_the_committed_per_step_record_is_what_the_gpu_profiles_say():
    root = pathlib.Path(__file__).resolve().parents[1]
    folder = root / "benchmarks" / "h100" / "profile"
    script = [sys.executable, str(folder / "per_step.py"), str(folder)]
    output = subprocess.run(script, capture_output=True, text=True, check=True).stdout
    assert output == (folder / "per_step.json").read_text()
    rows = json.loads(output)["rows"]
    assert [(row["terrain"], row["updates_per_step"]) for row in rows] == [
        ("flat", 1), ("flat", 8), ("slope5", 1), ("slope5", 8)
    ]
    for row in rows:  # idle is what the GPU's busy time leaves of a step; the kinds cover it
        assert 0 < row["idle_ms"] < row["wall_ms"]
        kinds = row["warp_ms"] + row["fusion_ms"] + row["matmul_ms"] + row["copy_ms"]
        assert kinds >= 0.99 * (row["wall_ms"] - row["idle_ms"])
    # docs/benchmarks.md shows it through its results record (checked by quadcos.results --check)
    record = json.loads((root / "results" / "profile_h100.json").read_text())
    assert record["sources"][0]["path"] == "benchmarks/h100/profile/per_step.json"
    assert record["numbers"]["rows.0.wall_ms"] == pytest.approx(rows[0]["wall_ms"])


def test_idle_gaps_are_classed_by_length_and_blamed_on_the_host_event_in_them():
    meta = [
        {"ph": "M", "name": "process_name", "pid": 1, "args": {"name": "/device:GPU:0"}},
        {"ph": "M", "name": "process_name", "pid": 2, "args": {"name": "/host:CPU"}},
        {"ph": "M", "name": "thread_name", "pid": 2, "tid": 3, "args": {"name": "python"}},
    ]
    kernels = [(0, 10, "physics_kernel"), (12, 8, "fusion.1"), (100, 10, "gemm.2")]
    kernels += [(1110, 10, "fusion.3")]  # gaps: 2, 80 and 1000 µs
    device = [{"ph": "X", "pid": 1, "tid": 9, "ts": t, "dur": d, "name": n} for t, d, n in kernels]
    host = [  # the whole execution, and inside it a callback across the 80-µs gap
        {"ph": "X", "pid": 2, "tid": 3, "ts": 0, "dur": 2000, "name": "Execute"},
        {"ph": "X", "pid": 2, "tid": 3, "ts": 20, "dur": 85, "name": "ffi_callback"},
    ]
    (idle,) = profile.idle_gaps(meta + device + host, min_gap_us=10)
    assert (idle.process, idle.host_thread) == ("/device:GPU:0", "python")
    classes = dict(zip(profile.GAP_CLASSES_US, idle.counts))
    assert (classes[2.0], classes[200.0], classes[1000.0]) == (1, 1, 1)
    assert sum(idle.seconds) == pytest.approx(1082e-6)
    assert idle.by_host == pytest.approx({"ffi_callback": 80e-6, "Execute": 1000e-6})
    assert idle.by_neighbours["fusion.1 → gemm.2"] == pytest.approx(80e-6)
    text = profile.idle_report([idle], top=5)
    assert "| ffi_callback | 0.0001 |" in text and "| 200–1000 | 1 | 0.0010 |" in text
