"""The Edits panel's other daily edits: a fillet's radius, the distance and the angle between two
features, a twist's table law and a bend, a map onto a cylinder and a sphere (projected along a
direction), and a Shapes slider whose shape sets an edit, each made in a real browser as a person
makes them (named sets as regions, nodes picked on the model, typed values, a slider).

Each test solves the MOVE with ``solver.precompute(...).solve(...)`` in the test and compares the
positions the page shows (float32 frames) with it; rest values the page shows (a fillet's fitted
radius, a distance, an angle) are compared with the library's own. Every test failed before these
tools existed.
"""

from __future__ import annotations

import re

import httpx
import numpy as np
import pytest

from solver import precompute, read_mesh
from solver.workflows.shapes import combine, parse_shapes
from tests.browser.conftest import BRACKET, assign_set, create, load_bracket, positions, settle, upload
from tests.browser.test_editor_edits import (
    bore_session,
    choose_region,
    hole,
    load_corners,
    open_edits,
    pick,
    row,
    sent_spec,
    type_value,
)
from tests.gmsh_parts import filleted_bracket

#: The positions the page shows are float32: within this of the library's on the parts here (≤ 100 mm).
SHOWN = 1e-4


@pytest.fixture(scope="module")
def bracket():
    return read_mesh(BRACKET)


@pytest.fixture(scope="module")
def filleted(tmp_path_factory):
    path = tmp_path_factory.mktemp("fillet") / "filleted.msh"
    filleted_bracket(path, size=3.0, order=1)
    return path


def add_edit(pg, name: str) -> None:
    pg.fill("#edit-name", name)
    pg.click("#edit-add")


def rest_shown(pg, name: str) -> float:
    return float(pg.inner_text(f"{row(name)} [data-rest]").split()[1])


def drag_slider(pg, name: str, fraction: float) -> None:
    """Press a row's slider at its middle and drag it to `fraction` of its width."""
    slider = pg.locator(f"{row(name)} input[type=range]")
    slider.scroll_into_view_if_needed()
    box = slider.bounding_box()
    pg.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    pg.mouse.down()
    pg.mouse.move(box["x"] + fraction * box["width"], box["y"] + box["height"] / 2, steps=8)
    pg.mouse.up()
    settle(pg)


def regions_of(pg, *names: str, fixed: str | None = "FIXED") -> None:
    """Named sets as regions, in this order, the fixed one last: a node two sets share is the later one's."""
    for n in names:
        assign_set(pg, n, 2)
    if fixed:
        assign_set(pg, fixed, 1)


def test_a_fillet_radius_from_its_fitted_rest_value_typed_and_refused(page, filleted):
    mesh = read_mesh(filleted)
    upload(page, filleted)
    regions_of(page, "INNER_H", "INNER_V", "FILLET")  # the fillet's edges are the fillet's, as in the library
    open_edits(page, "fillet")
    choose_region(page, "#edit-region", "FILLET")
    choose_region(page, "#edit-face-a", "INNER_H")
    choose_region(page, "#edit-face-b", "INNER_V")
    add_edit(page, "corner")
    create(page)
    spec = {"selections": {n: {"set": n} for n in ("FIXED", "FILLET", "INNER_H", "INNER_V")}, "fixed": ["FIXED"],
            "fillet": [{"name": "corner", "selection": "FILLET", "faces": ["INNER_H", "INNER_V"]}]}
    d = precompute(mesh, spec)
    r0 = d.data.constraints.rest.nominal["fillet"]["corner"]
    # the field starts at the radius fitted on the page, the library's fit of the rest positions
    assert float(page.input_value(f"{row('corner')} input[type=number]")) == pytest.approx(r0, rel=1e-5)
    assert rest_shown(page, "corner") == pytest.approx(r0, rel=1e-5)
    # once the session is ready, the row shows the rest radius the service states (its own request here)
    sid = page.evaluate("window.tetmorph.session().id")
    stated = httpx.get(f"{page.base}/v1/sessions/{sid}").json()["edits_at_rest"]
    assert stated == [{"kind": "fillet", "name": "corner", "parameter": "radius", "rest": pytest.approx(r0, rel=1e-12)}]
    page.wait_for_function("(s) => document.querySelector(s).title.includes('by the service')",
                           arg=f"{row('corner')} [data-rest]")
    assert rest_shown(page, "corner") == float(f"{stated[0]['rest']:.6g}")
    sent = sent_spec(page)
    assert sent["fillet"] == [{"name": "corner", "selection": "fillet.corner",
                               "faces": ["fillet.corner.face1", "fillet.corner.face2"]}]
    assert sent["selections"]["fillet.corner"] == {"set": "FILLET"}
    for s, name in ((".face1", "INNER_H"), (".face2", "INNER_V")):  # less the nodes the fillet and FIXED hold
        ids = sent["selections"][f"fillet.corner{s}"]["ids"]
        want_ids = np.setdiff1d(mesh.sets[name], np.union1d(mesh.sets["FILLET"], mesh.sets["FIXED"]))
        np.testing.assert_array_equal(np.sort(ids), want_ids[mesh.referenced[want_ids]])
    type_value(page, "corner", 7)
    want = d.solve({"fillet": {"corner": {"radius": 7.0}}}).V
    np.testing.assert_allclose(positions(page), want, rtol=0, atol=SHOWN)
    # a radius beyond the faces is the service's refusal, said where errors are said
    type_value(page, "corner", 200)
    page.wait_for_selector("#errors:not([hidden])")
    assert "radius must stay below" in page.inner_text("#error-text")


