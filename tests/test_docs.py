"""The documentation site builds without a warning, and its tutorials run as written."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.tutorial_blocks import check_output, run_steps, steps_with_output

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


#: A file of the repository named in prose: ``solver/linalg/constrained.py``, ``tests/data/plate.inp``, ...
REPO_PATH = re.compile(r"(?<![\w/.$-])(?:solver|service|tests|benchmarks|examples|web|docker|docs)/"
                       r"[\w./-]*\w\.[A-Za-z0-9]+\b")


def test_every_file_the_pages_name_exists():
    pages = [README, ROOT / "CONTRIBUTING.md", *sorted((ROOT / "docs").rglob("*.md")),
             ROOT / "docs" / "hooks" / "reference_text.py"]
    named = {(p.relative_to(ROOT).as_posix(), m) for p in pages for m in REPO_PATH.findall(p.read_text())}
    assert len(named) > 100
    missing = sorted(f"{page}: {path}" for page, path in named if not (ROOT / path).exists())
    assert not missing, "pages name files that are not in the repository:\n" + "\n".join(missing)


@pytest.fixture
def checkout(tmp_path, monkeypatch) -> Path:
    """An empty working directory that reads like the reader's clone of the repository.

    The pages use the repository's paths (``tests/data/...``, ``examples/...``); nothing else is
    made for them: a page that writes ``out/...`` must get that folder made by the code it calls
    or by its own commands, as it would be for a reader.
    """
    work = tmp_path / "checkout"
    work.mkdir()
    for name in ("tests", "examples", "docs"):
        (work / name).symlink_to(ROOT / name, target_is_directory=True)
    monkeypatch.chdir(work)
    return work


def _readme_output(code: str) -> str:
    """The ``text`` block that shows what a README block prints."""
    (step,) = [s for s in steps_with_output(README.read_text()) if s[1] == code]
    assert step[2] is not None, f"README.md shows no output after:\n{code}"
    return step[2]


def test_the_readme_library_example_runs_and_prints_what_it_shows(checkout):
    import contextlib
    import io

    (code,) = _blocks(README, "python")
    scope: dict = {}
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, "README.md", "exec"), scope)  # noqa: S102 - the README's own example
    assert scope["result"].report["inverted_elements"] == 0
    check_output(_readme_output(code), printed.getvalue(), "README.md, the library example")


def _readme_block(needle: str) -> str:
    (block,) = [b for b in _blocks(README, "sh") if needle in b]
    return block


def _run_bash(block: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    r = subprocess.run(["bash", "-euo", "pipefail", "-c", block], cwd=cwd, capture_output=True, text=True,
                       timeout=300, env=env)
    assert r.returncode == 0, f"README.md:\n{block}\n{r.stdout[-2000:]}{r.stderr[-2000:]}"
    return r


def _bash(block: str, cwd: Path) -> str:
    return _run_bash(block, cwd).stdout


def test_the_readme_command_line_example_runs_and_says_what_it_shows(checkout):
    import csv
    import json

    import meshio

    block = _readme_block("tetmorph morph")
    run = _run_bash(block, checkout)
    out = run.stdout
    # what the commands say on standard error is the README's text, to its marked timings; a kernel
    # load that takes over a second (a busy machine, a fresh install) is announced too, and left out here
    said = "".join(line for line in run.stderr.splitlines(keepends=True)
                   if not line.startswith("tetmorph: loading the solver's compiled kernels"))
    check_output(_readme_output(block), said, "README.md, the command line")
    beam = meshio.read(ROOT / "examples" / "beam" / "beam.node")
    moves = json.loads((ROOT / "examples" / "beam" / "moves.json").read_text())
    for i in range(len(moves)):  # one deformed beam per MOVE
        assert len(meshio.read(checkout / "out" / f"beam_{i}.vtu").points) == len(beam.points)
    assert out.count('"inverted_elements"') >= len(moves)  # `info`'s JSON, then a REPORT per MOVE
    plan = list(csv.reader((ROOT / "tests" / "solver" / "workflows" / "data" / "plate_plan.csv").open()))
    summary = list(csv.DictReader((checkout / "out" / "summary.csv").open()))
    assert len(summary) == len(plan) - 1  # one row per plan row, below the header
    assert all((checkout / "out" / f"plate_{row['row']}.inp").is_file() for row in summary)


@pytest.mark.slow  # a real server process
def test_the_readme_rest_example_answers_what_the_library_computes(tmp_path):
    import json

    from service.process import serve_process
    from solver import precompute, read_mesh

    block = _readme_block("curl")
    move = json.loads(re.search(r"-d '(.*)'", block).group(1))
    with serve_process(tmp_path / "data", env={"TETMORPH_DEMO": "1"}) as (url, _):
        report = json.loads(_bash(block.replace("http://127.0.0.1:8000", url), tmp_path))["report"]
    beam = ROOT / "examples" / "beam"
    spec = json.loads((beam / "spec.json").read_text())
    expected = precompute(read_mesh(beam / "beam.node"), spec).solve(move).report
    assert report["inverted_elements"] == expected["inverted_elements"] == 0
    for key in ("max_displacement", "min_scaled_jacobian"):
        assert report[key] == pytest.approx(expected[key], rel=1e-9), key


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once for the tests of this module, with warnings as errors."""
    out = tmp_path_factory.mktemp("docs") / "site"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d", str(out)],
                       cwd=ROOT, capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    return out


