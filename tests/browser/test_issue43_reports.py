"""Issue 43, defects 4 and 7, driven in a real browser as a person does (file chooser, typed moves, clicks).

Defect 4: the "original format" download of an ASCII legacy VTK is the uploaded file, only its
coordinate lines changed. Defect 7: the REPORT and the error panel name the nodes of conflicting
constraints (by their deck numbers) and say what to do, and warn of a free node outrunning the
handles only when it does (by more than the threshold the warning states). The MOVE counter
starting again in each session is tests/browser/test_workspace.py's
test_the_move_counter_starts_again_with_each_session.
"""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from solver import ConstraintError, precompute, read_mesh
from tests.browser.conftest import (
    BRACKET,
    DATA,
    bracket_session,
    confirm,
    create,
    numeric_move,
    positions,
    report_row,
    rest,
    settle,
    use_spec,
)
from tests.browser.test_regions import deck_numbers

WHEELSET = DATA / "wheelset.vtk"


def choose_file(pg, path) -> None:
    """Upload… and pick the file in the chooser, as a person does; wait until the mesh is open."""
    with pg.expect_file_chooser() as fc:
        pg.click("#upload-btn")
    fc.value.set_files(str(path))
    pg.wait_for_function(f"window.tetmorph.mesh().open && window.tetmorph.mesh().name === {path.name!r}",
                         timeout=60000)


def coordinate_block(lines: list[bytes]) -> tuple[int, int]:
    """[first, end) of a legacy VTK's coordinate lines: after POINTS, up to the next keyword."""
    start = next(i for i, s in enumerate(lines) if s.strip().upper().startswith(b"POINTS")) + 1
    end = next(k for k in range(start, len(lines)) if lines[k].strip()[:1].isalpha())
    return start, end


def test_the_original_format_download_of_an_ascii_vtk_is_the_uploaded_file(page, tmp_path):
    spec = {"selections": {"a": {"ids": [0]}, "b": {"ids": [100]}}, "fixed": ["a"], "handles": {"h": "b"}}
    t = [0.002, 0.0, 0.0]
    choose_file(page, WHEELSET)
    use_spec(page, spec)
    create(page)
    numeric_move(page, t=t)
    settle(page)
    own = page.locator("#format option").nth(0)
    assert own.get_attribute("value") == "" and "as uploaded" in own.inner_text() and "vtk" in own.inner_text()
    page.select_option("#format", "")
    with page.expect_download() as dl:
        page.click("#download")
    path = tmp_path / "back.vtk"
    dl.value.save_as(path)
    original, got = WHEELSET.read_bytes().splitlines(), path.read_bytes().splitlines()
    assert got[2] == b"ASCII"  # not turned binary
    assert len(got) == len(original)
    changed = [i for i, (a, b) in enumerate(zip(original, got, strict=True)) if a != b]
    lo, hi = coordinate_block(original)
    assert changed and all(lo <= i < hi for i in changed), (changed[:5], lo, hi)  # only coordinates differ
    # the positions read back are the library's solve of the same SPEC and MOVE
    want = precompute(read_mesh(WHEELSET), spec).solve({"handles": {"h": {"translation": t}}}).V
    back = meshio.read(path).points
    assert np.abs(back[100] - want[100]).max() < 1e-9
    np.testing.assert_allclose(back[100], read_mesh(WHEELSET).V[100] + t, atol=1e-9)
    np.testing.assert_allclose(back, want, atol=1e-9)


def _conflicting_spec(mesh) -> dict:
    """The bracket's FIXED end held, LOAD a handle, and two points pulling FIXED nodes away: they conflict."""
    fixed = mesh.sets["FIXED"]
    v, w = int(fixed[3]), int(fixed[17])
    return {"selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"set": "LOAD"}}, "fixed": ["FIXED"],
            "handles": {"LOAD": "LOAD"},
            "points": [{"name": "pull", "vertices": [v], "target": (mesh.V[v] + [0, 0, 1]).tolist()},
                       {"name": "push", "vertices": [w], "target": (mesh.V[w] + [0, 2, 0]).tolist()}]}


