"""The editor's views, regions, moves, sessions, feedback, keyboard and onboarding in a real browser.

Each test drives the page with the real mouse and keyboard against a real server and checks
what the page shows against the service or the library.
"""

from __future__ import annotations

import json
import os

import httpx
import numpy as np
import pytest

from solver import read_mesh
from solver.constraints.features import feature_candidates
from solver.constraints.selection import select
from solver.validity.quality import scaled_jacobians
from tests.browser.conftest import (
    ARTIFACTS,
    BRACKET,
    DATA,
    ROOT,
    assign_set,
    bracket_session,
    canvas_box,
    confirm,
    create,
    differs,
    drag,
    image,
    load_bracket,
    numeric_move,
    positions,
    report_row,
    rest,
    settle,
    shared_file,
    upload,
)

DOCS_IMG = ROOT / "docs" / "img"


def camera_dir(pg) -> np.ndarray:
    c = pg.evaluate("window.tetmorph.camera()")
    d = np.array(c["position"]) - np.array(c["target"])
    return d / np.linalg.norm(d)


def server_positions(base: str, sid: str) -> np.ndarray:
    with httpx.Client(base_url=base) as c:
        return np.array(c.get(f"/v1/sessions/{sid}/positions").json()["positions"])


def regions(pg) -> dict:
    return {r["name"]: r for r in pg.evaluate("window.tetmorph.regions()")}


def focus_view(pg) -> None:
    """Keyboard focus on the page itself (not a field), as after clicking the view."""
    pg.evaluate("document.activeElement && document.activeElement.blur()")


# ---------------------------------------------------------------------------- orientation and views
def test_axes_triad_standard_views_and_fit(page):
    load_bracket(page)
    corner = image(page.locator("#canvas").screenshot())[-96:, :96]
    for rgb in ((214, 40, 40), (42, 157, 58), (31, 95, 214)):  # the x, y, z arrows
        assert (np.abs(corner - rgb).max(axis=2) < 40).sum() > 20
    cases = {"front": [0, -1, 0], "top": [0, 0, 1], "side": [1, 0, 0], "iso": np.ones(3) * [1, -1, 1] / np.sqrt(3)}
    for name, d in cases.items():
        page.click(f"[data-view={name}]")
        np.testing.assert_allclose(camera_dir(page), d, atol=1e-3)
    page.click("[data-view=front]")
    ax = page.evaluate("window.tetmorph.triadAxes()")
    assert ax["z"]["y"] < -0.99 and ax["x"]["x"] > 0.99  # z up, x right on screen
    focus_view(page)
    for key, name in (("7", "top"), ("3", "side"), ("1", "front"), ("0", "iso")):
        page.keyboard.press(key)
        np.testing.assert_allclose(camera_dir(page), cases[name], atol=1e-3)
    c0 = page.evaluate("window.tetmorph.camera()")
    dist0 = np.linalg.norm(np.subtract(c0["position"], c0["target"]))
    box = canvas_box(page)
    page.mouse.move(box["x"] + box["w"] / 2, box["y"] + box["h"] / 2)
    for _ in range(5):
        page.mouse.wheel(0, -300)
    page.wait_for_function(f"(() => {{ const c = window.tetmorph.camera(); return Math.hypot(...c.position.map("
                           f"(x, k) => x - c.target[k])) < {0.8 * dist0}; }})()")
    page.keyboard.press("f")  # Fit: the whole model again, same direction, z still up
    c1 = page.evaluate("window.tetmorph.camera()")
    assert np.linalg.norm(np.subtract(c1["position"], c1["target"])) == pytest.approx(dist0, rel=1e-3)
    np.testing.assert_allclose(camera_dir(page), cases["iso"], atol=1e-3)
    assert c1["up"] == [0, 0, 1]


