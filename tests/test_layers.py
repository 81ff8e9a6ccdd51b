"""The package's layers (quadcos/__init__.py's docstring, docs/architecture.md): every module
imports only modules of lower layers or of its own package, with no circle, lazy imports inside
functions included; read from the source (AST), nothing is imported."""

import ast
import re
import pathlib

import pytest

import quadcos

PACKAGE = pathlib.Path(quadcos.__file__).resolve().parent
LAYERS = (
    "_util",
    "equations",
    "robot",
    "terrain",
    "viz",
    "env",
    "training",
    "evaluation",
    "deploy",
    "benchmarking",
)
COMMANDS = ("train", "evaluate", "bench", "play", "sim2sim", "export", "results")


def _module_name(path: pathlib.Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str) -> bool:
    relative = pathlib.Path(*name.split(".")[1:])
    return (PACKAGE / relative).with_suffix(".py").is_file() or (
        PACKAGE / relative / "__init__.py"
    ).is_file()


def _imports(path: pathlib.Path) -> set[str]:
    """The quadcos modules `path` imports, anywhere in it (`from quadcos.x import y` counts as
    quadcos.x.y when y is a module, else as quadcos.x)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names if alias.name.split(".")[0] == "quadcos"}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module.split(".")[0] != "quadcos":
                continue
            for alias in node.names:
                child = f"{node.module}.{alias.name}"
                found.add(child if _is_module(child) else node.module)
    return found


def _layer(name: str) -> int:
    """0.. for the layers, len(LAYERS) for the command lines (a package's `__main__` is one),
    one more for the package facade."""
    parts = name.split(".")
    if len(parts) == 1:
        return len(LAYERS) + 1
    if parts[-1] == "__main__":
        return len(LAYERS)
    if parts[1] in LAYERS:
        return LAYERS.index(parts[1])
    if parts[1] in COMMANDS:
        return len(LAYERS)
    raise AssertionError(f"{name} belongs to no layer: add it to LAYERS or COMMANDS")


GRAPH = {_module_name(path): _imports(path) for path in sorted(PACKAGE.rglob("*.py"))}


def test_the_top_level_holds_at_most_ten_modules():
    top = sorted(path.name for path in PACKAGE.glob("*.py"))
    assert len(top) <= 10, top
    assert {f"{name}.py" for name in COMMANDS} <= set(top)


def test_every_module_belongs_to_a_layer():
    for name in GRAPH:
        _layer(name)


@pytest.mark.parametrize("name", sorted(GRAPH))
def test_imports_point_down_or_within_the_package(name):
    own = name.split(".")[:2]
    for target in GRAPH[name]:
        assert target == "quadcos" or _is_module(target), f"{name} imports {target}: no such module"
        if target.split(".")[:2] == own and _layer(name) < len(LAYERS):
            continue  # inside its own package: the circle test below
        assert _layer(target) < _layer(name), (
            f"{name} (layer {_layer(name)}) imports {target} (layer {_layer(target)})"
        )


def test_no_import_circles():
    def visit(name, trail):
        assert name not in trail, " -> ".join([*trail, name])
        for target in GRAPH.get(name, ()):
            if target.split(".")[:2] == name.split(".")[:2] and target != name:
                visit(target, (*trail, name))

    for name in GRAPH:
        visit(name, ())


def test_the_checks_can_fail():
    """A command line importing another, and a lower layer importing a higher one, are caught."""
    assert _layer("quadcos.equations.slope") < _layer("quadcos.env.quadruped")
    assert _layer("quadcos.train") == _layer("quadcos.sim2sim")  # so neither may import the other
    assert _layer("quadcos.robot.__main__") == _layer("quadcos.train")
    assert "quadcos.env.backends" in GRAPH["quadcos.env.quadruped"]


def test_the_architecture_page_shows_the_layers_as_they_are():
    page = (PACKAGE.parent / "docs" / "architecture.md").read_text()
    table = re.findall(r"^\| `(\w+)/` \|", page, re.M)
    assert tuple(table) == LAYERS
    chain = re.search(r"^\s*util --> (.*)$", page, re.M).group(1).split(" --> ")
    assert tuple(["_util", *chain[:-1]]) == LAYERS and chain[-1] == "clis"


def _long_functions(source: str, limit: int) -> list[str]:
    """The functions (methods and nested ones included) of `source` over `limit` lines, each as
    "name (N lines)"."""
    return [
        f"{node.name} ({node.end_lineno - node.lineno + 1} lines)"
        for node in ast.walk(ast.parse(source))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
        and node.end_lineno - node.lineno + 1 > limit
    ]


def test_no_function_runs_over_100_lines():
    too_long = {
        str(path.relative_to(PACKAGE.parent)): found
        for path in sorted(PACKAGE.rglob("*.py"))
        if (found := _long_functions(path.read_text(), 100))
    }
    assert not too_long, too_long


def test_the_length_check_counts_decorators_out_and_nested_functions_in():
    body = "\n".join(f"        x{i} = {i}" for i in range(100))
    source = f"@staticmethod\ndef outer():\n    def inner():\n{body}\n    return inner\n"
    assert _long_functions(source, 100) == ["outer (103 lines)", "inner (101 lines)"]
    assert _long_functions(source, 103) == []