def test_conflicting_constraints_name_their_deck_nodes_and_what_to_do(page):
    mesh = read_mesh(BRACKET)
    labels, _ = deck_numbers(BRACKET)
    spec = _conflicting_spec(mesh)
    move = {"handles": {"LOAD": {"translation": [0, 0, 1]}}}
    rep = precompute(mesh, spec).solve(move).report
    nodes = sorted({v for e in rep["conflicting_constraints"] for v in e["vertices"]})
    assert len(nodes) == 2
    # "warn": the session is made, and the REPORT lists the nodes by their deck numbers
    choose_file(page, BRACKET)
    use_spec(page, spec)
    create(page)
    numeric_move(page, t=(0, 0, 1))
    settle(page)
    page.wait_for_selector("#report tr[data-key=conflicting_nodes]")
    at = report_row(page, "conflicting_nodes")
    assert at.startswith("deck nodes ")
    assert sorted(int(s.replace(",", "")) for s in at[len("deck nodes "):].split(", ")) == sorted(
        labels[v] for v in nodes)
    count = report_row(page, "conflicting")
    assert "pull" in count and "push" in count and "residual up to 2" in count
    assert "take them out of one region" in report_row(page, "conflicting_fix")
    # "reject": Create session is refused, and the error panel names the same deck nodes and what to do
    with pytest.raises(ConstraintError) as e:
        precompute(mesh, {**spec, "conflicts": "reject"})
    assert sorted(e.value.details["nodes"]) == nodes
    use_spec(page, {**spec, "conflicts": "reject"})
    page.click("#create")
    confirm(page)  # the warned session was moved: replace it
    page.wait_for_function("window.tetmorph.error() && window.tetmorph.error().code === 'conflicting_constraints'")
    said = page.inner_text("#error-text")
    line = next((s for s in said.splitlines() if s.startswith("at deck nodes ")), None)
    assert line is not None, said
    assert sorted(int(s.replace(",", "")) for s in line[len("at deck nodes "):].split(", ")) == sorted(
        labels[v] for v in nodes)
    assert "take them out of one region" in said


def test_the_free_node_warning_only_when_a_free_node_outruns_the_handles(page):
    mesh = read_mesh(BRACKET)
    V = mesh.V
    # an ordinary lift of the LOAD end: free nodes move at most as far as the handle, no warning
    bracket_session(page)
    numeric_move(page, t=(0, 0, 5))
    settle(page)
    d = np.linalg.norm(positions(page) - V, axis=1)
    free = np.setdiff1d(np.arange(len(V)), np.concatenate([mesh.sets["LOAD"], mesh.sets["FIXED"]]))
    assert d[free].max() <= 1.05 * d[mesh.sets["LOAD"]].max()
    assert report_row(page, "max_displacement") is not None  # the REPORT is shown
    assert report_row(page, "free_exceeds") is None
    # a slab across the middle turned 10° about y: the free end beyond it swings much further
    mid = 0.5 * (V[:, 0].min() + V[:, 0].max())
    slab = np.flatnonzero((np.abs(V[:, 0] - mid) < 3) & mesh.referenced)
    use_spec(page, {"selections": {"FIXED": {"set": "FIXED"}, "MID": {"ids": slab.tolist()}}, "fixed": ["FIXED"],
                    "handles": {"MID": "MID"}})
    create(page, replace=True)
    np.testing.assert_array_equal(positions(page), rest(page))
    numeric_move(page, axis=(0, 1, 0), angle=10)
    settle(page)
    d = np.linalg.norm(positions(page) - V, axis=1)
    free = np.setdiff1d(np.arange(len(V)), np.concatenate([slab, mesh.sets["FIXED"]]))
    ratio = d[free].max() / d[slab].max()
    assert ratio > 1.05
    page.wait_for_selector("#report tr[data-key=free_exceeds]")
    warning = report_row(page, "free_exceeds")
    assert f"moves {float(f'{ratio:.3g}'):g}× as far as the handles" in warning, (ratio, warning)
    assert "warned above 1.05×" in warning
