"""The device set up while a command imports: `quadcos._util.device_warmup`."""

import subprocess
import sys

import pytest

from quadcos._util import device_warmup


def test_import_quadcos_loads_no_physics():
    # `python -m quadcos.train` imports the package before its first line runs: the device
    # thread only overlaps the imports if the package itself imports nothing heavy.
    code = "import sys, quadcos; print(sorted(m for m in ('jax', 'mujoco') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
    import quadcos

    assert quadcos.make_env is quadcos.env.make_env  # ... and its names still load on first use
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        quadcos.no_such_name  # noqa: B018


def test_the_first_device_use_runs_in_a_thread_with_the_xla_flags_set(monkeypatch):
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    thread = device_warmup.start(["--preset=smoke"])
    assert thread is not None and thread.daemon
    thread.join(timeout=60)
    assert not thread.is_alive()
    assert device_warmup.os.environ["XLA_FLAGS"] == device_warmup.XLA_FLAGS


@pytest.mark.parametrize("argv", [["--help"], ["--coordinator=10.0.0.1:1234", "--process_id=1"]])
def test_no_thread_for_help_or_a_multi_process_run(argv, monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", "--xla_dump_to=/tmp/x")  # a user's flags are kept
    assert device_warmup.start(argv) is None
    assert device_warmup.os.environ["XLA_FLAGS"] == "--xla_dump_to=/tmp/x"