def angle_form(pg, part):
    """The L bracket uploaded, LOAD the angle edit's moving region and FIXED its reference: its mesh."""
    upload(pg, part)
    regions_of(pg, "LOAD", fixed=None)
    assign_set(pg, "FIXED", 2)
    open_edits(pg, "angle")
    choose_region(pg, "#edit-region", "LOAD")
    choose_region(pg, "#edit-reference", "FIXED")  # the fixed end is the reference
    return read_mesh(part)


def test_an_angle_between_two_faces_from_its_rest_angle(page, filleted):
    mesh = angle_form(page, filleted)
    add_edit(page, "tilt")
    create(page)
    spec = {"selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"set": "LOAD"}},
            "angle": [{"name": "tilt", "selection": "LOAD", "reference": "FIXED"}]}
    d = precompute(mesh, spec)
    a0 = d.data.constraints.rest.nominal["angle"]["tilt"]
    assert a0 == pytest.approx(90, abs=1e-6)  # the y = 50 face and the x = 60 face
    assert rest_shown(page, "tilt") == pytest.approx(a0, abs=1e-4)
    assert float(page.input_value(f"{row('tilt')} input[type=number]")) == pytest.approx(a0, abs=1e-4)
    type_value(page, "tilt", 84)
    want = d.solve({"angle": {"tilt": {"angle_deg": 84.0}}}).V
    np.testing.assert_allclose(positions(page), want, rtol=0, atol=SHOWN)
    P, load = positions(page), mesh.sets["LOAD"]
    n = np.linalg.svd(P[load] - P[load].mean(0))[2][2]  # the turned face's normal, fitted to what the page shows
    assert np.degrees(np.arccos(abs(n @ [1, 0, 0]))) == pytest.approx(84, abs=1e-3)
    assert sent_spec(page)["angle"] == [{"name": "tilt", "selection": "angle.tilt",
                                         "reference": "angle.tilt.reference"}]


def test_an_angle_about_a_typed_axis_and_pivot_with_a_typed_planar_tolerance(page, filleted):
    mesh = angle_form(page, filleted)
    page.fill("#edit-turn-axis", "0 0 1")
    page.fill("#edit-pivot", "3 50")  # two numbers: refused, nothing added
    page.fill("#edit-planar", "2")
    add_edit(page, "tilt")
    page.wait_for_selector("#errors:not([hidden])")
    assert "the pivot is three numbers" in page.inner_text("#error-text")
    assert page.locator(row("tilt")).count() == 0
    page.fill("#edit-pivot", "3, 50, 10")
    add_edit(page, "tilt")
    create(page)
    entry = {"name": "tilt", "selection": "angle.tilt", "reference": "angle.tilt.reference", "axis": [0, 0, 1],
             "pivot": [3, 50, 10], "planar_deg": 2}
    assert sent_spec(page)["angle"] == [entry]
    spec = {"selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"set": "LOAD"}},
            "angle": [{**entry, "selection": "LOAD", "reference": "FIXED"}]}
    d = precompute(mesh, spec)
    type_value(page, "tilt", 80)
    np.testing.assert_allclose(positions(page), d.solve({"angle": {"tilt": {"angle_deg": 80.0}}}).V, rtol=0,
                               atol=SHOWN)
    # the turn is about the typed axis through the typed pivot: the pivot's line stays, the face's normal turns
    P, load = positions(page), mesh.sets["LOAD"]
    n = np.linalg.svd(P[load] - P[load].mean(0))[2][2]
    assert abs(n[2]) <= 1e-4 and np.degrees(np.arccos(abs(n @ [1, 0, 0]))) == pytest.approx(80, abs=1e-3)


