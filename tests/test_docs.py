"""The documentation site builds without a warning, and its tutorials run as written."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((ROOT / "docs" / "tutorials").glob("*.md"))


def _blocks(page: Path, lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", page.read_text(), re.S)


README = ROOT / "README.md"
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def test_the_readme_is_a_short_front_page():
    lines = README.read_text().splitlines()
    assert len(lines) < 250, f"README.md has {len(lines)} lines; its sections belong in docs/"


def test_every_relative_link_of_the_readme_points_to_a_file():
    targets = LINK.findall(README.read_text())
    relative = [t.split("#")[0] for t in targets if not re.match(r"[a-z][a-z0-9+.-]*:|#", t)]
    assert relative, "README.md links nowhere into the site"
    missing = [t for t in relative if not (ROOT / t).is_file()]
    assert not missing, f"README.md links to missing files: {missing}"


def test_the_readme_library_example_runs(monkeypatch):
    monkeypatch.chdir(ROOT)
    (ROOT / "out").mkdir(exist_ok=True)
    (code,) = _blocks(README, "python")
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)  # noqa: S102 - the README's own example
    assert scope["result"].report["inverted_elements"] == 0


def test_the_site_builds_with_warnings_as_errors(tmp_path):
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d", str(tmp_path / "site")],
                       cwd=ROOT, capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    api = (tmp_path / "site" / "reference" / "solver" / "index.html").read_text()
    assert "precompute" in api and "Parameters" in api  # the reference is generated from the docstrings
    for page in TUTORIALS:
        assert (tmp_path / "site" / "tutorials" / page.stem / "index.html").is_file()


@pytest.mark.ccx  # the last step runs CalculiX
@pytest.mark.parametrize("page", TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_every_block_of_a_tutorial_runs_as_written(page, monkeypatch):
    monkeypatch.chdir(ROOT)  # the pages' paths are the repository's
    (ROOT / "out").mkdir(exist_ok=True)
    scope: dict = {}
    for code in _blocks(page, "python"):
        exec(compile(code, f"{page.name}", "exec"), scope)  # noqa: S102 - the page's own code
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    for script in _blocks(page, "sh"):
        r = subprocess.run(["bash", "-euo", "pipefail", "-c", script], cwd=ROOT, capture_output=True, text=True,
                           timeout=600, env=env)
        assert r.returncode == 0, f"{page.name}:\n{script}\n{r.stdout[-2000:]}{r.stderr[-2000:]}"