def test_rest_ghost_and_displacement_colour_map(page):
    bracket_session(page)
    numeric_move(page, t=(0, 0, 10))
    settle(page)
    plain = page.locator("#canvas").screenshot()
    page.check("#ghost")
    assert page.evaluate("window.tetmorph.ghostVisible()")
    page.wait_for_timeout(200)
    assert differs(plain, page.locator("#canvas").screenshot()) > 1000
    assert "rest shape" in page.inner_text("#legend")
    page.select_option("#color-by", "displacement")
    legend = page.inner_text("#legend")
    assert "displacement magnitude (mm)" in legend
    assert page.inner_text("[data-key=disp-max]") == "10"
    mesh = read_mesh(BRACKET)
    np.testing.assert_allclose(page.evaluate(f"window.tetmorph.surfaceColor({int(mesh.sets['LOAD'][0])})"), [1, 0, 0],
                               atol=1e-4)  # the handle moved the most: red
    np.testing.assert_allclose(page.evaluate(f"window.tetmorph.surfaceColor({int(mesh.sets['FIXED'][0])})"), [0, 0, 1],
                               atol=1e-4)  # the fixed end not at all: blue
    page.select_option("#units", "in")
    assert "displacement magnitude (in)" in page.inner_text("#legend")


# ---------------------------------------------------------------------------- regions
def box_over(pg, lo, hi, modifiers=()):
    """Drag a selection box over the screen rectangle spanning two world points."""
    a = pg.evaluate("(p) => window.tetmorph.worldToPage(p)", list(lo))
    b = pg.evaluate("(p) => window.tetmorph.worldToPage(p)", list(hi))
    drag(pg, a["x"], a["y"], b["x"], b["y"], steps=4, modifiers=modifiers)


def test_regions_list_with_counts_visibility_delete_modifiers_and_front_only_box(page):
    load_bracket(page)
    mesh = read_mesh(BRACKET)
    V = mesh.V
    focus_view(page)
    page.keyboard.press("7")  # top view: x right, y up on screen
    assign_set(page, "FIXED", 1)
    page.check("input[name=role][value='2']")
    page.check("input[name=tool][value='box']")
    box_over(page, (88, -3, 10), (102, 23, 10))  # through: the top and the bottom of the x > 88 end
    r = regions(page)
    assert r["FIXED"]["count"] == mesh.sets["FIXED"].size and r["FIXED"]["kind"] == "fixed"
    role = np.array(page.evaluate("window.tetmorph.role()"))
    through = np.flatnonzero(role == 2)
    assert V[through, 2].min() < 1e-9 and V[through, 2].max() > 10 - 1e-9
    page.select_option("#box-mode", "front")
    box_over(page, (88, -3, 10), (102, 23, 10))  # plain drag: replaces the region, front surface only
    role = np.array(page.evaluate("window.tetmorph.role()"))
    front = np.flatnonzero(role == 2)
    assert 0 < front.size < through.size
    assert V[front, 2].min() > 10 - 0.5  # no vertex of the hidden bottom face
    page.select_option("#box-mode", "through")
    n0 = regions(page)["handle1"]["count"]
    box_over(page, (70, -3, 10), (80, 23, 10), modifiers=("Shift",))  # Shift adds
    n1 = regions(page)["handle1"]["count"]
    assert n1 > n0
    box_over(page, (70, -3, 10), (80, 23, 10), modifiers=("Control",))  # Ctrl subtracts
    assert regions(page)["handle1"]["count"] == n0
    # a second handle region, from the list's button, painted with the brush
    page.click("#add-handle")
    page.check("input[name=tool][value='brush']")
    c = page.evaluate("(p) => window.tetmorph.worldToPage(p)", [50, 10, 10])
    drag(page, c["x"] - 5, c["y"], c["x"] + 5, c["y"], steps=3)
    r = regions(page)
    assert set(r) == {"FIXED", "handle1", "handle2"} and r["handle2"]["count"] > 0
    assert page.locator("#regions li").count() == 3
    assert page.inner_text("#regions li:nth-child(3) .count") == f"{r['handle2']['count']:,}"
    # visibility: a hidden region is drawn uncoloured; delete takes its vertices out
    i = int(front[0])
    coloured = page.evaluate(f"window.tetmorph.surfaceColor({i})")
    page.uncheck("#regions li:nth-child(2) input[data-act=visible]")
    assert page.evaluate(f"window.tetmorph.surfaceColor({i})") != coloured
    page.check("#regions li:nth-child(2) input[data-act=visible]")
    assert page.evaluate(f"window.tetmorph.surfaceColor({i})") == pytest.approx(coloured)
    page.click("#regions li:nth-child(3) button[data-act=delete]")
    assert set(regions(page)) == {"FIXED", "handle1"}
    spec = page.evaluate("window.tetmorph.spec()")
    assert spec["fixed"] == ["FIXED"] and spec["handles"] == {"handle1": "handle1"}
    create(page)