def test_a_distance_between_two_features_typed_and_dragged(page, filleted):
    mesh = read_mesh(filleted)
    upload(page, filleted)
    regions_of(page, "BORE", "LOAD")
    open_edits(page, "distance")
    choose_region(page, "#edit-region", "BORE")
    choose_region(page, "#edit-reference", "LOAD")
    add_edit(page, "pitch")
    create(page)
    spec = {"selections": {n: {"set": n} for n in ("FIXED", "BORE", "LOAD")}, "fixed": ["FIXED"],
            "distance": [{"name": "pitch", "selection": "BORE", "reference": "LOAD"}]}
    d = precompute(mesh, spec)
    d0 = d.data.constraints.rest.nominal["distance"]["pitch"]
    assert rest_shown(page, "pitch") == pytest.approx(d0, rel=1e-5)
    assert float(page.input_value(f"{row('pitch')} input[type=number]")) == pytest.approx(d0, rel=1e-5)
    type_value(page, "pitch", 16.5)
    np.testing.assert_allclose(positions(page), d.solve({"distance": {"pitch": {"distance": 16.5}}}).V, rtol=0,
                               atol=SHOWN)
    drag_slider(page, "pitch", 0.8)
    last = page.evaluate("window.tetmorph.history()")["entries"][-1]
    dragged = last["move"]["distance"]["pitch"]["distance"]
    assert last["label"].startswith("distance pitch") and dragged > d0
    np.testing.assert_allclose(positions(page), d.solve({"distance": {"pitch": {"distance": dragged}}}).V, rtol=0,
                               atol=SHOWN)



def test_a_slider_pressed_before_the_service_rest_values_come_stays_under_the_pointer(page, filleted):
    """The rest values the service measured at set-up come after the session is ready (its document,
    GET /v1/sessions/{id}); the row they change is brought up to date in place, so a slider a person
    is dragging when they come keeps being dragged, and its release is the history's entry."""
    mesh = read_mesh(filleted)
    upload(page, filleted)
    regions_of(page, "BORE", "LOAD")
    open_edits(page, "distance")
    choose_region(page, "#edit-region", "BORE")
    choose_region(page, "#edit-reference", "LOAD")
    add_edit(page, "pitch")
    held = []

    def hold_ready(route):  # the ready session's document waits until the slider is pressed
        doc = route.fetch()
        if route.request.method == "GET" and doc.json().get("status") == "ready":
            held.append((route, doc))
        else:
            route.fulfill(response=doc)

    page.route(re.compile(r".*/v1/sessions/s_[0-9a-f]+$"), hold_ready)
    create(page)
    slider = page.locator(f"{row('pitch')} input[type=range]")
    slider.scroll_into_view_if_needed()
    box = slider.bounding_box()
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + box["width"] / 2, y)
    page.mouse.down()
    page.mouse.move(box["x"] + 0.6 * box["width"], y, steps=4)
    pressed = float(slider.input_value())
    for _ in range(200):  # the tab asks for the document when the session opens
        if held:
            break
        page.wait_for_timeout(50)
    assert held and "by the service" not in page.get_attribute(f"{row('pitch')} [data-rest]", "title")
    for route, doc in held:
        route.fulfill(response=doc)
    page.unroute_all()
    page.wait_for_function("(s) => document.querySelector(s).title.includes('by the service')",
                           arg=f"{row('pitch')} [data-rest]")
    page.mouse.move(box["x"] + 0.9 * box["width"], y, steps=4)
    page.mouse.up()
    settle(page)
    dragged = float(slider.input_value())
    span = float(slider.get_attribute("max")) - float(slider.get_attribute("min"))
    assert dragged - pressed > 0.2 * span  # the drag went on, by about 0.3 of the slider, after the rest values came
    last = page.evaluate("window.tetmorph.history()")["entries"][-1]
    assert last["label"].startswith("distance pitch")
    assert last["move"]["distance"]["pitch"]["distance"] == pytest.approx(dragged, rel=1e-9)
    spec = {"selections": {n: {"set": n} for n in ("FIXED", "BORE", "LOAD")}, "fixed": ["FIXED"],
            "distance": [{"name": "pitch", "selection": "BORE", "reference": "LOAD"}]}
    want = precompute(mesh, spec).solve({"distance": {"pitch": {"distance": dragged}}}).V
    np.testing.assert_allclose(positions(page), want, rtol=0, atol=SHOWN)


