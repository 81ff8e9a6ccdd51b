"""The installed package works outside a checkout: the wheel carries the code and the robot files,
and the package list in pyproject.toml is the package as it is."""

import os
import pathlib
import subprocess
import sys
import tomllib

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_pyproject_lists_every_package():
    listed = set(PYPROJECT["tool"]["setuptools"]["packages"])
    found = {
        ".".join(path.parent.relative_to(ROOT).parts)
        for path in (ROOT / "quadcos").rglob("__init__.py")
    }
    assert listed == found | {"quadcos.models"}
    assert PYPROJECT["tool"]["setuptools"]["package-dir"] == {"quadcos.models": "models"}


@pytest.mark.slow
def test_the_wheel_builds_the_env_from_another_directory(tmp_path):
    wheels, site, elsewhere = (tmp_path / name for name in ("wheels", "site", "elsewhere"))
    elsewhere.mkdir()
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    subprocess.run(
        [*pip, "wheel", str(ROOT), "--no-deps", "--no-build-isolation", "-w", str(wheels)],
        check=True,
        cwd=tmp_path,
    )
    (wheel,) = wheels.glob("quadcos-*.whl")
    subprocess.run([*pip, "install", "--no-deps", "--target", str(site), str(wheel)], check=True)
    assert (site / "quadcos" / "models" / "mjcf" / "quadruped.xml").is_file()

    script = (
        "import pathlib, quadcos\n"
        "from quadcos.robot import constants\n"
        "print(pathlib.Path(quadcos.__file__).parent)\n"
        "print(constants.MJCF_PATH)\n"
        "env = quadcos.make_env('flat')\n"
        "print(env.observation_size, env.action_size)\n"
        "import sys, quadcos.train\n"
        "print('orbax' in sys.modules)\n"  # imported at a run's first checkpoint, not at start
    )
    environment = {**os.environ, "PYTHONPATH": str(site), "JAX_PLATFORMS": "cpu"}
    result = subprocess.run(
        [sys.executable, "-c", script],
        cwd=elsewhere,
        env=environment,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    package, mjcf, sizes, orbax_imported = result.stdout.split("\n")[:4]
    assert orbax_imported == "False"
    assert pathlib.Path(package) == site / "quadcos"
    assert pathlib.Path(mjcf) == site / "quadcos" / "models" / "mjcf" / "quadruped.xml"
    observation_size, action_size = map(int, sizes.split())
    assert observation_size > 0 and action_size == 5