def test_brush_cursor_preview(page):
    load_bracket(page)
    page.check("input[name=tool][value='brush']")
    ids = page.evaluate("window.tetmorph.set('LOAD')")
    pts = page.evaluate("(ids) => ids.map((i) => window.tetmorph.screenOf(i))", ids)
    x, y = np.mean([q["x"] for q in pts]), np.mean([q["y"] for q in pts])
    page.mouse.move(x, y)
    ring = page.evaluate("window.tetmorph.ring()")
    assert ring["visible"]
    assert ring["position"][0] == pytest.approx(100, abs=1e-3)  # on the x = 100 end face
    diag = page.evaluate("window.tetmorph.mesh().diag")
    assert ring["radius"] == pytest.approx(0.04 * diag)  # the brush radius, 4 % of the size
    page.fill("#brush", "10")
    page.mouse.move(x, y + 1)
    assert page.evaluate("window.tetmorph.ring()")["radius"] == pytest.approx(0.1 * diag)
    box = canvas_box(page)
    page.mouse.move(box["x"] + 5, box["y"] + 5)  # off the mesh
    assert not page.evaluate("window.tetmorph.ring()")["visible"]


def test_feature_candidates_are_one_click_regions(page):
    load_bracket(page)
    page.click("#find-features")
    page.wait_for_selector("#features li button")
    text = page.inner_text("#features")
    assert "hole_1" in text and "plane_6" in text
    page.click("#features li:has-text('hole_1') button[data-kind=fixed]")
    r = regions(page)["hole_1"]
    expected = next(c for c in feature_candidates(read_mesh(BRACKET), 30, 1e-3) if c.name == "hole_1")
    ids = np.array(expected.to_dict()["selection"]["ids"])
    assert r["kind"] == "fixed" and r["count"] == ids.size == 61
    role = np.array(page.evaluate("window.tetmorph.role()"))
    assert set(np.flatnonzero(role == 1)) == set(ids.tolist())
    page.click("#features li:has-text('plane_6') button[data-kind=handle]")
    assert regions(page)["plane_6"]["kind"] == "handle"
    create(page)


def test_the_spec_is_shown_exported_and_imported(page, tmp_path):
    load_bracket(page)
    assign_set(page, "FIXED", 1)
    assign_set(page, "LOAD", 2)
    page.click("#spec-view")
    shown = json.loads(page.input_value("#spec-text"))
    assert shown["selections"] == {"FIXED": {"set": "FIXED"}, "LOAD": {"set": "LOAD"}}
    with page.expect_download() as dl:
        page.click("#spec-export")
    path = tmp_path / "spec.json"
    dl.value.save_as(path)
    assert json.loads(path.read_text()) == shown
    page.click("#spec-close")
    create(page)
    sid = page.evaluate("window.tetmorph.session().id")
    with httpx.Client(base_url=page.base) as c:
        assert c.get(f"/v1/sessions/{sid}").json()["spec"] == shown  # what the dialog showed is what was sent
    # import: a SPEC with a box selection becomes regions
    doc = {"selections": {"root": {"set": "FIXED"}, "end": {"box": {"min": [95, -1, -1], "max": [101, 21, 11]}}},
           "fixed": ["root"], "handles": {"tip": "end"}, "inversion": "clamp", "laplacian": "cotangent"}
    (tmp_path / "import.json").write_text(json.dumps(doc))
    page.click("#spec-view")
    with page.expect_file_chooser() as fc:
        page.click("#spec-import-btn")
    fc.value.set_files(str(tmp_path / "import.json"))
    page.wait_for_function("window.tetmorph.regions().some((r) => r.name === 'end')")
    page.click("#spec-close")
    mesh = read_mesh(BRACKET)
    r = regions(page)
    assert set(r) == {"root", "end"} and r["end"]["kind"] == "handle"
    expected = select(mesh, doc["selections"]["end"])
    assert r["end"]["count"] == expected.size
    assert page.input_value("#policy") == "clamp"
    spec = page.evaluate("window.tetmorph.spec()")
    assert spec["handles"] == {"tip": "end"} and spec["laplacian"] == "cotangent"
    assert spec["selections"]["end"]["ids"] == expected.tolist()
    create(page, policy="clamp")
    numeric_move(page, t=(0, 0, 3))
    settle(page)
    sid = page.evaluate("window.tetmorph.session().id")
    with httpx.Client(base_url=page.base) as c:
        assert list(c.get(f"/v1/sessions/{sid}").json()["last_move"]["handles"]) == ["tip"]


