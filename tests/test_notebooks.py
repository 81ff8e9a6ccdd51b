"""The notebooks run top to bottom at tiny sizes (QUADCOS_NOTEBOOK_TINY=1) and draw their figures.

Their kernels share the tests' JAX compilation cache: notebook (a)'s rollouts have the shapes of
tests/test_evaluate.py's, so only notebook (b)'s course and the own-robot notebook's quad12
rollouts compile anew.
"""

import json
import pathlib

import nbformat
import pytest
from nbclient import NotebookClient

from tests.cli_runs import cache_env

ROOT = pathlib.Path(__file__).resolve().parent.parent
NOTEBOOKS = ROOT / "notebooks"


def run_notebook(name: str, out: pathlib.Path, monkeypatch) -> nbformat.NotebookNode:
    monkeypatch.setenv("QUADCOS_NOTEBOOK_TINY", "1")
    monkeypatch.setenv("QUADCOS_NOTEBOOK_OUT", str(out))
    for variable, value in cache_env().items():
        monkeypatch.setenv(variable, value)
    notebook = nbformat.read(NOTEBOOKS / name, as_version=4)
    client = NotebookClient(
        notebook,
        timeout=600,
        kernel_name="python3",
        resources={"metadata": {"path": str(NOTEBOOKS)}},
    )
    client.execute()
    return notebook


def _text(notebook: nbformat.NotebookNode) -> str:
    return "\n".join(
        output.get("text", "")
        for cell in notebook.cells
        if cell.cell_type == "code"
        for output in cell.get("outputs", [])
    )


@pytest.mark.slow
def test_evaluate_and_plot_notebook(tmp_path, monkeypatch):
    notebook = run_notebook("evaluate_and_plot.ipynb", tmp_path, monkeypatch)
    assert "success_rate" in _text(notebook)
    result = json.loads((tmp_path / "evaluation_flat.json").read_text())
    assert result["num_episodes"] == 4 and result["setup"]["policy_kind"] == "sac"
    for name in (
        "cog_flat",
        "attitude_flat",
        "controller_flat",
        "parameters_flat",
        "cog_fixed",
        "learning_curve",
    ):
        assert (tmp_path / f"{name}.png").stat().st_size > 1000, name


@pytest.mark.slow
def test_custom_course_notebook(tmp_path, monkeypatch):
    notebook = run_notebook("custom_course.ipynb", tmp_path, monkeypatch)
    result = json.loads((tmp_path / "evaluation_my_course.json").read_text())
    assert result["setup"]["terrain"] == "sections:4@2,0@1.5,7@1,0@1,-6@2;lead_in=1"
    assert result["setup"]["course_end_x"] == pytest.approx(8.5)
    assert result["num_episodes"] == 4
    for name in ("course", "cog_my_course", "attitude_my_course", "controller_my_course"):
        assert (tmp_path / f"{name}.png").stat().st_size > 1000, name
    assert (tmp_path / "my_course.mp4").exists() or "lib" in _text(notebook)


@pytest.mark.slow
def test_own_robot_notebook(tmp_path, monkeypatch):
    notebook = run_notebook("own_robot.ipynb", tmp_path, monkeypatch)
    text = _text(notebook)
    assert "robot: quad12" in text and "success_rate" in text
    assert "FL_thigh_joint" in text  # the legs' table
    for name in ("cog_quad12", "attitude_quad12"):
        assert (tmp_path / f"{name}.png").stat().st_size > 1000, name