def _page(site: Path, uri: str) -> str:
    return (site / uri / "index.html").read_text()


def _row(html_text: str, needle: str) -> str:
    """The table row of a page that holds ``needle``."""
    rows = [r for r in re.findall(r"<tr>(.*?)</tr>", html_text, re.S) if needle in r]
    assert rows, f"no table row holds {needle!r}"
    return rows[0]


def test_the_site_builds_with_warnings_as_errors(site):
    api = _page(site, "reference/solver")
    assert "precompute" in api and "Parameters" in api  # the reference is generated from the docstrings
    for page in TUTORIALS:
        assert (site / "tutorials" / page.stem / "index.html").is_file()


def test_every_public_name_of_the_library_and_the_client_has_its_reference(site):
    import solver
    import solver.workflows
    from service import client

    pages = {"reference/solver": [solver, solver.workflows], "reference/client": [client]}
    for uri, modules in pages.items():
        ids = set(re.findall(r'id="([\w.]+)"', _page(site, uri)))
        for module in modules:
            for name in module.__all__:
                obj = getattr(module, name)
                anchor = f"{obj.__module__}.{obj.__qualname__}"  # mkdocstrings' id: the object's own path
                assert anchor in ids, f"{module.__name__}.{name} is not on {uri} (as {anchor})"


def test_the_benchmark_plot_is_drawn_from_the_scaling_table(site):
    sys.path.insert(0, str(ROOT / "docs" / "scripts"))
    import benchmark_plots

    page = (ROOT / "docs" / "benchmarks.md").read_text()
    scaling = page.split("\n## Scaling", 1)[1]
    first_table = re.search(r"(?:^\|.*\n)+", scaling, re.M).group()  # the section's first table
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in first_table.splitlines()
            if re.match(r"\| [\d,]+ \|", line)]
    expected = [(float(r[0].replace(",", "")), float(r[-1])) for r in rows]
    assert len(expected) >= 3
    assert sorted(benchmark_plots.series(page)["scaling run"]) == sorted(expected)
    svg = (site / "img" / "benchmark-update-ratio.svg").read_text()
    assert svg.startswith("<?xml") and "<svg" in svg
    assert 'src="../img/benchmark-update-ratio.svg"' in _page(site, "benchmarks")


def test_the_bracket_picture_is_the_first_tutorials_morph(site):
    import ast

    sys.path.insert(0, str(ROOT / "docs" / "scripts"))
    import pictures

    page = (ROOT / "docs" / "tutorials" / "morph-a-deck.md").read_text()
    spec = ast.literal_eval(re.search(r"^spec = (\{.*?^\})", page, re.S | re.M).group(1))
    move = ast.literal_eval(re.search(r"deformer\.solve\((\{.*?\})\)", page).group(1))
    assert (spec, move) == (pictures.BRACKET_SPEC, pictures.BRACKET_MOVE)
    png = (site / "img" / "tutorial-bracket-displacement.png").read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 10_000
    assert 'src="../../img/tutorial-bracket-displacement.png"' in _page(site, "tutorials/morph-a-deck")


def test_every_setting_is_on_the_settings_page_with_its_variable_and_default(site):
    from service.settings import Settings

    page = _page(site, "reference/settings")
    for name, field in Settings.model_fields.items():
        row = _row(page, f"<code>TETMORPH_{name.upper()}</code>")
        assert f"<code>{name}</code>" in row
        if field.default_factory is None:
            assert f"<code>{field.default}</code>" in row, (name, field.default)


#: An environment variable a module reads: ``TETMORPH_*`` anywhere, or any name looked up in ``os.environ``.
ENV_READ = re.compile(r"\b(TETMORPH_[A-Z0-9_]*[A-Z0-9])\b"
                      r"|(?:\benv(?:iron)?\.get|getenv|environ\[)\(?\s*[\"']([A-Z][A-Z0-9_]+)[\"']"
                      r"|[\"']([A-Z][A-Z0-9_]+)[\"'] (?:not )?in os\.environ")