# ---------------------------------------------------------------------------- moves
def test_several_handles_each_with_its_own_transform(page):
    load_bracket(page)
    assign_set(page, "FIXED", 1)
    assign_set(page, "LOAD", 2)
    page.click("#find-features")
    page.wait_for_selector("#features li button")
    page.click("#features li:has-text('hole_1') button[data-kind=handle]")
    create(page)
    assert page.evaluate("Array.from(document.querySelectorAll('#handle-select option'), (o) => o.value)") == \
        ["LOAD", "hole_1"]
    numeric_move(page, t=(0, 0, 4))
    settle(page)
    page.select_option("#handle-select", "hole_1")
    assert page.input_value("#tz") == "0"  # the fields show the picked handle
    numeric_move(page, t=(0, 0, -2))
    settle(page)
    page.select_option("#handle-select", "LOAD")
    assert page.input_value("#tz") == "4"
    sid = page.evaluate("window.tetmorph.session().id")
    with httpx.Client(base_url=page.base) as c:
        last = c.get(f"/v1/sessions/{sid}").json()["last_move"]["handles"]
    assert last["LOAD"]["translation"] == [0, 0, 4] and last["hole_1"]["translation"] == [0, 0, -2]
    P, V0 = positions(page), read_mesh(BRACKET).V
    load = read_mesh(BRACKET).sets["LOAD"]
    np.testing.assert_allclose(P[load] - V0[load], [[0, 0, 4]] * load.size, atol=1e-4)


def test_gizmo_snaps_and_reads_out_distance_and_angle(page):
    bracket_session(page)
    page.check("#snap")
    page.fill("#snap-t", "5")
    page.dispatch_event("#snap-t", "change")
    c = page.evaluate("window.tetmorph.pivotScreen()")
    drag(page, c["x"], c["y"], c["x"] - 25, c["y"] - 90, steps=12)
    settle(page)
    p = page.evaluate("window.tetmorph.pivot()")
    t = np.array(p["position"]) - np.array(p["centroid"])
    assert np.linalg.norm(t) >= 5
    # snapping rounds the gizmo's position on the world grid of the step
    np.testing.assert_allclose(np.array(p["position"]) / 5, np.round(np.array(p["position"]) / 5), atol=1e-6)
    label = page.locator("#gizmo-label")
    assert label.is_visible()
    assert float(label.get_attribute("data-distance")) == pytest.approx(np.linalg.norm(t))
    assert "mm" in label.inner_text() and "0.0°" in label.inner_text()
    page.keyboard.press("e")  # rotate: the read-out shows the angle
    assert page.is_checked("input[name=gizmo][value=rotate]")
    numeric_move(page, t=tuple(t), axis=(0, 0, 1), angle=30)
    settle(page)
    assert "30.0°" in label.inner_text()


def test_relative_moves(page):
    bracket_session(page)
    page.fill("#dz", "3")
    page.click("#move-by")
    settle(page)
    page.click("#move-by")
    settle(page)
    assert page.input_value("#tz") == "6"
    page.fill("#dz", "0")
    page.fill("#dangle", "90")
    page.select_option("#daxis", "2")
    page.click("#move-by")
    settle(page)
    assert page.input_value("#angle") == "90" and page.input_value("#az") == "1"
    h = next(iter(page.evaluate("window.tetmorph.session().lastMove")["handles"].values()))
    np.testing.assert_allclose(h["translation"], [0, 0, 6], atol=1e-12)
    np.testing.assert_allclose(h["rotation"]["quaternion"], [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], atol=1e-9)


def test_undo_and_redo_with_a_visible_history(page):
    bracket_session(page)
    snaps = []
    for z in (1, 2, 3):
        numeric_move(page, t=(0, 0, z))
        settle(page)
        snaps.append(positions(page))
    assert page.locator("#history li").count() == 4
    focus_view(page)
    page.keyboard.press("Control+z")
    settle(page)
    np.testing.assert_allclose(positions(page), snaps[1], atol=1e-6)
    page.keyboard.press("Control+z")
    settle(page)
    np.testing.assert_allclose(positions(page), snaps[0], atol=1e-6)
    assert page.get_attribute("#history li.active", "data-k") == "1"
    page.keyboard.press("Control+Shift+z")
    settle(page)
    np.testing.assert_allclose(positions(page), snaps[1], atol=1e-6)
    assert page.input_value("#tz") == "2"
    page.click("#history li[data-k='0']")
    page.wait_for_function("window.tetmorph.report() && window.tetmorph.report().reset === true")
    np.testing.assert_array_equal(positions(page), rest(page))
    page.click("#history li[data-k='3']")
    settle(page)
    np.testing.assert_allclose(positions(page), snaps[2], atol=1e-6)