def table_point(pg, name: str, k: int, at: float, deg: float) -> None:
    """Type point k (0-based) of a twist row's table."""
    line = pg.locator(f"{row(name)} .twist-point").nth(k)
    line.locator("[data-at]").fill(str(at))
    line.locator("[data-deg]").fill(str(deg))


def test_a_twist_table_typed_refused_when_not_increasing_then_sent(page, bracket):
    load_bracket(page)
    regions_of(page, "LOAD")
    a, b = load_corners(bracket)
    pick(page, (a, b))
    open_edits(page, "twist")
    choose_region(page, "#edit-region", "LOAD")
    page.select_option("#edit-axis", "AB")
    add_edit(page, "shaft")
    create(page)
    page.select_option(f"{row('shaft')} select[data-param=law]", "table")
    for _ in range(2):
        page.click(f"{row('shaft')} button[data-act=point-add]")
    table_point(page, "shaft", 0, 0, 0)
    table_point(page, "shaft", 1, 10, 3)
    table_point(page, "shaft", 2, 10, 1)
    before = page.evaluate("window.tetmorph.history()")["entries"]
    page.click(f"{row('shaft')} button[data-act=set]")
    page.wait_for_selector("#errors:not([hidden])")
    assert "positions must increase strictly: point 3 (10) is not past point 2 (10)" in page.inner_text("#error-text")
    assert page.evaluate("window.tetmorph.history()")["entries"] == before  # nothing was sent
    table_point(page, "shaft", 2, 20, 1)
    page.press(f"{row('shaft')} .twist-point >> nth=2 >> [data-deg]", "Enter")
    settle(page)
    table = [{"at": 0, "angle_deg": 0}, {"at": 10, "angle_deg": 3}, {"at": 20, "angle_deg": 1}]
    assert page.evaluate("window.tetmorph.session().lastMove")["twist"] == {"shaft": {"table": table}}
    sent = sent_spec(page)
    move = {"twist": {"shaft": {"table": table}}}
    np.testing.assert_allclose(positions(page), precompute(bracket, sent).solve(move).V, rtol=0, atol=SHOWN)
    # each node of the end face turned about the axis by the table's angle at its axial position
    axis = sent["twist"][0]["axis"]
    p0, u = np.array(axis["point"]), np.array(axis["direction"]) / np.linalg.norm(axis["direction"])
    P, V = positions(page), bracket.V
    for i in bracket.sets["LOAD"][::4]:
        x = V[i] - p0
        t = np.radians(np.interp(x @ u, [0, 10, 20], [0, 3, 1]))
        r = x * np.cos(t) + np.cross(u, x) * np.sin(t) + u * (u @ x) * (1 - np.cos(t))
        np.testing.assert_allclose(P[i], p0 + r, atol=SHOWN)


def test_a_bend_toward_two_picked_nodes(page, bracket):
    load_bracket(page)
    regions_of(page, "LOAD")
    V = bracket.V
    a, b = load_corners(bracket)
    front = np.flatnonzero(bracket.boundary & (np.abs(V[:, 1]) < 1e-9))  # the y = 0 face, in the first view
    c = front[np.argmin(np.abs(V[front, 0] - 97) + np.abs(V[front, 2] - 10))]
    pick(page, (a, b, c))
    open_edits(page, "twist")
    choose_region(page, "#edit-region", "LOAD")
    page.select_option("#edit-axis", "AB")
    page.select_option("#edit-twist-mode", "bend")
    page.select_option("#edit-toward-from", "picked")
    add_edit(page, "arc")
    create(page)
    type_value(page, "arc", 0.8)
    entry = sent_spec(page)["twist"][0]
    assert entry["mode"] == "bend"
    np.testing.assert_allclose(entry["toward"], V[c] - V[b], atol=1e-5)  # from B to C, the last two picked
    sent = sent_spec(page)
    want = precompute(bracket, sent).solve({"twist": {"arc": {"angle_deg_per_length": 0.8}}}).V
    np.testing.assert_allclose(positions(page), want, rtol=0, atol=SHOWN)
    assert np.abs(want - V).max() > 0.1  # it bent