def test_every_environment_variable_the_code_reads_is_on_the_settings_page(site):
    page = re.sub(r"<[^>]+>", "", _page(site, "reference/settings"))
    read: dict[str, str] = {}
    for source in sorted((ROOT / "solver").rglob("*.py")) + sorted((ROOT / "service").rglob("*.py")):
        for groups in ENV_READ.findall(source.read_text()):
            read.setdefault(next(g for g in groups if g), source.relative_to(ROOT).as_posix())
    assert {"TETMORPH_SOLVER", "TETMORPH_DATABASE_URL", "TETMORPH_MKL_RT"} <= set(read)
    missing = sorted(f"{name} ({where})" for name, where in read.items() if not re.search(rf"\b{name}\b", page))
    assert not missing, f"read by the code, not on the settings page: {missing}"


def _error_codes() -> dict[str, int | None]:
    """Every error code: the two error modules' tables and classes, and every literal code raised."""
    import service.errors as sv
    import solver.errors as se

    codes: dict[str, int | None] = dict(sv.CODE_STATUS)
    codes.update({c: s for s, c in sv.HTTP_CODES.items() if c not in codes})
    for name in se.__all__:
        cls = getattr(se, name)
        if isinstance(cls, type) and issubclass(cls, se.SolverError):
            codes.setdefault(cls.default_code, None)
            listed = re.sub(r"\([^)]*\)", "", (cls.__doc__ or "").partition("Codes:")[2], flags=re.S)
            for c in re.findall(r"``(\w+)``", listed):
                codes.setdefault(c, None)
    for source in list((ROOT / "solver").rglob("*.py")) + list((ROOT / "service").rglob("*.py")):
        s = source.read_text()
        for c in re.findall(r"\bcode=[\"']([a-z_]+)[\"']", s) + re.findall(r"ServiceError\(\s*[\"']([a-z_]+)[\"']", s):
            codes.setdefault(c, None)
        for status, c in re.findall(r"\benvelope\(\s*(\d+),\s*[\"']([a-z_]+)[\"']", s):  # answered directly
            codes.setdefault(c, int(status))
    return codes


def test_every_error_code_is_on_the_errors_page_with_its_status_meaning_and_fix(site):
    page = _page(site, "reference/errors")
    codes = _error_codes()
    assert len(codes) > 80
    unexplained = []
    for c, status in codes.items():
        row = _row(page, f'id="{c}"')
        if status is not None:
            assert f"<td>{status}</td>" in row, (c, status)
        cells = [re.sub(r"<[^>]+>", "", cell).strip() for cell in re.findall(r"<td>(.*?)</td>", row, re.S)]
        if not (cells[2] and cells[3]):  # code, HTTP, meaning, fix
            unexplained.append(c)
    assert not unexplained, f"codes without a meaning or a fix in docs/hooks/reference_text.py: {unexplained}"


def test_every_route_is_on_the_rest_page(site):
    from service.app import create_app
    from service.settings import Settings

    page = _page(site, "reference/rest")
    doc = create_app(Settings(data_dir=site.parent / "data", load_kernels=False)).openapi()
    for path, ops in doc["paths"].items():
        for method in ops:
            assert f"{method.upper()} <code>{path}</code>" in page, (method, path)


def test_every_format_is_on_the_formats_page_with_what_it_keeps(site):
    from service.formats import capabilities

    page = _page(site, "reference/formats")
    for f in capabilities():
        cells = re.findall(r"<td>(.*?)</td>", _row(page, f"<code>{f['name']}</code>"))
        assert f"<code>{f['extension']}</code>" in cells[1], f["name"]
        marks = ["—" if f[k] is None else "yes" if f[k] else "no"  # None: not measured (written back in place)
                 for k in ("read", "write", "sets", "quadratic", "mixed", "needs", "available", "in_place")]
        assert cells[2:7] == marks[:5] and cells[9] == marks[7], (f["name"], cells)
        if f["reads"]:  # a format of tetmorph's own readers: what it reads and refuses, as registered
            import html

            section = page.split(f">{html.escape(f['title'], quote=False)}<", 1)[1][:4000]
            assert "Reads:" in section and "Refuses:" in section, f["name"]
            assert html.escape(f["reads"], quote=False).split(",")[0] in section, f["name"]


def _section(html_text: str, anchor: str) -> str:
    """The part of a page from the heading with id ``anchor`` to the next heading."""
    after = html_text.split(f'id="{anchor}"', 1)[1]
    return re.split(r"<h[1-3][ >]", after, maxsplit=1)[0]