def save_lift_preset(pg) -> np.ndarray:
    """On a new bracket session, make a lift-and-tilt MOVE, save it as preset "lift 5"; its positions."""
    bracket_session(pg)
    numeric_move(pg, t=(0, 0, 5), axis=(1, 0, 0), angle=20)
    settle(pg)
    moved = positions(pg)
    pg.fill("#preset-name", "lift 5")
    pg.click("#preset-save")
    pg.wait_for_selector("#presets li:has-text('lift 5')")  # stored on the service
    return moved


def test_named_presets_are_kept_with_the_session(page):
    moved = save_lift_preset(page)
    page.click("#reset")
    confirm(page)
    page.wait_for_function("window.tetmorph.report() && window.tetmorph.report().reset === true")
    sid = page.evaluate("window.tetmorph.session().id")
    # leave the session and open it again from the list: the preset is still there
    page.click("#sessions-btn")
    page.click(f"#sessions-table tr[data-id={sid}] button[data-act=close]")
    page.wait_for_function("window.tetmorph.session().id === null")
    page.click(f"#sessions-table tr[data-id={sid}] button[data-act=open]")
    page.wait_for_function(f"window.tetmorph.session().id === '{sid}'")
    page.click("#presets li:has-text('lift 5') button[data-act=apply]")
    settle(page)
    np.testing.assert_allclose(positions(page), moved, atol=1e-6)
    assert page.input_value("#tz") == "5" and page.input_value("#angle") == "20"


def test_presets_live_on_the_service_another_browser_sees_and_applies_them(pages, server):
    a = pages(server)
    moved = save_lift_preset(a)
    sid = a.evaluate("window.tetmorph.session().id")
    stored = httpx.get(f"{server}/v1/sessions/{sid}").json()["presets"]
    assert [p["name"] for p in stored] == ["lift 5"]
    assert stored[0]["move"] == a.evaluate("window.tetmorph.session().lastMove")  # the MOVE shown when saved
    assert a.evaluate("Object.keys(localStorage).filter((k) => k.startsWith('tetmorph-presets'))") == []
    a.click("#reset")
    confirm(a)
    a.wait_for_function("window.tetmorph.report() && window.tetmorph.report().reset === true")
    a.close()  # the tab goes; the moved session stays on the service
    # another browser (a fresh context: nothing of the first one's storage), where an editor of before
    # left presets of this session in localStorage: they join the service's on open (its own names win)
    b = pages(server)
    legacy = [{"name": "kept here", "move": {"handles": {"tip": {"translation": [0, 0, -3]}}}},
              {"name": "lift 5", "move": {"handles": {"tip": {"translation": [9, 9, 9]}}}}]
    b.evaluate("([k, v]) => localStorage.setItem(k, v)", [f"tetmorph-presets:{sid}", json.dumps(legacy)])
    b.click("#sessions-btn")
    b.click(f"#sessions-table tr[data-id={sid}] button[data-act=open]")
    b.wait_for_function(f"window.tetmorph.session().id === '{sid}' && window.tetmorph.session().stream.open")
    b.wait_for_function("window.tetmorph.session().presets.length === 2")
    b.evaluate("document.getElementById('sessions-dialog').close()")
    assert b.evaluate(f"localStorage.getItem('tetmorph-presets:{sid}')") is None
    stored = httpx.get(f"{server}/v1/sessions/{sid}").json()["presets"]
    assert [p["name"] for p in stored] == ["lift 5", "kept here"] and stored[1]["move"] == legacy[0]["move"]
    assert [t.strip() for t in b.locator("#presets li .name").all_inner_texts()] == ["lift 5", "kept here"]
    np.testing.assert_array_equal(positions(b), rest(b))  # the session is at rest (reset), the preset not applied
    b.click("#presets li:has-text('lift 5') button[data-act=apply]")
    settle(b)
    np.testing.assert_allclose(positions(b), moved, atol=1e-6)
    np.testing.assert_allclose(positions(b), server_positions(server, sid), atol=1e-4)
    assert b.input_value("#tz") == "5" and b.input_value("#angle") == "20"
    b.click("#presets li:has-text('kept here') button[data-act=delete]")
    b.click("#confirm-ok")  # deleting a preset asks first
    b.wait_for_function("window.tetmorph.session().presets.length === 1")
    assert [p["name"] for p in httpx.get(f"{server}/v1/sessions/{sid}").json()["presets"]] == ["lift 5"]
    # a save the service refuses (the session was deleted behind the editor's back) is shown, and the
    # list stays the service's last one
    assert httpx.delete(f"{server}/v1/sessions/{sid}").status_code == 204
    b.fill("#preset-name", "too late")
    b.click("#preset-save")
    b.wait_for_function("window.tetmorph.error() && window.tetmorph.error().code === 'session_not_found'")
    assert b.is_visible("#errors") and "no longer exists" in b.inner_text("#error-text")
    assert [p["name"] for p in b.evaluate("window.tetmorph.session().presets")] == ["lift 5"]
    assert [t.strip() for t in b.locator("#presets li .name").all_inner_texts()] == ["lift 5"]


