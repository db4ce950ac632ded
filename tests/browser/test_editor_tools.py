"""The editor's tools a morphing user reaches for: node picking and measuring, snapping the gizmo to
nodes, a section plane at any orientation and a PNG of the view, driven in a real browser.

Every test here failed on the editor before its tool was added (run against that build once).
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
import zipfile

import httpx
import numpy as np
import pytest
from PIL import Image

from solver import precompute, read_mesh
from solver.constraints.features import feature_candidates
from solver.validity.quality import aspect_ratios, dihedral_angles, scaled_jacobians
from tests.browser.conftest import (
    BRACKET,
    assign_set,
    bracket_session,
    confirm,
    create,
    differs,
    image,
    load_bracket,
    numeric_move,
    positions,
    rest,
    settle,
    shared_file,
    upload,
    use_spec,
)


def test_the_view_is_saved_as_a_png(page, tmp_path):
    load_bracket(page)
    with page.expect_download() as dl:
        page.click("#png")
    assert dl.value.suggested_filename == "bracket.png"
    path = tmp_path / "view.png"
    dl.value.save_as(path)
    img = Image.open(path)
    size = page.eval_on_selector("#canvas", "c => [c.width, c.height]")
    assert img.format == "PNG" and list(img.size) == size
    px = np.asarray(img.convert("RGB"), dtype=np.int16)
    background = np.array([0xF4, 0xF5, 0xF7])
    assert (np.abs(px - background).max(axis=2) > 20).sum() > 0.1 * px.shape[0] * px.shape[1]  # the model is in it


def test_picked_nodes_read_out_coordinates_distance_and_angle(page):
    load_bracket(page)
    mesh = read_mesh(BRACKET)
    V = mesh.V
    load = mesh.sets["LOAD"]  # the x = 100 end face, facing the camera of the first view
    a = load[np.argmin(V[load, 1] + V[load, 2])]
    b = load[np.argmax(V[load, 1] - V[load, 2])]
    c = load[np.argmax(V[load, 1] + V[load, 2])]
    page.check("input[name=tool][value='pick']")
    for i in (a, b, c):
        p = page.evaluate("(i) => window.tetmorph.screenOf(i)", int(i))
        page.mouse.move(p["x"], p["y"])
        page.wait_for_selector("#pick-tip:not([hidden])")
        assert page.inner_text("#pick-tip").startswith(f"vertex {i} ")
        page.mouse.click(p["x"], p["y"])
    got = page.evaluate("window.tetmorph.measure()")
    assert got["vertices"] == [int(a), int(b), int(c)]
    ab, cb = V[a] - V[b], V[c] - V[b]
    dist = float(np.linalg.norm(V[b] - V[a]))
    angle = float(np.degrees(np.arccos(ab @ cb / np.linalg.norm(ab) / np.linalg.norm(cb))))
    assert abs(got["distance"] - dist) < 1e-4 and abs(got["angle"] - angle) < 1e-3
    assert f"{float(f'{dist:.6g}'):g}" in page.inner_text("#measure [data-key=distance]").replace(",", "")
    assert f"{angle:.3f}°" in page.inner_text("#measure [data-key=angle]")
    assert f"vertex {a}" in page.inner_text("#measure [data-key=node0]")
    page.click("#measure-clear")
    assert page.evaluate("window.tetmorph.measure()")["vertices"] == []


def _drag_to(pg, x: float, y: float) -> None:
    c = pg.evaluate("window.tetmorph.pivotScreen()")
    pg.mouse.move(c["x"], c["y"])
    pg.mouse.down()
    for k in range(1, 13):
        pg.mouse.move(c["x"] + (x - c["x"]) * k / 12, c["y"] + (y - c["y"]) * k / 12)
    pg.mouse.up()


def test_the_gizmo_snaps_to_nodes(page):
    bracket_session(page)
    mesh = read_mesh(BRACKET)
    handle = set(mesh.sets["LOAD"].tolist())
    c = page.evaluate("window.tetmorph.pivotScreen()")
    # a surface node of the fixed part about 120 px from the gizmo
    cand = [int(i) for i in np.flatnonzero(mesh.boundary) if i not in handle]
    pts = page.evaluate("(ids) => ids.map((i) => window.tetmorph.screenOf(i))", cand)
    d = np.array([np.hypot(p["x"] - c["x"], p["y"] - c["y"]) for p in pts])
    j = int(np.argmin(np.abs(d - 120)))
    target = pts[j]
    page.check("#snap-node")
    _drag_to(page, target["x"] + 2, target["y"] + 1)
    settle(page)
    pivot = np.array(page.evaluate("window.tetmorph.pivot()")["position"])
    V = rest(page)  # where the nodes were when the drag began
    k = int(np.argmin(np.linalg.norm(V - pivot, axis=1)))
    assert np.linalg.norm(V[k] - pivot) < 1e-9  # exactly on a node
    assert k not in handle and mesh.boundary[k]
    s = pts[cand.index(k)]
    assert np.hypot(s["x"] - target["x"] - 2, s["y"] - target["y"] - 1) < 13
    # and the session moved the handle's centre there
    sid = page.evaluate("window.tetmorph.session().id")
    last = httpx.get(f"{page.base}/v1/sessions/{sid}").json()["last_move"]
    h = next(iter(last["handles"].values()))
    np.testing.assert_allclose(np.array(h["pivot"]) + np.array(h["translation"]), V[k], atol=1e-5)
    # without snapping, the same drag leaves the gizmo between nodes
    page.uncheck("#snap-node")
    page.click("#reset")
    page.click("#confirm-ok")
    page.wait_for_function("window.tetmorph.report() && window.tetmorph.report().reset === true")
    _drag_to(page, target["x"] + 2, target["y"] + 1)
    settle(page)
    pivot = np.array(page.evaluate("window.tetmorph.pivot()")["position"])
    assert np.linalg.norm(rest(page) - pivot, axis=1).min() > 1e-3


def test_a_section_plane_at_any_orientation(page):
    load_bracket(page)
    V = rest(page).astype(np.float64)
    T = read_mesh(BRACKET).T

    def expected(n):
        n = np.asarray(n, float) / np.linalg.norm(n)
        d = V @ n
        c = d.min() + 0.5 * (d.max() - d.min())
        below = (d[T] < c).sum(axis=1)
        return int(((below > 0) & (below < 4)).sum())

    page.check("#clip")
    page.select_option("#clip-axis", "n")
    page.fill("#clip-normal", "1 1 0")
    page.press("#clip-normal", "Enter")
    page.wait_for_function("window.tetmorph.view().cut > 0")
    assert page.evaluate("window.tetmorph.view().cut") == expected([1, 1, 0])
    assert "tets in the section" in page.inner_text("#cut-count")
    # a plane facing the camera
    page.click("[data-view=iso]")
    page.click("#clip-from-view")
    n = [float(x) for x in page.input_value("#clip-normal").split()]
    cam = page.evaluate("window.tetmorph.camera()")
    view = np.array(cam["position"]) - np.array(cam["target"])
    np.testing.assert_allclose(n, view / np.linalg.norm(view), atol=1e-4)
    page.wait_for_function(f"window.tetmorph.view().cut === {expected(n)}")


def test_hide_isolate_show_and_opacity(page):
    load_bracket(page)
    mesh = read_mesh(BRACKET)
    F = mesh.F
    inside = np.zeros(mesh.n, bool)
    inside[mesh.sets["LOAD"]] = True
    whole = inside[F].all(axis=1)
    assert 0 < whole.sum() < len(F)
    visible = lambda: page.evaluate("window.tetmorph.view().visibleFaces")  # noqa: E731
    assert visible() == len(F)
    page.select_option("#show-what", "set:LOAD")
    page.click("#hide-sel")
    assert visible() == len(F) - whole.sum()
    page.click("#isolate-sel")
    assert visible() == whole.sum()
    isolated = shot_of(page)
    page.click("#show-all")
    assert visible() == len(F)
    page.focus("#opacity")  # the slider, with the keys
    page.keyboard.press("Home")
    assert page.evaluate("window.tetmorph.viewOptions().opacity") == 0.1
    seen = shot_of(page)
    page.keyboard.press("End")
    assert page.evaluate("window.tetmorph.viewOptions().opacity") == 1
    opaque = shot_of(page)
    assert differs(seen, opaque) > 2000 and differs(isolated, opaque) > 2000


def test_hide_and_isolate_a_region_made_on_the_model(page):
    load_bracket(page)
    mesh = read_mesh(BRACKET)
    F = mesh.F
    page.click("#find-features")
    page.click("#features li:has-text('hole_1') button[data-kind=handle]")  # a region, not a set of the file
    hole = next(c.to_dict() for c in feature_candidates(mesh, 30, 1e-3) if c.name == "hole_1")["selection"]["ids"]
    inside = np.zeros(mesh.n, bool)
    inside[hole] = True
    whole = inside[F].all(axis=1)
    assert 0 < whole.sum() < len(F)
    (region,) = [r for r in page.evaluate("window.tetmorph.regions()") if r["name"] == "hole_1"]
    visible = lambda: page.evaluate("window.tetmorph.view().visibleFaces")  # noqa: E731
    page.select_option("#show-what", f"region:{region['id']}")
    assert page.inner_text("#show-what option:checked") == "region hole_1"
    page.click("#hide-sel")
    assert visible() == len(F) - whole.sum()
    page.click("#isolate-sel")
    assert visible() == whole.sum()
    page.click("#show-all")
    assert visible() == len(F)


def shot_of(pg) -> bytes:
    return pg.locator("#canvas").screenshot()


def test_a_feature_candidate_shows_what_it_selects_under_the_pointer(page):
    load_bracket(page)
    page.click("#find-features")
    page.wait_for_selector("#features li button")
    expected = next(c for c in feature_candidates(read_mesh(BRACKET), 30, 1e-3) if c.name == "hole_1")
    ids = expected.to_dict()["selection"]["ids"]
    before = page.evaluate("(i) => window.tetmorph.surfaceColor(i)", ids[0])
    page.hover("#features li:has-text('hole_1') .name")
    shown = page.evaluate("(ids) => ids.map((i) => window.tetmorph.surfaceColor(i))", ids)
    assert all(np.allclose(c, shown[0]) for c in shown) and not np.allclose(shown[0], before, atol=0.05)
    others = np.setdiff1d(np.flatnonzero(read_mesh(BRACKET).boundary), ids)[:50]
    for c in page.evaluate("(ids) => ids.map((i) => window.tetmorph.surfaceColor(i))", others.tolist()):
        assert np.allclose(c, before, atol=1e-6)  # only the candidate's vertices
    page.mouse.move(5, 5)  # off the list: the colours are back
    page.wait_for_function(f"Math.abs(window.tetmorph.surfaceColor({ids[0]})[0] - {before[0]}) < 1e-6")


def test_a_feature_candidate_shows_over_the_quality_contour(page):
    load_bracket(page)
    mesh = read_mesh(BRACKET)
    page.select_option("#color-by", "quality")
    page.click("#find-features")
    page.wait_for_selector("#features li button")
    expected = next(c for c in feature_candidates(mesh, 30, 1e-3) if c.name == "hole_1")
    ids = np.asarray(expected.to_dict()["selection"]["ids"])
    inside = np.isin(mesh.F, ids)
    whole, untouched = np.flatnonzero(inside.all(axis=1)), np.flatnonzero(~inside.any(axis=1))
    assert len(whole) > 10 and len(untouched) > 10
    contour = np.array(page.evaluate("window.tetmorph.faceColors()"), float)
    preview = np.array(page.evaluate("window.tetmorph.previewColor()"), float)
    page.hover("#features li:has-text('hole_1') .name")
    shown = np.array(page.evaluate("window.tetmorph.faceColors()"), float)
    np.testing.assert_allclose(shown[whole], np.broadcast_to(preview, (len(whole), 3)), atol=1e-6)
    np.testing.assert_allclose(shown[untouched], contour[untouched], atol=1e-6)  # the contour elsewhere
    page.mouse.move(5, 5)  # off the list: the contour is back
    k, red = int(whole[0]), float(contour[whole[0], 0])
    page.wait_for_function(f"Math.abs(window.tetmorph.faceColors()[{k}][0] - {red}) < 1e-6")


def test_local_axes_from_three_picked_nodes_drive_the_numeric_moves(page):
    bracket_session(page)
    mesh = read_mesh(BRACKET)
    V = mesh.V
    load = mesh.sets["LOAD"]
    a = load[np.argmin(V[load, 1] + V[load, 2])]
    b = load[np.argmax(V[load, 1] - V[load, 2])]
    c = load[np.argmax(V[load, 1] + V[load, 2])]
    page.check("input[name=tool][value='pick']")
    for i in (a, b, c):
        p = page.evaluate("(i) => window.tetmorph.screenOf(i)", int(i))
        page.mouse.click(p["x"], p["y"])
    assert page.evaluate("window.tetmorph.measure()")["vertices"] == [int(a), int(b), int(c)]
    page.click("#csys-from-picks")
    assert page.is_checked("#local")
    e1 = (V[b] - V[a]) / np.linalg.norm(V[b] - V[a])
    e3 = np.cross(e1, V[c] - V[a])
    e3 /= np.linalg.norm(e3)
    e2 = np.cross(e3, e1)
    np.testing.assert_allclose(page.evaluate("window.tetmorph.csys()"), [e1, e2, e3], atol=1e-6)
    page.check("input[name=tool][value='orbit']")
    page.fill("#tx", "5")
    page.fill("#ty", "0")
    page.fill("#tz", "2")
    page.click("#apply-move")
    settle(page)
    sid = page.evaluate("window.tetmorph.session().id")
    h = next(iter(httpx.get(f"{page.base}/v1/sessions/{sid}").json()["last_move"]["handles"].values()))
    np.testing.assert_allclose(h["translation"], 5 * e1 + 2 * e3, atol=1e-5)
    assert [page.input_value(f"#{k}") for k in ("tx", "ty", "tz")] == ["5", "0", "2"]
    page.uncheck("#local")  # the same move in global axes
    shown = [float(page.input_value(f"#{k}")) for k in ("tx", "ty", "tz")]
    np.testing.assert_allclose(shown, 5 * e1 + 2 * e3, atol=1e-4)


def rotation(axis, deg) -> np.ndarray:
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    a = np.radians(deg)
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def test_a_turn_about_an_axis_and_a_pivot_picked_on_the_model(page):
    bracket_session(page)
    mesh = read_mesh(BRACKET)
    V = mesh.V
    load = mesh.sets["LOAD"]
    a = load[np.argmin(V[load, 1] + V[load, 2])]
    b = load[np.argmax(V[load, 1] - V[load, 2])]
    page.check("input[name=tool][value='pick']")
    for i in (a, b):
        p = page.evaluate("(i) => window.tetmorph.screenOf(i)", int(i))
        page.mouse.click(p["x"], p["y"])
    assert page.evaluate("window.tetmorph.measure()")["vertices"] == [int(a), int(b)]
    page.check("input[name=tool][value='orbit']")
    page.fill("#dangle", "30")
    page.select_option("#daxis", "AB")
    page.select_option("#dpivot", "A")
    page.click("#move-by")
    settle(page)
    sid = page.evaluate("window.tetmorph.session().id")
    h = next(iter(httpx.get(f"{page.base}/v1/sessions/{sid}").json()["last_move"]["handles"].values()))
    w, x, y, z = h["rotation"]["quaternion"]
    ab = (V[b] - V[a]) / np.linalg.norm(V[b] - V[a])
    np.testing.assert_allclose(np.array([x, y, z]) / np.sin(np.radians(15)), ab, atol=1e-6)
    assert np.degrees(2 * np.arccos(w)) == pytest.approx(30, abs=1e-6)
    c = np.array(h["pivot"])  # the handle's centre: it turned about the line AB through A
    np.testing.assert_allclose(c + np.array(h["translation"]), V[a] + rotation(ab, 30) @ (c - V[a]), atol=1e-5)
    # and node A, on the axis, stays where it was
    np.testing.assert_allclose(positions(page)[a], V[a], atol=1e-4)


def rainbow(t) -> np.ndarray:
    """The contour's map: blue, cyan, green, yellow, red at t = 0, 1/4, 1/2, 3/4, 1 (t an array)."""
    stops = np.array([[0, 0, 1], [0, 1, 1], [0, 1, 0], [1, 1, 0], [1, 0, 0]], float)
    return np.stack([np.interp(t, np.linspace(0, 1, 5), stops[:, k]) for k in range(3)], axis=-1)