def test_every_field_of_the_documents_and_their_parts_is_on_the_documents_page(site):
    import json

    from service.models.session import SessionPatch
    from solver.documents.move import Move
    from solver.documents.report import Report
    from solver.documents.shapes import Shapes
    from solver.documents.spec import Spec

    page = _page(site, "reference/documents")
    checked = 0
    for model in (Spec, Move, Report, Shapes, SessionPatch):
        mode = "serialization" if model is Report else "validation"
        schema = model.model_json_schema(mode=mode)
        for name, s in [(model.__name__, schema), *schema.get("$defs", {}).items()]:
            section = _section(page, name.lower())
            for field in s.get("properties", {}):
                assert f"<code>{field}</code>" in section, (name, field)
                checked += 1
        section = _section(page, model.__name__.lower())
        for field, info in model.model_fields.items():
            if info.default_factory is not None:  # a default made by a factory is shown too
                default = json.dumps(info.default_factory())
                assert f"<code>{default}</code>" in _row(section, f"<code>{field}</code>"), (model.__name__, field)
    assert checked > 150


def test_the_guides_grammar_names_every_field_of_spec_move_and_report():
    from solver.documents.move import Move
    from solver.documents.report import Report
    from solver.documents.spec import Spec

    (grammar,) = _blocks(ROOT / "docs" / "guide" / "documents.md", "text")
    for model, start, end in ((Spec, "SPEC      =", "POINT     ="), (Move, "MOVE      =", "REPORT    ="),
                              (Report, "REPORT    =", None)):
        part = grammar.split(start, 1)[1]
        part = part.split(end, 1)[0] if end else part
        missing = [f for f in model.model_fields if f'"{f}"' not in part]
        assert not missing, f"docs/guide/documents.md: the {model.__name__} grammar leaves out {missing}"


def _needs_ccx(page: Path) -> bool:
    return any(re.search(r"\bccx\b", s) for s in _blocks(page, "sh"))


def _marks(page: Path) -> list:
    marks = [pytest.mark.ccx] if _needs_ccx(page) else []
    if any("serve_process" in c for c in _blocks(page, "python")) or any("--engine ray" in s
                                                                          for s in _blocks(page, "sh")):
        marks.append(pytest.mark.slow)  # a real server process or a Ray cluster: make test, not make check
    return marks


#: Pages whose blocks another test runs: the cluster page needs PostgreSQL and HAProxy, which `make test`
#: installs and `make check` does not; tests/cluster/test_cluster_tutorial.py runs its blocks.
RUN_ELSEWHERE = {"cluster.md": "run by tests/cluster/test_cluster_tutorial.py (PostgreSQL and HAProxy)"}


def _params(page: Path):
    if page.name in RUN_ELSEWHERE:
        return pytest.param(page, marks=pytest.mark.skip(reason=RUN_ELSEWHERE[page.name]))
    return pytest.param(page, marks=_marks(page))


def _optimize_table_is_this_run(text: str, work: Path) -> None:
    """The history the optimize page shows is the one its commands wrote (to its rounding)."""
    import csv

    table = text.split("A run of this page", 1)[1]
    shown = [[c.strip() for c in line.strip().strip("|").split("|")]
             for line in table.splitlines() if re.match(r"\| \d+ \|", line)]
    run = list(csv.DictReader((work / "out" / "opt" / "history.csv").open()))
    assert len(shown) == len(run) >= 4
    for row, got in zip(shown, run, strict=True):
        evaluation, iteration, role, move1, move2, objective = row
        assert (evaluation, iteration, role) == (got["evaluation"], got["iteration"], got["role"])
        for value, key in ((move1, "move1"), (move2, "move2")):
            assert float(value) == pytest.approx(float(got[key]), abs=0.006), (evaluation, key)
        assert float(objective) == pytest.approx(float(got["objective"]), abs=0.06), evaluation


#: Checks after a page ran: what the page states about its own run is what the run gave.
AFTER_RUN = {"optimize.md": _optimize_table_is_this_run}


@pytest.mark.parametrize("page", [_params(p) for p in TUTORIALS], ids=[p.stem for p in TUTORIALS])
def test_every_block_of_a_tutorial_runs_as_written(page, checkout, monkeypatch):
    """The page's Python and shell blocks run in the order they appear, sharing the environment,
    in an empty folder, and each prints what the ``text`` block after it shows."""
    monkeypatch.setenv("PATH", f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")  # venv on
    monkeypatch.setenv("TETMORPH_URL", "")  # a page may set it for its shell blocks; restored afterwards
    text = page.read_text()
    run_steps(steps_with_output(text), checkout, page.name)
    if page.name in AFTER_RUN:
        AFTER_RUN[page.name](text, checkout)
