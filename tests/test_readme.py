"""The README's library example runs as written."""

import pathlib
import re


def test_readme_library_example_runs():
    readme = (pathlib.Path(__file__).resolve().parent.parent / "README.md").read_text()
    block = re.search(r"```python\n(.*?)```", readme, re.S).group(1)
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    state, course = namespace["state"], namespace["course"]
    assert float(state.pipeline_state.qpos[0]) > 0.3  # the fixed trot walked forward
    assert not bool(state.done)
    assert "my_course" in namespace["terrain"].names()