def face_owners(F: np.ndarray, T: np.ndarray) -> np.ndarray:
    """The tet each boundary triangle is a face of."""
    faces = np.sort(np.concatenate([T[:, [1, 2, 3]], T[:, [0, 2, 3]], T[:, [0, 1, 3]], T[:, [0, 1, 2]]]), axis=1)
    of = {tuple(f): t % len(T) for t, f in enumerate(faces.tolist())}
    return np.array([of[tuple(f)] for f in np.sort(F, axis=1).tolist()])


def test_an_element_quality_contour_with_a_choice_of_metric(page):
    load_bracket(page)
    mesh = read_mesh(BRACKET)
    per_tet = {"scaled_jacobian": (scaled_jacobians(mesh.V, mesh.T), False),
               "aspect_ratio": (aspect_ratios(mesh.V, mesh.T), True),
               "min_dihedral_deg": (dihedral_angles(mesh.V, mesh.T).min(axis=1), False)}
    owner = face_owners(mesh.F, mesh.T)

    def colour(q, high_is_bad):  # the map's colour of each tet: red the worst of the mesh, blue the best
        lo, hi = q.min(), q.max()
        return rainbow((q - lo) / (hi - lo) if high_is_bad else (hi - q) / (hi - lo))

    before = image(page.locator("#canvas").screenshot())
    page.select_option("#color-by", "quality")
    for metric, (q, high_is_bad) in per_tet.items():
        page.select_option("#quality-metric", metric)
        page.wait_for_selector("#legend [data-key=q-worst]")
        worst = float(page.inner_text("#legend [data-key=q-worst]").replace(",", ""))
        best = float(page.inner_text("#legend [data-key=q-best]").replace(",", ""))
        assert worst == pytest.approx(q.max() if high_is_bad else q.min(), rel=1e-3), metric
        assert best == pytest.approx(q.min() if high_is_bad else q.max(), rel=1e-3), metric
        # every surface triangle is flat in the colour of its own tet, not blended from its nodes
        drawn = np.array(page.evaluate("window.tetmorph.faceColors()"), float)
        np.testing.assert_allclose(drawn, colour(q, high_is_bad)[owner], atol=2e-3, err_msg=metric)
        # the face of the worst element at the surface is red when that element is at the surface
        t = int(np.argmax(q) if high_is_bad else np.argmin(q))
        if t in owner:
            np.testing.assert_allclose(drawn[list(owner).index(t)], [1, 0, 0], atol=1e-6)
    assert len(set(map(tuple, np.round(drawn, 3)))) > 20  # a contour, not one colour
    assert (np.abs(image(page.locator("#canvas").screenshot()) - before).max(axis=2) > 30).sum() > 2000
    # the section's tets wear the chosen metric's colours too
    page.check("#clip")
    V = mesh.V
    for metric in ("aspect_ratio", "scaled_jacobian"):
        page.select_option("#quality-metric", metric)
        q, high_is_bad = per_tet[metric]
        got = page.evaluate("window.tetmorph.sectionColors()")
        z = V[:, 2]
        below = (z[mesh.T] < z.min() + 0.5 * (z.max() - z.min())).sum(axis=1)
        cut = np.flatnonzero((below > 0) & (below < 4))
        assert sorted(got["tets"]) == cut.tolist()
        np.testing.assert_allclose(got["colors"], colour(q, high_is_bad)[got["tets"]], atol=2e-3, err_msg=metric)


