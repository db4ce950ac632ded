"""The editor's quality-check panel (issue 43): criteria with thresholds typed in the page, the service's
answer shown per criterion, the failing elements listed by deck id, isolated in the view and downloaded.

The numbers on the page are checked against :func:`solver.validity.criteria.quality_check` computed here,
and the downloads are read back. Each test failed before the panel was added (no #sec-check).
"""

from __future__ import annotations

import csv
import io
import re

import numpy as np
import pytest

from solver import read_mesh
from solver.io.element_sets import deck_element_ids
from solver.validity.criteria import CRITERIA, PRESETS, quality_check
from tests.browser.conftest import BRACKET, DATA, canvas_box, image, load_bracket, numeric_move, set_session, settle

CCX = DATA / "ccx_bracket.inp"  # C3D10


def open_panel(pg) -> None:
    pg.click("#sec-check summary")
    pg.wait_for_function("document.querySelector('[data-threshold=min_scaled_jacobian]') &&"
                         " document.querySelector('[data-threshold=min_scaled_jacobian]').value !== ''")


def type_thresholds(pg, values: dict[str, float | None]) -> None:
    """Type a threshold per criterion; None unticks it."""
    for name, v in values.items():
        if v is None:
            pg.uncheck(f"[data-on={name}]")
        else:
            pg.check(f"[data-on={name}]")
            pg.fill(f"[data-threshold={name}]", str(v))


def run(pg) -> dict:
    before = pg.evaluate("JSON.stringify(window.tetmorph.checks().result)")
    pg.click("#check-run")
    pg.wait_for_function(f"JSON.stringify(window.tetmorph.checks().result) !== {before!r}", timeout=60000)
    return pg.evaluate("window.tetmorph.checks().result")


def shown(pg) -> dict[str, dict]:
    """Per criterion row of the table: the result text, the failing count, the worst value and element."""
    return pg.evaluate("""() => Object.fromEntries([...document.querySelectorAll('#check-table tr[data-criterion]')]
        .map((tr) => { const w = tr.querySelector('[data-cell=worst]'), r = tr.querySelector('[data-cell=result]');
          return [tr.dataset.criterion, {result: r.textContent, failing: r.dataset.failing, worst: w.dataset.value,
            element: w.dataset.element, text: w.textContent}]; }))""")


def assert_matches_library(pg, lib, ids: np.ndarray) -> None:
    rows = shown(pg)
    for r in lib.results:
        row = rows[r.name]
        if r.threshold is None:
            assert row["result"] == "off", r.name
            continue
        assert int(row["failing"]) == r.failing.size, r.name
        expected = "n/a" if not r.applicable else "pass" if r.passed else f"fail {r.failing.size:,}"
        assert row["result"] == expected, r.name
        if r.worst is None:
            assert row["worst"] == "", r.name
        else:
            assert float(row["worst"]) == pytest.approx(r.worst, rel=1e-9, abs=1e-12), r.name
            assert int(row["element"]) == ids[r.worst_element], r.name
            assert float(row["text"].replace(",", "")) == pytest.approx(r.worst, rel=1e-3, abs=1e-6), r.name
        listed = pg.evaluate("(n) => { const e = document.querySelector(`[data-ids=${n}]`);"
                             " return e ? e.textContent : ''; }", r.name)
        got = [int(x) for x in re.findall(r"\d+", listed.split("…")[0])]
        assert got == ids[r.failing][:200].tolist(), r.name  # ascending deck ids
    total = lib.failing.size
    status = pg.inner_text("#check-status")
    assert (f"{total:,} of {lib.elements:,} elements fail" in status) if total else status.startswith("passed")


def downloads(pg, tmp_path) -> tuple[list[dict], list[int]]:
    with pg.expect_download() as dl:
        pg.click("#check-csv")
    p = tmp_path / dl.value.suggested_filename
    dl.value.save_as(p)
    rows = list(csv.DictReader(io.StringIO(p.read_text())))
    with pg.expect_download() as dl:
        pg.click("#check-elset")
    q = tmp_path / dl.value.suggested_filename
    dl.value.save_as(q)
    text = q.read_text()
    assert text.startswith("*ELSET, ELSET=FAILED_QUALITY")
    elset = [int(x) for line in text.splitlines()[1:] for x in line.split(",") if x.strip()]
    return rows, elset


def orange(png: bytes) -> int:
    """Pixels in the isolated elements' orange, lit or in shade (the surface is grey, the background white)."""
    a = image(png)
    R, G, B = a[..., 0], a[..., 1], a[..., 2]
    return int(((R > 90) & (R - B > 60) & (R - G > 30)).sum())


