"""The browser editor in a real browser: Debian's chromium, headless, driven by Playwright.

A real ``tetmorph serve`` runs in a subprocess; the page is loaded from it (fixtures in
conftest.py). ``make test`` builds the editor and installs chromium when they are missing;
without them these tests fail and say why.
"""

from __future__ import annotations

import json

import httpx
import meshio
import numpy as np

from solver import precompute, read_mesh
from tests.browser.conftest import BRACKET, confirm, differs, drag_pivot, load_bracket, settle, shot


def select_and_create(pg, handle_by_box: bool = True, policy: str = "warn") -> None:
    # fixed: the file's node set
    pg.select_option("#sets", "FIXED")
    pg.click("#set-apply")
    pg.check("input[name=role][value='2']")
    if handle_by_box:  # handle: a box drawn with the mouse around the x = 100 end
        ids = pg.evaluate("window.tetmorph.set('LOAD')")
        pts = pg.evaluate("(ids) => ids.map((i) => window.tetmorph.screenOf(i))", ids)
        xs, ys = [p["x"] for p in pts], [p["y"] for p in pts]
        pg.check("input[name=tool][value='box']")
        pg.mouse.move(min(xs) - 6, min(ys) - 6)
        pg.mouse.down()
        pg.mouse.move((min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2, steps=3)
        pg.mouse.move(max(xs) + 6, max(ys) + 6, steps=3)
        pg.mouse.up()
        pg.check("input[name=tool][value='orbit']")
    else:
        pg.select_option("#sets", "LOAD")
        pg.click("#set-apply")
    pg.select_option("#policy", policy)
    pg.click("#create")
    pg.wait_for_function("window.tetmorph.session().id !== null", timeout=30000)


def test_upload_select_drag_download_matches_the_library(page, server, tmp_path):
    load_bracket(page)
    select_and_create(page)
    role = np.array(page.evaluate("window.tetmorph.role()"))
    load_set = read_mesh(BRACKET).sets["LOAD"]
    assert (role[load_set] == 2).all() and (role == 1).sum() == read_mesh(BRACKET).sets["FIXED"].size
    before = shot(page, "editor-before-drag")
    p0 = np.array(page.evaluate("window.tetmorph.positions()"))
    # drag the gizmo with the real mouse: press on its centre, move up
    drag_pivot(page, -24, -84)
    settle(page)
    after = shot(page, "editor-after-drag")
    p1 = np.array(page.evaluate("window.tetmorph.positions()"))
    assert np.abs(p1 - p0).max() > 1.0  # the mesh moved by more than a millimetre
    assert differs(before, after) > 2000  # and the picture on screen changed
    sid = page.evaluate("window.tetmorph.session().id")
    with httpx.Client(base_url=server) as c_:
        server_pos = np.array(c_.get(f"/v1/sessions/{sid}/positions").json()["positions"])
        doc = c_.get(f"/v1/sessions/{sid}").json()
    np.testing.assert_allclose(p1.reshape(-1, 3), server_pos, atol=1e-4)  # float32 on the wire
    # download the deformed mesh as VTU through the page, compare with the library's result
    page.select_option("#format", "vtu")
    with page.expect_download() as dl:
        page.click("#download")
    path = tmp_path / "deformed.vtu"
    dl.value.save_as(path)
    got = np.asarray(meshio.read(path).points)
    expected = precompute(read_mesh(BRACKET), doc["spec"]).solve(doc["last_move"]).V
    np.testing.assert_allclose(got, expected, atol=1e-9)
    assert json.loads(json.dumps(page.evaluate("window.tetmorph.session().lastMove"))) == doc["last_move"]


def test_numeric_moves_undo_and_reset(page, server):
    load_bracket(page)
    select_and_create(page, handle_by_box=False)
    page.fill("#tz", "5")
    page.click("#apply-move")
    settle(page)
    first = np.array(page.evaluate("window.tetmorph.positions()"))
    page.fill("#tz", "10")
    page.click("#apply-move")
    settle(page)
    second = np.array(page.evaluate("window.tetmorph.positions()"))
    assert np.abs(second - first).max() > 1.0
    page.click("#undo")
    settle(page)
    np.testing.assert_allclose(np.array(page.evaluate("window.tetmorph.positions()")), first, atol=1e-5)
    page.click("#reset")
    confirm(page)
    page.wait_for_function("window.tetmorph.report() && window.tetmorph.report().reset === true")
    V0 = np.array(page.evaluate("window.tetmorph.rest()"))
    np.testing.assert_array_equal(np.array(page.evaluate("window.tetmorph.positions()")), V0)


def test_clipping_shows_interior_tets_and_colours_bad_ones(page):
    load_bracket(page)
    select_and_create(page, handle_by_box=False)
    # a hard twist of the handle end: some tets become poor or inverted
    page.fill("#ax", "1"), page.fill("#ay", "0"), page.fill("#az", "0"), page.fill("#angle", "150")
    page.click("#apply-move")
    settle(page)
    bad = page.evaluate("window.tetmorph.view().badCount")
    assert bad > 0
    plain = shot(page, "editor-unclipped")
    page.check("#clip")
    page.select_option("#clip-axis", "1")
    page.wait_for_function("window.tetmorph.view().cut > 0")
    cut = page.evaluate("window.tetmorph.view().cut")
    clipped = shot(page, "editor-clipped")
    assert differs(plain, clipped) > 2000
    # moving the plane changes which tets are cut
    page.fill("#clip-pos", "0.2")
    page.dispatch_event("#clip-pos", "input")
    page.wait_for_function(f"window.tetmorph.view().cut !== {cut}")
    assert "tets in the section" in page.inner_text("#cut-count")


def test_error_panel_shows_the_report_of_a_rejected_move(page):
    load_bracket(page)
    select_and_create(page, handle_by_box=False, policy="reject")
    page.fill("#tx", "-90"), page.fill("#ax", "0"), page.fill("#ay", "1"), page.fill("#az", "0")
    page.fill("#angle", "170")
    page.click("#apply-move")
    page.wait_for_selector("#errors:not([hidden])", timeout=30000)
    text = page.inner_text("#error-text")
    assert "inverted_elements" in text and "safe fraction" in text
    shot(page, "editor-error-panel")
    # the session stayed where it was: the rest shape
    V0 = np.array(page.evaluate("window.tetmorph.rest()"))
    np.testing.assert_array_equal(np.array(page.evaluate("window.tetmorph.positions()")), V0)


def test_brush_paints_vertices_near_the_cursor(page):
    load_bracket(page)
    page.check("input[name=role][value='2']")
    page.check("input[name=tool][value='brush']")
    # press on the middle of the x = 100 end face as drawn, and paint a short stroke
    ids = page.evaluate("window.tetmorph.set('LOAD')")
    pts = page.evaluate("(ids) => ids.map((i) => window.tetmorph.screenOf(i))", ids)
    x, y = np.mean([q["x"] for q in pts]), np.mean([q["y"] for q in pts])
    page.mouse.move(x, y - 4)
    page.mouse.down()
    page.mouse.move(x, y + 4, steps=4)
    page.mouse.up()
    role = np.array(page.evaluate("window.tetmorph.role()"))
    V = np.array(page.evaluate("window.tetmorph.rest()")).reshape(-1, 3)
    painted = np.flatnonzero(role == 2)
    assert painted.size > 0
    # all of them on the boundary and near the x = 100 end (brush radius 4% of the diagonal)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    assert V[painted, 0].min() > 100 - 0.15 * diag
    boundary = np.array(page.evaluate("window.tetmorph.boundary()"))
    assert boundary[painted].all()


def test_the_test_hook_answers_copies_and_holds_no_state(page):
    load_bracket(page)
    page.select_option("#sets", "FIXED")
    page.click("#set-apply")
    hook = page.evaluate("(() => { const t = window.tetmorph; return {state: 'state' in t, frozen: Object.isFrozen(t),"
                         " fns: Object.keys(t).filter((k) => typeof t[k] !== 'function')}; })()")
    assert hook == {"state": False, "frozen": True, "fns": ["qualityColors"]}
    fixed = read_mesh(BRACKET).sets["FIXED"]
    # what an accessor answers is a copy: changing it changes nothing the editor holds
    after = page.evaluate("(() => { const r = window.tetmorph.role(); r.fill(0); const m = window.tetmorph.mesh();"
                          " m.name = 'x'; return [window.tetmorph.role(), window.tetmorph.mesh().name]; })()")
    role = np.array(after[0])
    assert (role[fixed] == 1).all() and (role == 1).sum() == len(fixed) and after[1] == BRACKET.name