# ---------------------------------------------------------------------------- sessions
def test_session_list_close_delete_and_reopening_a_mesh_offers_its_sessions(pages, server):
    a = pages(server)
    bracket_session(a)
    numeric_move(a, t=(0, 0, 6))
    settle(a)
    sid = a.evaluate("window.tetmorph.session().id")
    mesh_id = a.evaluate("window.tetmorph.mesh().id")
    b = pages(server)
    b.select_option("#meshes", mesh_id)
    b.click("#open-mesh")
    b.wait_for_selector(f"#mesh-sessions tr[data-id={sid}]")
    b.click(f"#mesh-sessions tr[data-id={sid}] button[data-act=open]")
    b.wait_for_function(f"window.tetmorph.session().id === '{sid}' && window.tetmorph.session().stream.open")
    np.testing.assert_allclose(positions(b), server_positions(server, sid), atol=1e-4)
    r = regions(b)
    assert r["FIXED"]["count"] == 46 and r["LOAD"]["count"] == 46
    assert b.input_value("#tz") == "6"
    b.click("#sessions-btn")
    b.wait_for_selector(f"#sessions-table tr.current[data-id={sid}]")
    b.click(f"#sessions-table tr[data-id={sid}] button[data-act=close]")
    b.wait_for_function("window.tetmorph.session().id === null")
    with httpx.Client(base_url=server) as c:
        assert c.get(f"/v1/sessions/{sid}").status_code == 200  # closed here, kept there
        b.click(f"#sessions-table tr[data-id={sid}] button[data-act=delete]")
        confirm(b)
        b.wait_for_function(f"!document.querySelector('#sessions-table tr[data-id={sid}]')")
        assert c.get(f"/v1/sessions/{sid}").status_code == 404


def test_a_session_is_saved_to_a_file_and_reloaded(pages, server, tmp_path):
    a = pages(server)
    bracket_session(a)
    snaps = []
    for z in (2, 4):
        numeric_move(a, t=(0, 0, z))
        settle(a)
        snaps.append(positions(a))
    a.fill("#preset-name", "p4")
    a.click("#preset-save")
    a.wait_for_selector("#presets li:has-text('p4')")
    a.click("#undo")
    settle(a)
    with a.expect_download() as dl:
        a.click("#save-session")
    path = tmp_path / "bracket.session.json"
    dl.value.save_as(path)
    doc = json.loads(path.read_text())
    assert doc["history_index"] == 1 and len(doc["history"]) == 3 and doc["presets"][0]["name"] == "p4"
    b = pages(server)
    with b.expect_file_chooser() as fc:
        b.click("#load-session-btn")
    fc.value.set_files(str(path))
    b.wait_for_function("window.tetmorph.session().id !== null && window.tetmorph.session().historyLength === 3")
    settle(b)
    np.testing.assert_allclose(positions(b), snaps[0], atol=1e-6)
    assert b.get_attribute("#history li.active", "data-k") == "1"
    assert "p4" in b.inner_text("#presets")
    sid = b.evaluate("window.tetmorph.session().id")
    assert [p["name"] for p in httpx.get(f"{server}/v1/sessions/{sid}").json()["presets"]] == ["p4"]
    b.click("#redo")
    settle(b)
    np.testing.assert_allclose(positions(b), snaps[1], atol=1e-6)