def test_a_map_onto_a_typed_cylinder_along_a_direction(page, bracket):
    load_bracket(page)
    regions_of(page, "LOAD")
    open_edits(page, "map")
    choose_region(page, "#edit-region", "LOAD")
    page.select_option("#edit-geometry", "cylinder")
    page.select_option("#edit-gsource", "typed")
    page.fill("#edit-gpoint", "110 0 5")
    page.fill("#edit-gdir", "0 1 0")
    page.fill("#edit-gradius", "12")
    page.select_option("#edit-projection", "along")
    page.fill("#edit-pdir", "1 0 0")
    add_edit(page, "dish")
    create(page)
    drag_slider(page, "dish", 1.1)  # to its end: amount 1
    assert page.evaluate("window.tetmorph.session().lastMove")["map"] == {"dish": {"amount": 1}}
    entry = sent_spec(page)["map"][0]
    assert entry["geometry"] == {"cylinder": {"point": [110, 0, 5], "axis": [0, 1, 0], "radius": 12}}
    assert entry["projection"] == "along" and entry["direction"] == [1, 0, 0]
    spec = {"selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"set": "LOAD"}}, "fixed": ["FIXED"],
            "map": [{**entry, "selection": "LOAD"}]}
    want = precompute(bracket, spec).solve({"map": {"dish": {"amount": 1.0}}}).V
    P = positions(page)
    np.testing.assert_allclose(P, want, rtol=0, atol=SHOWN)
    load, V = bracket.sets["LOAD"], bracket.V  # on the cylinder, moved along x only, by its nearer side
    np.testing.assert_allclose(np.hypot(P[load, 0] - 110, P[load, 2] - 5), 12, atol=SHOWN)
    np.testing.assert_allclose(P[load][:, 1:], V[load][:, 1:], atol=SHOWN)
    assert (P[load, 0] < 100).all()


def test_a_map_onto_a_sphere_through_picked_nodes(page, bracket):
    load_bracket(page)
    regions_of(page, "LOAD")
    V = bracket.V
    a, _ = load_corners(bracket)
    front = np.flatnonzero(bracket.boundary & (np.abs(V[:, 1]) < 1e-9))  # the y = 0 face, in the first view
    b = front[np.argmin(np.abs(V[front, 0] - 97) + np.abs(V[front, 2] - 10))]  # the centre: off the end face
    pick(page, (b, a))
    open_edits(page, "map")
    choose_region(page, "#edit-region", "LOAD")
    page.select_option("#edit-geometry", "sphere")
    add_edit(page, "ball")
    create(page)
    type_value(page, "ball", 0.25)
    entry = sent_spec(page)["map"][0]
    np.testing.assert_allclose(entry["geometry"]["sphere"]["center"], V[b], atol=1e-5)
    assert entry["geometry"]["sphere"]["radius"] == pytest.approx(np.linalg.norm(V[a] - V[b]), rel=1e-6)
    want = precompute(bracket, sent_spec(page)).solve({"map": {"ball": {"amount": 0.25}}}).V
    np.testing.assert_allclose(positions(page), want, rtol=0, atol=SHOWN)


def test_a_shape_slider_carries_the_edit_value_of_its_preset(page, bracket):
    bore_session(page)
    type_value(page, "bore", 6)
    page.fill("#preset-name", "wider")
    page.click("#preset-save")
    page.wait_for_selector("#shapes input[data-shape='wider']")
    preset = page.evaluate("window.tetmorph.session().presets")[0]["move"]
    assert preset["radius"] == {"bore": {"radius": 6}}
    slider = page.locator("#shapes input[data-shape='wider']")
    slider.scroll_into_view_if_needed()
    box = slider.bounding_box()  # from -1 to 2: dragged from 0 to about 0.5
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + box["width"] / 3, y)
    page.mouse.down()
    page.mouse.move(box["x"] + box["width"] / 2, y, steps=6)
    page.mouse.up()
    settle(page)
    theta = float(page.input_value("#shapes input[data-shape='wider']"))
    assert 0.2 < theta < 0.8
    h = hole(bracket)
    spec = {"selections": {"FIXED": {"set": "FIXED"}, "hole": {"ids": h.ids.tolist()}}, "fixed": ["FIXED"],
            "radius": [{"name": "bore", "selection": "hole", "axis": sent_spec(page)["radius"][0]["axis"]}]}
    d = precompute(bracket, spec)
    move = combine(parse_shapes({"shapes": {"wider": preset}}, d), [theta])
    np.testing.assert_allclose(positions(page), d.solve(move).V, rtol=0, atol=SHOWN)
    r0 = d.data.constraints.rest.nominal["radius"]["bore"]
    sent = page.evaluate("window.tetmorph.session().lastMove")["radius"]["bore"]
    assert sent["delta"] == pytest.approx(theta * (6 - r0), rel=1e-5)
    shown = float(page.input_value(f"{row('bore')} input[type=number]"))
    assert shown == pytest.approx(r0 + theta * (6 - r0), rel=1e-5)
