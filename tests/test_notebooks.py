"""The notebooks run top to bottom at tiny sizes (QUADCOS_NOTEBOOK_TINY=1) and draw their figures.

Their kernels share the tests' JAX compilation cache: notebook (a)'s rollouts have the shapes of
tests/test_evaluate.py's, so only notebook (b)'s course, the own-robot notebook's quad12 rollouts
and the commands notebook's Go1 rollouts compile anew. The commands notebook needs MuJoCo
Menagerie's Go1 (MENAGERIE_ROOT, or the copies beside the repository that tests/test_robot.py
uses).
"""

import asyncio
import json
import os
import pathlib

import nbformat
import pytest
from nbclient import NotebookClient

from tests.cli_runs import cache_env

ROOT = pathlib.Path(__file__).resolve().parent.parent
NOTEBOOKS = ROOT / "notebooks"
MENAGERIE = pathlib.Path(os.environ.get("MENAGERIE_ROOT") or ROOT.parent / "shared" / "menagerie")
NOTEBOOKS_RUN = ("evaluate_and_plot.ipynb", "custom_course.ipynb", "own_robot.ipynb") + (
    ("commands.ipynb",) if MENAGERIE.is_dir() else ()
)


def _run_all(out: pathlib.Path) -> dict[str, nbformat.NotebookNode | BaseException]:
    """Every notebook of NOTEBOOKS_RUN executed at once, each in its own kernel (a process of
    its own) writing to out/<name>: name -> the executed notebook, or what stopped it."""
    base = {**os.environ, **cache_env(), "QUADCOS_NOTEBOOK_TINY": "1"}
    if MENAGERIE.is_dir():
        base["MENAGERIE_ROOT"] = str(MENAGERIE)

    async def run(name: str) -> nbformat.NotebookNode:
        notebook = nbformat.read(NOTEBOOKS / name, as_version=4)
        client = NotebookClient(
            notebook,
            timeout=600,
            kernel_name="python3",
            resources={"metadata": {"path": str(NOTEBOOKS)}},
        )
        (out / name).mkdir(parents=True)
        await client.async_execute(env={**base, "QUADCOS_NOTEBOOK_OUT": str(out / name)})
        return notebook

    async def run_all() -> list[nbformat.NotebookNode | BaseException]:
        runs = (run(name) for name in NOTEBOOKS_RUN)
        return await asyncio.gather(*runs, return_exceptions=True)

    return dict(zip(NOTEBOOKS_RUN, asyncio.run(run_all())))


@pytest.fixture(scope="module")
def run_notebook(tmp_path_factory):
    """name -> (its executed notebook, its output folder), the notebooks run side by side (each
    kernel compiles its own programs while the others wait on theirs); raises what stopped it."""
    out = tmp_path_factory.mktemp("notebooks")
    executed = _run_all(out)

    def result(name: str) -> tuple[nbformat.NotebookNode, pathlib.Path]:
        if isinstance(executed[name], BaseException):
            raise executed[name]
        return executed[name], out / name

    return result


def _text(notebook: nbformat.NotebookNode) -> str:
    return "\n".join(
        output.get("text", "")
        for cell in notebook.cells
        if cell.cell_type == "code"
        for output in cell.get("outputs", [])
    )


@pytest.mark.slow
def test_evaluate_and_plot_notebook(run_notebook):
    notebook, out = run_notebook("evaluate_and_plot.ipynb")
    assert "success_rate" in _text(notebook)
    result = json.loads((out / "evaluation_flat.json").read_text())
    assert result["num_episodes"] == 4 and result["setup"]["policy_kind"] == "sac"
    for name in (
        "cog_flat",
        "attitude_flat",
        "controller_flat",
        "parameters_flat",
        "cog_fixed",
        "learning_curve",
    ):
        assert (out / f"{name}.png").stat().st_size > 1000, name


@pytest.mark.slow
def test_custom_course_notebook(run_notebook):
    notebook, out = run_notebook("custom_course.ipynb")
    result = json.loads((out / "evaluation_my_course.json").read_text())
    assert result["setup"]["terrain"] == "sections:4@2,0@1.5,7@1,0@1,-6@2;lead_in=1"
    assert result["setup"]["course_end_x"] == pytest.approx(8.5)
    assert result["num_episodes"] == 4
    for name in ("course", "cog_my_course", "attitude_my_course", "controller_my_course"):
        assert (out / f"{name}.png").stat().st_size > 1000, name
    assert (out / "my_course.mp4").exists() or "lib" in _text(notebook)


@pytest.mark.slow
def test_own_robot_notebook(run_notebook):
    notebook, out = run_notebook("own_robot.ipynb")
    text = _text(notebook)
    assert "robot: quad12" in text and "success_rate" in text
    assert "FL_thigh_joint" in text  # the legs' table
    for name in ("cog_quad12", "attitude_quad12"):
        assert (out / f"{name}.png").stat().st_size > 1000, name


@pytest.mark.slow
@pytest.mark.skipif(not MENAGERIE.is_dir(), reason=f"no MuJoCo Menagerie copies at {MENAGERIE}")
def test_commands_notebook(run_notebook):
    notebook, out = run_notebook("commands.ipynb")
    result = json.loads((out / "evaluation_schedule.json").read_text())
    assert result["num_episodes"] == 4 and result["setup"]["commands"] == "0.5,0@1;0.6,0.4@1"
    assert result["setup"]["policy_env_steps"] > 0  # a policy from training, not its gait
    assert 0 <= result["speed_tracking_rms"] < 0.5 and 0 <= result["yaw_rate_tracking_rms"] < 0.5
    assert (out / "command_tracking.png").stat().st_size > 1000
    text = _text(notebook)
    assert "gait" in text and "C MuJoCo" in text and "'command': ['batch', 2]" in text
    assert (out / "unitree_go1_command.onnx").stat().st_size > 1000