def test_the_first_load_says_what_to_do_and_demo_opens_the_ready_session(pages, demo_server):
    pg = pages(demo_server)
    welcome = pg.inner_text("#welcome")
    assert "Open the demo" in welcome and "Upload a mesh" in welcome
    pg.click("#welcome-demo")
    pg.wait_for_function("window.tetmorph.session().id === 's_demo' && window.tetmorph.session().stream.open")
    assert pg.is_hidden("#welcome")
    mesh = read_mesh(DATA / "beam.node")
    spec = json.loads((ROOT / "examples" / "beam" / "spec.json").read_text())
    r = regions(pg)
    assert r["root"]["kind"] == "fixed" and r["root"]["count"] == select(mesh, spec["selections"]["root"]).size
    assert r["tip"]["kind"] == "handle" and r["tip"]["count"] == select(mesh, spec["selections"]["tip"]).size
    legend = pg.inner_text("#legend")
    assert "root" in legend and "tip" in legend
    np.testing.assert_allclose(positions(pg), server_positions(demo_server, "s_demo"), atol=1e-5)
    np.testing.assert_array_equal(positions(pg), rest(pg))  # it opens at rest, ready to be dragged
    assert pg.input_value("#ty") == "0" and pg.input_value("#scale") == "1"


# ---------------------------------------------------------------------------- feedback
def test_histogram_threshold_drags_and_counts_follow(page):
    bracket_session(page)
    numeric_move(page, axis=(1, 0, 0), angle=150)
    settle(page)
    ticks = page.evaluate("window.tetmorph.histogramTicks()")
    assert ticks[:4] == ["0", "10", "100", "1k"]  # a log y scale, labelled by decades
    # the REPORT rows above the histogram move it as they come (displacements are fetched after the
    # frame): the pointer goes down through the locator, which waits until the canvas is still and
    # is what the point hits, and each point is measured where the canvas is at that moment
    page.wait_for_selector("#report tr[data-key=max_free_displacement]")
    where = "(t) => { const r = document.getElementById('hist').getBoundingClientRect();" \
            " return {x: window.tetmorph.histogramX(t), left: r.left, y: r.top + r.height / 2, h: r.height}; }"
    a = page.evaluate(where, 0.2)
    page.locator("#hist").hover(position={"x": a["x"] - a["left"], "y": a["h"] / 2})
    page.mouse.down()
    b = page.evaluate(where, 0.5)
    page.mouse.move(b["x"], b["y"], steps=5)
    page.mouse.up()
    t = page.evaluate("window.tetmorph.view().threshold")
    assert t == pytest.approx(0.5, abs=0.011)
    sj = scaled_jacobians(positions(page).astype(np.float64), read_mesh(BRACKET).T)
    assert report_row(page, "below") == f"{int((sj < t).sum()):,}"
    assert f"< {t:g}" in page.inner_text("#legend")
    assert page.input_value("#threshold") == f"{t:g}"
    page.fill("#threshold", "0.3")
    page.press("#threshold", "Enter")
    assert page.evaluate("window.tetmorph.view().threshold") == 0.3
    assert report_row(page, "below") == f"{int((sj < 0.3).sum()):,}"


def test_units_and_bounding_box_are_shown(page):
    load_bracket(page)
    assert page.inner_text("#model-info [data-key=size]") == "size 100 × 20 × 10 mm"
    assert page.inner_text("#model-info [data-key=bbox-x]") == "x 0 … 100 mm"
    page.select_option("#units", "in")
    assert page.inner_text("#model-info [data-key=size]") == "size 100 × 20 × 10 in"


def test_errors_are_said_in_the_users_words(page):
    page.set_input_files("#upload", str(DATA / "beam.node"))  # a TetGen .node without its .ele
    page.wait_for_selector("#errors:not([hidden])")
    assert "TetGen mesh comes in two files: beam.ele is missing" in page.inner_text("#error-text")
    text = page.evaluate("""import('/editor/messages.js').then((m) => m.explain({body: {error: {code: 'bad_selection',
        message: "selection 'BC_RIMTIRE': vertices 12, 15 (112 in all) belong to no element",
        details: {selection: 'BC_RIMTIRE'}}}}).text)""")
    assert "contains mid-side nodes" in text and "112 of its vertices" in text
    bracket_session(page, policy="reject")
    numeric_move(page, t=(-90, 0, 0), axis=(0, 1, 0), angle=170)
    page.wait_for_selector("#errors:not([hidden])")
    words = page.inner_text("#error-text")
    assert "would invert" in words and "not applied" in words and "clamp" in words


