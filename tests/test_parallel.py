"""Data-parallel SAC on the CPU: two devices of one process (XLA's forced host device count) and
two processes on localhost (`jax.distributed`, Gloo collectives), each against one device."""

import json
import os
import pathlib
import socket
import subprocess
import sys

import numpy as np
import pytest

from tests.cli_runs import ROOT, cli_env

SCRIPT = ROOT / "tests" / "parallel_checks.py"
# How far two devices may end from one after 4,000 toy env steps: their runs differ only in
# which device samples which transitions (each device samples its own half of the buffer). A
# learned policy scores about -3, a random one about -9.
RETURN_TOLERANCE = 1.0


def _env(device_count: int) -> dict[str, str]:
    """The tests' environment and compilation cache, with `device_count` CPU devices."""
    flags = os.environ.get("XLA_FLAGS", "")
    return {
        **cli_env(),
        "XLA_FLAGS": f"{flags} --xla_force_host_platform_device_count={device_count}",
    }


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("localhost", 0))
        return sock.getsockname()[1]


def _result(process: subprocess.Popen) -> dict:
    out, err = process.communicate(timeout=600)
    assert process.returncode == 0, err[-3000:]
    return json.loads(out.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Runs both checks, one after the other (the two processes of the second wait on each
    other's collectives: they get a core each), and returns their JSON results."""
    base = tmp_path_factory.mktemp("parallel")
    command = [sys.executable, str(SCRIPT)]
    pipes = dict(cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    devices = _result(
        subprocess.Popen([*command, "devices", str(base / "devices")], env=_env(2), **pipes)
    )
    coordinator = f"localhost:{_free_port()}"
    processes = [
        subprocess.Popen(
            [*command, "process", str(base / "processes"), coordinator, "2", str(index)],
            env=_env(1),
            **pipes,
        )
        for index in range(2)
    ]
    return {
        "devices": devices,
        "processes": [_result(process) for process in processes],
        "process_dir": base / "processes",
    }


@pytest.mark.slow
def test_two_devices_keep_one_set_of_parameters_and_learn_as_one(runs):
    result = runs["devices"]
    one, two = result["d1"], result["d2"]
    assert result["device_count"] == 2
    assert two["obs_sharding"] == "P('devices',)"  # the envs are split, not copied
    assert two["replicas_identical"] and one["replicas_identical"]
    # Each device keeps half of the buffer; together they hold every transition.
    assert two["replay_sizes"] == [2000, 2000] and one["replay_sizes"] == [4000]
    assert one["env_steps"] == two["env_steps"] == 4000
    assert "n_step=3 runs on one device; this run spans 2" in result["n_step_refused"]
    # The same initial policy and evaluation episodes, split over the devices.
    assert two["first_eval_reward"] == pytest.approx(one["first_eval_reward"], abs=1e-4)
    # Each device evaluates its half of the episodes; only the metrics' means cross devices.
    evaluation = runs["devices"]["eval_collectives"]
    assert evaluation and all(entry.startswith("all-reduce") for entry in evaluation), evaluation
    for run in (one, two):
        assert run["final_eval_reward"] > run["first_eval_reward"] + 4.0
    assert two["final_eval_reward"] == pytest.approx(one["final_eval_reward"], abs=RETURN_TOLERANCE)
    for loss_one, loss_two in zip(one["critic_loss"], two["critic_loss"]):
        assert loss_two == pytest.approx(loss_one, rel=0.3)


@pytest.mark.slow
def test_each_update_reduces_its_gradients_in_one_collective_and_samples_locally(runs):
    # One all-reduce of every gradient (temperature, critics, actor) per update; the env step's
    # few scalar reductions (the transition count and reward, the observation statistics; a
    # non-finite env restarts by a select, no reduction); no gather: each device inserts into
    # and samples its own ring.
    assert runs["devices"]["collectives"] == [
        "all-reduce gradients",
        "all-reduce reduce_sum",
        "all-reduce reduce_sum",
        "all-reduce reduce_sum",
    ]


@pytest.mark.slow
def test_an_env_stepped_per_device_trains_as_the_partitioned_one(runs):
    # MJX-Warp's path (`parallel.per_device`): each device steps its own envs in a shard_map,
    # with no gather of the envs onto every device; the run is the partitioned one's.
    per_device, two = runs["devices"]["per_device"], runs["devices"]["d2"]
    assert per_device["obs_sharding"] == "P('devices',)"
    # Shardy crashes XLA's GPU compiler on a shard_map of the MJX step: runs over a mesh (whose
    # evaluation, and MJX-Warp's steps, run per device) partition with GSPMD.
    assert runs["devices"]["shardy"] and not per_device["shardy"]
    assert per_device["collectives"] == runs["devices"]["collectives"]
    assert per_device["final_eval_reward"] == pytest.approx(two["final_eval_reward"], abs=1e-3)


@pytest.mark.slow
def test_warp_steps_each_devices_robots_as_the_jax_physics_does(tmp_path):
    """Two devices, MJX-Warp's kernels called by each on its own robots (Warp's CPU kernels
    here; runs where warp-lang is installed): the robots move as under MJX-JAX."""
    pytest.importorskip("warp", reason="warp-lang (the warp extra) is not installed")
    process = subprocess.Popen(
        [sys.executable, str(SCRIPT), "warp", str(tmp_path)],
        cwd=ROOT,
        env=_env(2),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    positions = _result(process)
    assert positions["warp_shard_rows"] == positions["jax_shard_rows"] == [2, 2]
    # Each device's Warp calls step its own 2 robots; no device gathers all 4.
    assert positions["warp_call_rows"] == [2] and positions["all_gathers"] == 0
    difference = np.abs(np.subtract(positions["warp"], positions["jax"]))
    assert difference.max() < 1e-3, difference
    assert np.ptp(np.asarray(positions["warp"])[:, 0]) > 0.01  # the robots moved, differently
    # The evaluation (every device runs all its episodes) scores alike on both physics.
    assert positions["warp_eval_reward"] == pytest.approx(positions["jax_eval_reward"], rel=0.01)


@pytest.mark.slow
def test_checkpoints_resume_on_another_device_count(runs):
    resumed = runs["devices"]["resumed"]
    # Saved on 2 devices at 2,400 env steps with the replay buffer, resumed on 1 to 4,000, then
    # on 2 to 5,600: every stored transition kept at each change, nothing refilled.
    assert resumed["on_1"]["env_steps"] == 4000
    assert resumed["on_1"]["replay_size"] == 4000
    assert resumed["on_2"]["env_steps"] == 5600
    assert resumed["on_2"]["replay_size"] == 5600
    assert resumed["on_2"]["rows"] == 7  # one metrics row per evaluation, none lost or repeated
    assert resumed["on_2"]["final_eval_reward"] > -4.0


@pytest.mark.slow
def test_global_sizes_must_divide_over_the_devices(runs):
    assert runs["devices"]["odd_num_envs_error"] == (
        "num_envs=15 does not divide evenly over 2 devices; use a multiple of 2 (e.g. 14)"
    )


@pytest.mark.slow
def test_two_processes_train_as_two_devices_and_write_one_set_of_outputs(runs):
    first, second = runs["processes"]
    assert (first["process_index"], second["process_index"]) == (0, 1)
    assert first["device_count"] == second["device_count"] == 2
    assert first["local_device_count"] == 1
    # The same program as two devices of one process: the same numbers.
    assert first["final_eval_reward"] == pytest.approx(
        runs["devices"]["d2"]["final_eval_reward"], abs=1e-3
    )
    assert first["policy_checksum"] == second["policy_checksum"]
    # The paper's robot in each process lives on that process's device (MJX puts a model on
    # the first of all processes' devices by default) and steps there.
    assert first["robot_addressable"] and second["robot_addressable"]
    assert first["robot_height"] == second["robot_height"] > 0.3
    run_dir: pathlib.Path = runs["process_dir"]
    names = sorted(path.name for path in run_dir.iterdir())
    assert names == [
        "checkpoints",
        "config.json",
        "metrics.csv",
        "metrics.jsonl",
        "policy",
        "startup.json",
        "tensorboard",
    ]
    rows = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    assert [row["step"] for row in rows] == [0, 1600, 2400, 3200, 4000]  # written once
    assert len(list((run_dir / "tensorboard").iterdir())) == 1
    assert sorted(path.name for path in (run_dir / "checkpoints").iterdir()) == [
        "1600",
        "3200",
        "4000",
    ]


def test_a_bench_over_processes_is_of_its_train_rows_timed_alike_in_each(
    tmp_path, capsys, monkeypatch
):
    from quadcos import bench
    from quadcos.benchmarking import trainers

    argv = [f"--out={tmp_path / 'b.json'}", "--coordinator=localhost:1234", "--num_processes=2"]
    assert bench.main([*argv, "--process_id=0"]) == 2
    assert "--coordinator benches the train rows only: add --only train" in capsys.readouterr().err
    assert not (tmp_path / "b.json").exists()
    # Each process times the chunks process 0's first timed chunk plans: at least two.
    sent = []
    broadcast = lambda value: sent.append(int(value)) or value  # noqa: E731 - process 0's value
    monkeypatch.setattr(trainers.multihost_utils, "broadcast_one_to_all", broadcast)
    assert trainers._agreed_chunks(10.0, 0.3) == 34 and sent == [34]  # noqa: SLF001
    assert trainers._agreed_chunks(0.0, 0.3) == 2  # noqa: SLF001


# --- Command line and the committed two-GPU figures (no extra devices needed) ---------------


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ["--coordinator=localhost:1234"],
            "--coordinator needs --num_processes=N and --process_id=I",
        ),
        (["--num_processes=2"], "--num_processes and --process_id need --coordinator=HOST:PORT"),
        (
            ["--coordinator=localhost:1234", "--num_processes=2", "--process_id=2"],
            "--process_id=2: choose 0 to 1",
        ),
        (
            ["--coordinator=localhost:1234", "--num_processes=2", "--process_id=0", "--numbered"],
            "--numbered with --coordinator: give every process the same --output_dir",
        ),
        (["--num_devices=0"], "config.sac.num_devices must be >= 1 or None (all), got 0"),
    ],
)
def test_scale_out_flags_are_checked_in_one_line(args, message, tmp_path, capsys):
    from quadcos import train

    status = train.main(["--preset=smoke", f"--output_dir={tmp_path / 'run'}", *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2
    assert message in err[-1] and err[-1].startswith("quadcos.train: error:")
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("device", ["h200x2", "h100x2", "h200x2_warp", "h200x4_warp"])
def test_committed_scaling_table_is_what_its_runs_measured(device):
    from quadcos.benchmarking import scaling

    committed = json.loads((ROOT / "benchmarks" / f"{device}.json").read_text())
    rows = scaling.scaling_rows(committed["runs"])
    assert rows == committed["rows"]
    for many in (row for row in rows if row["num_devices"] > 1):
        one = next(
            row
            for row in rows
            if row["num_devices"] == 1
            and all(
                row[key] == many[key] for key in ("terrain", "envs_per_device", "updates_per_step")
            )
        )
        assert many["envs_per_device"] == one["envs_per_device"] == 4096
        assert many["speedup"] == pytest.approx(many["env_steps_per_s"] / one["env_steps_per_s"])


def test_a_two_gpu_row_is_compared_with_the_one_gpu_row_of_its_own_physics():
    from quadcos.benchmarking import scaling

    def run(impl, devices, rate):
        row = {"num_envs": 4096 * devices, "batch_size": 8192 * devices, "updates_per_step": 1}
        return {
            "terrain": "flat",
            "impl": impl,
            "settings": {"num_devices": devices},
            "train": [{**row, "quadcos_env_steps_per_s": rate}],
        }

    rates = {("jax", 1): 100.0, ("warp", 1): 400.0, ("jax", 2): 180.0, ("warp", 2): 760.0}
    rows = scaling.scaling_rows([run(impl, n, rate) for (impl, n), rate in rates.items()])
    speedups = {(row["impl"], row["num_devices"]): row["speedup"] for row in rows}
    assert speedups == {("jax", 1): 1.0, ("jax", 2): 1.8, ("warp", 1): 1.0, ("warp", 2): 1.9}
