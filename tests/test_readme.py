"""The README's library example runs as written."""

import pathlib
import re

import pytest

from quadcos import terrain


@pytest.mark.slow
def test_readme_library_example_runs(monkeypatch):
    monkeypatch.setattr(
        terrain, "_REGISTRY", dict(terrain._REGISTRY)
    )  # the example registers a course
    readme = (pathlib.Path(__file__).resolve().parent.parent / "README.md").read_text()
    block = re.search(r"```python\n(.*?)```", readme, re.S).group(1)
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    state = namespace["state"]
    assert float(state.pipeline_state.qpos[0]) > 0.3  # the fixed trot walked forward
    assert not bool(state.done)
    assert "my_course" in namespace["terrain"].names()