# ---------------------------------------------------------------------------- keyboard
def test_keyboard_only_upload_keys_and_esc(page):
    choosers = []
    page.on("filechooser", lambda fc: choosers.append(fc))  # intercepts the file dialog from here on
    page.evaluate("document.body.focus()")
    for _ in range(12):  # Tab to the Upload button
        page.keyboard.press("Tab")
        if page.evaluate("document.activeElement.id") == "upload-btn":
            break
    assert page.evaluate("document.activeElement.id") == "upload-btn"
    page.keyboard.press("Enter")
    for _ in range(100):
        if choosers:
            break
        page.wait_for_timeout(50)
    assert choosers, "Enter on the Upload button opened no file dialog"
    choosers[0].set_files(str(BRACKET))
    page.wait_for_function("window.tetmorph.mesh().name === 'bracket.inp'")
    assign_set(page, "FIXED", 1)
    assign_set(page, "LOAD", 2)
    create(page)
    focus_view(page)
    page.keyboard.press("e")
    assert page.is_checked("input[name=gizmo][value=rotate]")
    page.keyboard.press("w")
    assert page.is_checked("input[name=gizmo][value=translate]")
    page.fill("#tz", "3")
    page.press("#tz", "Enter")  # Enter in a number field applies
    settle(page)
    held = page.evaluate("window.tetmorph.session().lastMove")
    assert next(iter(held["handles"].values()))["translation"] == [0, 0, 3]
    page.fill("#dx", "2")
    page.press("#dx", "Enter")
    settle(page)
    assert page.input_value("#tx") == "2"
    # Esc: a box being drawn is dropped, then the tool goes back to navigating
    page.check("input[name=role][value='0']")
    page.check("input[name=tool][value='box']")
    box = canvas_box(page)
    before = page.evaluate("window.tetmorph.role()")
    page.mouse.move(box["x"] + 20, box["y"] + 20)
    page.mouse.down()
    page.mouse.move(box["x"] + box["w"] - 20, box["y"] + box["h"] - 20, steps=3)
    assert page.is_visible("#boxsel")
    page.keyboard.press("Escape")
    assert page.is_hidden("#boxsel")
    page.mouse.up()
    assert page.evaluate("window.tetmorph.role()") == before  # nothing erased
    page.keyboard.press("Escape")
    assert page.is_checked("input[name=tool][value=orbit]")


# ---------------------------------------------------------------------------- the README's picture
def test_a_real_deck_mid_morph_for_the_readme(page):
    """The README's editor screenshot: the tractor wheel deck, the rim seat fixed (a named set of
    the quadratic deck), the tread at the ground pushed up. Written to docs/img/ when
    TETMORPH_DOCS_IMAGES=1 (the committed picture), else to the test output."""
    deck = shared_file("tet/tractor_wheel_coarse.INP")
    page.set_viewport_size({"width": 1280, "height": 720})
    upload(page, deck)
    page.select_option("#units", "m")
    assign_set(page, "BC_RIMTIRE", 1)
    focus_view(page)
    page.keyboard.press("3")  # side view, along the axle
    page.check("input[name=role][value='2']")
    page.check("input[name=tool][value='box']")
    box_over(page, (0.3, -0.3, -0.6), (0.3, 0.3, -0.75))  # the lugs at the bottom, through the width
    page.check("input[name=tool][value='orbit']")
    r = regions(page)
    assert r["handle1"]["count"] > 50
    create(page)
    numeric_move(page, t=(0, 0, 0.03))
    settle(page)
    assert page.is_hidden("#errors") and page.evaluate("window.tetmorph.report().inverted_elements") == 0
    page.check("#ghost")
    page.uncheck("#bad")
    page.dispatch_event("#bad", "input")
    page.select_option("#color-by", "displacement")
    page.click("[data-view=iso]")
    page.evaluate("document.getElementById('left').scrollTop = 0")
    page.wait_for_timeout(300)
    out = DOCS_IMG if os.environ.get("TETMORPH_DOCS_IMAGES") == "1" else ARTIFACTS
    out.mkdir(parents=True, exist_ok=True)
    png = page.screenshot(path=str(out / "editor-tractor-wheel.png"))
    assert image(png).shape[:2] == (720, 1280)
