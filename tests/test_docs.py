"""The documentation builds: `mkdocs build --strict` over docs/ succeeds, and fails on a broken link
(so that the first check means something). Also the README's shape: a front page, not a manual."""

import os
import pathlib
import shutil
import subprocess
import sys

import pytest


ROOT = pathlib.Path(__file__).resolve().parent.parent


def build(config: pathlib.Path, site: pathlib.Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        # no -q: mkdocs counts the warnings it logs, and a quiet build logs none
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(config), "-d", str(site)],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},  # no banner about Material's future
    )


def test_docs_build_strict(tmp_path):
    result = build(ROOT / "mkdocs.yml", tmp_path / "site")
    assert result.returncode == 0, result.stderr
    for page in ("index", "training", "terrains", "env", "evaluation", "deploy", "benchmarks"):
        assert (tmp_path / "site" / ("" if page == "index" else page) / "index.html").is_file(), page


@pytest.mark.parametrize(
    "broken",
    ["[a page that is not there](no-such-page.md)", "[an anchor that is not there](training.md#no-such-section)"],
)
def test_a_broken_link_fails_the_strict_build(tmp_path, broken):
    copy = tmp_path / "copy"
    shutil.copytree(ROOT / "docs", copy / "docs")
    shutil.copy(ROOT / "mkdocs.yml", copy / "mkdocs.yml")
    with open(copy / "docs" / "index.md", "a") as index:
        index.write(f"\n{broken}\n")
    result = build(copy / "mkdocs.yml", tmp_path / "site")
    assert result.returncode != 0
    assert "no-such" in result.stderr


def test_readme_is_a_front_page():
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 200
    assert not [line for line in lines if line.startswith("|") and len(line) > 200]
    for page in ROOT.glob("docs/*.md"):  # every page the README's map names exists
        assert f"(docs/{page.name})" in (ROOT / "README.md").read_text(), page.name