def test_the_undo_history_survives_a_reload_and_reopening(page):
    bracket_session(page)
    shapes = []
    for tz in (2, 4, 6):
        page.fill("#tz", str(tz))
        page.click("#apply-move")
        settle(page)
        shapes.append(positions(page))
    sid = page.evaluate("window.tetmorph.session().id")
    page.reload()  # the address names the session: the reload reopens it
    page.wait_for_function("window.tetmorph !== undefined")
    page.wait_for_function(f"window.tetmorph.session().id === '{sid}' && window.tetmorph.session().stream.open")
    assert page.locator("#history li").count() == 4 and not page.is_disabled("#undo")
    np.testing.assert_allclose(positions(page), shapes[2], atol=1e-4)
    page.click("#undo")
    settle(page)
    np.testing.assert_allclose(positions(page), shapes[1], atol=1e-5)
    assert page.input_value("#tz") == "4"
    page.click("#redo")
    settle(page)
    np.testing.assert_allclose(positions(page), shapes[2], atol=1e-5)


def test_a_mirror_plane_from_the_section_goes_into_the_spec_and_is_drawn(page):
    load_bracket(page)
    assign_set(page, "FIXED", 1)
    assign_set(page, "LOAD", 2)
    page.click("#sec-symmetry summary")
    page.check("#clip")
    page.select_option("#clip-axis", "1")  # y, half way: y = 10 on the bracket (0 <= y <= 20)
    page.uncheck("#clip")
    page.click("#sym-from-section")
    assert "section plane" in page.inner_text("#sym-note")  # clip off: nothing to take
    page.check("#clip")
    page.fill("#sym-tol", "0.1")
    page.click("#sym-from-section")
    page.uncheck("#clip")
    V = rest(page)
    mid = (V.min(0) + V.max(0)) / 2
    sym = page.evaluate("window.tetmorph.spec()")["symmetry"]
    assert [s["name"] for s in sym] == ["mirror1"] and sym[0]["tolerance"] == 0.1
    np.testing.assert_allclose(sym[0]["plane"]["normal"], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(sym[0]["plane"]["point"], mid, atol=1e-5)
    drawn = page.locator("#canvas").screenshot()
    page.click("#sym-list li button")
    assert "symmetry" not in page.evaluate("window.tetmorph.spec()")
    assert differs(drawn, page.locator("#canvas").screenshot()) > 2000  # the plane was on screen
    page.fill("#sym-point", "50 10 5")
    page.fill("#sym-normal", "0 2 0")
    page.click("#sym-add")
    create(page)
    sid = page.evaluate("window.tetmorph.session().id")
    stored = httpx.get(f"{page.base}/v1/sessions/{sid}").json()["spec"]["symmetry"]
    assert stored == [{"name": "mirror1", "plane": {"point": [50, 10, 5], "normal": [0, 1, 0]}, "tolerance": 0.1}]
    numeric_move(page, t=(0, 0, 5))
    settle(page)
    page.reload()  # reopened from the address, the session's mirror plane is back in the panel
    page.wait_for_function("window.tetmorph !== undefined")
    page.wait_for_function(f"window.tetmorph.session().id === '{sid}'")
    assert page.locator("#sym-list li").count() == 1
    assert page.evaluate("window.tetmorph.spec()")["symmetry"] == stored


def lift_and_twist(pg) -> np.ndarray:
    """A bracket session with two presets: lift (5 along z) and twist (20 degrees about x); answers the lifted shape."""
    bracket_session(pg)
    numeric_move(pg, t=(0, 0, 5))
    settle(pg)
    lifted = positions(pg)
    pg.fill("#preset-name", "lift")
    pg.click("#preset-save")
    pg.wait_for_function("window.tetmorph.session().presets.length === 1")
    numeric_move(pg, t=(0, 0, 0), axis=(1, 0, 0), angle=20)
    settle(pg)
    pg.fill("#preset-name", "twist")
    pg.click("#preset-save")
    pg.wait_for_function("window.tetmorph.session().presets.length === 2")
    return lifted


def test_presets_are_shapes_with_sliders_and_a_plan_runs_as_a_doe(page, tmp_path):
    lifted = lift_and_twist(page)
    page.click("#reset")
    page.click("#confirm-ok")
    page.wait_for_function("window.tetmorph.report() && window.tetmorph.report().reset === true")
    for name, presses in (("lift", 10), ("twist", 20)):  # lift 0.5, twist 1 with the keys on the sliders
        page.focus(f"#shapes input[data-shape={name}]")
        for _ in range(presses):
            page.keyboard.press("ArrowRight")
    assert page.inner_text("#shapes [data-val=lift]") == "0.5" and page.inner_text("#shapes [data-val=twist]") == "1"
    settle(page)
    sid = page.evaluate("window.tetmorph.session().id")
    h = next(iter(httpx.get(f"{page.base}/v1/sessions/{sid}").json()["last_move"]["handles"].values()))
    np.testing.assert_allclose(h["translation"], [0, 0, 2.5], atol=1e-9)  # translations add, weighted
    w, x, y, z = h["rotation"]["quaternion"]  # rotations add as logarithms: twist's 20 degrees about x
    np.testing.assert_allclose([w, x, y, z], [np.cos(np.radians(10)), np.sin(np.radians(10)), 0, 0], atol=1e-9)
    combined = positions(page)
    # the same shapes and values as a DOE of the session
    page.click("#sec-doe summary")
    assert page.input_value("#doe-plan").splitlines()[:2] == ["lift,twist", "0.5,1"]
    page.fill("#doe-plan", "lift,twist\n0.5,1\n1,0\n")
    page.click("#doe-run")
    page.wait_for_selector("#doe-decks li[data-name='summary.csv']", timeout=120000)
    listed = page.locator("#doe-decks li[data-name]").evaluate_all("els => els.map((e) => e.dataset.name)")
    job = page.evaluate("window.tetmorph.doeJob()")
    z = httpx.get(f"{page.base}/v1/sessions/{sid}/batch/{job}/result").content
    zf = zipfile.ZipFile(io.BytesIO(z))
    assert sorted(listed) == sorted(zf.namelist())
    decks = sorted(n for n in zf.namelist() if n.endswith(".inp"))
    assert len(decks) == 2
    for name, expected in zip(decks, (combined, lifted), strict=True):
        (tmp_path / name).write_bytes(zf.read(name))
        np.testing.assert_allclose(read_mesh(tmp_path / name).V, expected, atol=1e-4)


def test_deleting_a_preset_asks_first(page):
    bracket_session(page)
    numeric_move(page, t=(0, 0, 5))
    settle(page)
    page.fill("#preset-name", "lift")
    page.click("#preset-save")
    page.wait_for_selector("#shapes input[data-shape=lift]")
    sid = page.evaluate("window.tetmorph.session().id")
    stored = lambda: [p["name"] for p in httpx.get(f"{page.base}/v1/sessions/{sid}").json()["presets"]]  # noqa: E731
    assert stored() == ["lift"]
    page.click("#presets button[data-act=delete][data-name=lift]")
    assert "lift" in confirm(page, ok=False)
    page.wait_for_timeout(300)
    assert stored() == ["lift"] and page.locator("#shapes input[data-shape=lift]").count() == 1
    page.click("#presets button[data-act=delete][data-name=lift]")
    assert "shape slider" in confirm(page, ok=True)
    page.wait_for_function("window.tetmorph.session().presets.length === 0")
    assert stored() == [] and page.locator("#shapes input[data-shape]").count() == 0


def test_the_doe_files_run_unchanged_with_tetmorph_doe(page, tmp_path):
    lift_and_twist(page)
    page.click("#sec-doe summary")
    page.fill("#doe-plan", "lift,twist\n0.5,1\n1,0\n")
    files = {}
    for what in ("spec", "shapes", "plan"):
        with page.expect_download() as dl:
            page.click(f"#doe-{what}-file")
        files[what] = tmp_path / dl.value.suggested_filename
        dl.value.save_as(files[what])
    assert [p.name for p in files.values()] == ["bracket.spec.json", "bracket.shapes.json", "bracket.plan.csv"]
    spec = json.loads(files["spec"].read_text())
    assert {k: spec[k] for k in ("selections", "fixed", "handles")} == {
        "selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"set": "LOAD"}}, "fixed": ["FIXED"],
        "handles": {"LOAD": "LOAD"}}
    out = subprocess.run([sys.executable, "-m", "service.cli", "doe", str(BRACKET), "--spec", str(files["spec"]),
                          "--shapes", str(files["shapes"]), "--plan", str(files["plan"]),
                          "--output", str(tmp_path / "deck_{i}.inp"), "--summary", str(tmp_path / "summary.csv")],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    mesh = read_mesh(BRACKET)
    centre = mesh.V[mesh.sets["LOAD"]].mean(axis=0).tolist()
    d = precompute(mesh, {k: spec[k] for k in ("selections", "fixed", "handles")})
    for row, move in ((1, {"translation": [0, 0, 2.5], "rotation": {"axis": [1, 0, 0], "angle_deg": 20}}),
                      (2, {"translation": [0, 0, 5]})):
        expected = d.solve({"handles": {"LOAD": {**move, "pivot": centre}}}).V
        np.testing.assert_allclose(read_mesh(tmp_path / f"deck_{row}.inp").V, expected, atol=1e-4)


def test_a_cyclic_sector_is_set_up_in_the_panel_and_kept_in_the_spec(page):
    deck = shared_file("tet/segmenttet.inp")  # a 30 degree sector about x, faces Nleft and Nright (*TIE, CYCLIC)
    upload(page, deck)
    c15, s15 = np.cos(np.radians(15)), np.sin(np.radians(15))
    spec = {"selections": {"hub": {"sphere": {"center": [0.05, 0.12 * c15, 0.12 * s15], "radius": 0.05}},
                           "rim": {"sphere": {"center": [0.05, 0.975 * c15, 0.975 * s15], "radius": 0.15}}},
            "fixed": ["hub"], "handles": {"rim": "rim"}}
    use_spec(page, spec)
    page.click("#sec-symmetry summary")
    page.fill("#cyc-point", "0 0 0")
    page.fill("#cyc-dir", "2 0 0")
    page.fill("#cyc-angle", "-30")
    page.select_option("#cyc-a", "Nright")
    page.select_option("#cyc-b", "Nleft")
    page.fill("#cyc-tol", "0.001")
    before = page.locator("#canvas").screenshot()
    page.click("#cyc-add")
    entry = {"name": "cyclic1", "axis": {"point": [0, 0, 0], "direction": [1, 0, 0]}, "angle_deg": -30,
             "faces": ["Nright", "Nleft"], "tolerance": 0.001}
    got = page.evaluate("window.tetmorph.spec()")
    assert got["cyclic"] == [entry]
    assert got["selections"]["Nright"] == {"set": "Nright"} and got["selections"]["Nleft"] == {"set": "Nleft"}
    assert differs(before, page.locator("#canvas").screenshot()) > 30  # the axis is drawn
    create(page)
    sid = page.evaluate("window.tetmorph.session().id")
    stored = httpx.get(f"{page.base}/v1/sessions/{sid}").json()["spec"]
    assert stored["cyclic"] == [entry] and stored["selections"]["Nleft"] == {"set": "Nleft"}
    numeric_move(page, t=(0.02, 0, 0))
    settle(page)
    assert page.is_hidden("#errors")
    # face B still lies on face A turned by -30 degrees about x, as closely as at rest (the faces'
    # nodes do not match one to one)
    mesh = read_mesh(deck)
    R = rotation([1, 0, 0], -30)

    def gap(V):
        A, B = V[mesh.sets["Nright"]] @ R.T, V[mesh.sets["Nleft"]]
        return float(np.median(np.min(np.linalg.norm(B[:, None, :] - A[None, :, :], axis=2), axis=1)))

    V = positions(page)
    assert np.abs(V - rest(page)).max() > 0.015
    assert gap(V) <= 1.2 * gap(rest(page)) + 1e-4
    # the SPEC read back (reopen, import) keeps the cyclic entry and its face selections
    page.click("#spec-view")
    page.click("#spec-apply")
    page.click("#spec-close")
    again = page.evaluate("window.tetmorph.spec()")
    assert again["cyclic"] == [entry] and again["selections"]["Nright"] == {"set": "Nright"}
    assert page.locator("#cyc-list li").count() == 1