def test_the_quality_check_shows_the_library_numbers_isolates_and_exports_the_failing_ids(page, tmp_path):
    load_bracket(page)
    open_panel(page)
    for name in CRITERIA:  # the preset's thresholds offered, as the library has them
        t = getattr(PRESETS["tetmorph"], name)
        assert float(page.input_value(f"[data-threshold={name}]")) == pytest.approx(t)
        assert page.is_checked(f"[data-on={name}]")
    page.select_option("#check-preset", "calculix")  # a preset that leaves criteria out
    page.wait_for_function("document.querySelector('[data-threshold=max_aspect_ratio]').value === ''")
    assert not page.is_checked("[data-on=max_aspect_ratio]") and page.is_checked("[data-on=min_scaled_jacobian]")
    page.select_option("#check-preset", "tetmorph")
    page.wait_for_function("document.querySelector('[data-threshold=max_aspect_ratio]').value === '10'")
    typed = {"max_aspect_ratio": 1.6, "min_dihedral": 32, "max_dihedral": None, "min_scaled_jacobian": 0.55}
    type_thresholds(page, typed)
    result = run(page)
    assert result["on"] == "mesh" and not result["passed"]
    mesh = read_mesh(BRACKET)
    ids = deck_element_ids(mesh)
    assert ids[0] != 1  # the deck numbers its tets after its surface elements: deck ids, not positions
    lib = quality_check(mesh.V, mesh.T, PRESETS["tetmorph"].replace(**typed), cells=mesh.cells, T10=mesh.T10, ids=ids)
    assert lib.failing.size > 20 and not lib.results[2].passed and not lib.results[3].passed
    assert_matches_library(page, lib, ids)
    # isolate: only the failing elements are drawn, the surface is hidden as Isolate hides it
    full = page.evaluate("window.tetmorph.view().visibleFaces")
    b = canvas_box(page)
    before = page.screenshot(clip={"x": b["x"], "y": b["y"], "width": b["w"], "height": b["h"]})
    page.click("#check-isolate")
    page.wait_for_timeout(200)  # a frame drawn
    iso = page.evaluate("window.tetmorph.checks().isolated")
    assert iso["elements"] == lib.failing.tolist()
    assert page.evaluate("window.tetmorph.view().visibleFaces") == 0
    after = page.screenshot(clip={"x": b["x"], "y": b["y"], "width": b["w"], "height": b["h"]})
    assert orange(after) > 10 * max(orange(before), 500)  # (before: the triad's red arrow only)
    # one criterion's elements
    page.click("#check-ids button[data-isolate=max_aspect_ratio]")
    assert page.evaluate("window.tetmorph.checks().isolated")["elements"] == lib.results[2].failing.tolist()
    page.click("#show-all")
    assert page.evaluate("window.tetmorph.view().visibleFaces") == full
    assert page.evaluate("window.tetmorph.checks().isolated") is None
    # the downloads list the same ids, one CSV row per failure
    rows, elset = downloads(page, tmp_path)
    want = sorted((int(ids[e]), r.name) for r in lib.results for e in r.failing)
    assert sorted((int(r["element"]), r["criterion"]) for r in rows) == want
    assert elset == ids[lib.failing].tolist()


def test_a_tet10_session_is_checked_at_its_current_shape(page, tmp_path):
    set_session(page, CCX, "FIXED", "LOAD")
    numeric_move(page, t=(0, 0, -12))
    settle(page)
    open_panel(page)
    assert page.input_value("#check-on") == "session"
    typed = {"min_scaled_jacobian_ip": 0.6, "min_volume_ratio": 0.97, "max_volume_ratio": 1.02}
    type_thresholds(page, typed)
    result = run(page)
    assert result["on"] == "session" and result["deformed"]
    sid = page.evaluate("window.tetmorph.session().id")
    # the session's shape, read back from its own deck (the service's positions, not the page's float32)
    import httpx

    deck = tmp_path / "deformed.inp"
    deck.write_bytes(httpx.get(f"{page.base}/v1/sessions/{sid}/mesh?format=inp").content)
    now, mesh = read_mesh(deck), read_mesh(CCX)
    assert mesh.T10 is not None
    ids = deck_element_ids(mesh)
    lib = quality_check(now.V, mesh.T, PRESETS["tetmorph"].replace(**typed), cells=mesh.cells, T10=mesh.T10,
                        V0=mesh.V, ids=ids)
    assert not lib.results[1].passed and not lib.results[5].passed  # Gauss points and volume both fail some
    assert lib.results[1].applicable == mesh.elements
    assert_matches_library(page, lib, ids)
    rows, elset = downloads(page, tmp_path)
    assert sorted((int(r["element"]), r["criterion"]) for r in rows) == sorted(
        (int(ids[e]), r.name) for r in lib.results for e in r.failing)
    assert elset == ids[lib.failing].tolist()
    # the mesh at rest, chosen instead: no volume ratio
    page.select_option("#check-on", "mesh")
    run(page)
    assert shown(page)["min_volume_ratio"]["result"] == "n/a"
    rest = quality_check(mesh.V, mesh.T, PRESETS["tetmorph"].replace(**typed), cells=mesh.cells, T10=mesh.T10, ids=ids)
    assert_matches_library(page, rest, ids)
    np.testing.assert_array_equal(page.evaluate("window.tetmorph.checks().result.failing_elements"), rest.failing.size)
