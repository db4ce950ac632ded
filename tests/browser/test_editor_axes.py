"""Local coordinate systems and pivots, driven in a real browser: axes from a feature candidate's axis
and typed ones, used by the numeric moves and the gizmo, and the gizmo's rings turning about a pivot
picked on the model. Positions are checked against the library's solve of the same SPEC and MOVE.

Every test here failed on the editor before its change (run against that build once).
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

from solver import precompute, read_mesh
from solver.constraints.features import feature_candidates
from tests.browser.conftest import BRACKET, assign_set, bracket_session, create, positions, settle, upload

SPEC = {"selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"set": "LOAD"}}, "fixed": ["FIXED"],
        "handles": {"LOAD": "LOAD"}}


def rotation(axis, deg) -> np.ndarray:
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    a = np.radians(deg)
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def tilted_bracket(path: Path, R: np.ndarray) -> Path:
    """bracket.inp with every node turned by R (its hole's axis then lies along no global axis)."""
    out, in_nodes = [], False
    for ln in BRACKET.read_text().splitlines():
        if ln.startswith("*"):
            in_nodes = ln.strip().upper() == "*NODE"
        elif in_nodes and ln.strip():
            i, *x = (s.strip() for s in ln.split(","))
            y = R @ np.array([float(v) for v in x])
            ln = f"{i}, {y[0]:.17g}, {y[1]:.17g}, {y[2]:.17g}"
        out.append(ln)
    path.write_text("\n".join(out) + "\n")
    return path


def last_handle(pg) -> dict:
    sid = pg.evaluate("window.tetmorph.session().id")
    (h,) = httpx.get(f"{pg.base}/v1/sessions/{sid}").json()["last_move"]["handles"].values()
    return h


def library_positions(mesh, move: dict) -> np.ndarray:
    return precompute(mesh, SPEC).solve({"handles": {"LOAD": move}}).V


def quaternion_rotation(q) -> np.ndarray:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def grab(pg, origin, direction, axis: str, radii=range(15, 200, 3)) -> tuple[float, float, np.ndarray]:
    """Move the real pointer from the gizmo's centre along a world direction's image on screen until it
    is over the gizmo handle `axis` ("X", "Z", ...); answers where, and the unit screen direction."""
    s0 = pg.evaluate("(p) => window.tetmorph.worldToPage(p)", list(map(float, origin)))
    s1 = pg.evaluate("(p) => window.tetmorph.worldToPage(p)",
                     list(map(float, np.asarray(origin) + 5 * np.asarray(direction))))
    u = np.array([s1["x"] - s0["x"], s1["y"] - s0["y"]])
    u /= np.linalg.norm(u)
    for r in radii:
        x, y = s0["x"] + r * u[0], s0["y"] + r * u[1]
        pg.mouse.move(x, y)
        if pg.evaluate("window.tetmorph.gizmoAxis()") == axis:
            return x, y, u
    pytest.fail(f"no {axis} handle of the gizmo along {direction}")


def drag_from(pg, x: float, y: float, dx: float, dy: float, steps: int = 10) -> None:
    pg.mouse.down()
    for k in range(1, steps + 1):
        pg.mouse.move(x + dx * k / steps, y + dy * k / steps)
        time.sleep(0.03)
    pg.mouse.up()


def type_axes(pg, origin: str, x: str, z: str, enter: bool = False) -> None:
    """Type local axes in the typed-axes fields; set them with the button, or Enter in the z field."""
    if not pg.is_visible("#csys-origin"):
        pg.click("#sec-csys summary")
    pg.fill("#csys-origin", origin)
    pg.fill("#csys-x", x)
    pg.fill("#csys-z", z)
    if enter:
        pg.press("#csys-z", "Enter")
    else:
        pg.click("#csys-set")


def test_local_axes_from_a_feature_candidates_axis_drive_the_numeric_moves(page, tmp_path):
    R = rotation([1, 2, 3], 35)
    deck = tilted_bracket(tmp_path / "tilted.inp", R)
    mesh = read_mesh(deck)
    hole = next(c.to_dict() for c in feature_candidates(mesh, 30, 1e-3) if c.name == "hole_1")
    z = np.asarray(hole["axis"], float) / np.linalg.norm(hole["axis"])
    assert abs(abs(z @ (R @ [0, 0, 1])) - 1) < 1e-9  # the hole's axis, turned with the deck
    upload(page, deck)
    assign_set(page, "FIXED", 1)
    assign_set(page, "LOAD", 2)
    create(page)
    page.click("#find-features")
    page.click("#features li:has-text('hole_1') button[data-kind=axes]")
    assert page.is_checked("#local")
    x = np.eye(3)[int(np.argmin(np.abs(z)))]  # the global axis least along z, made normal to it
    x = x - (x @ z) * z
    x /= np.linalg.norm(x)
    np.testing.assert_allclose(page.evaluate("window.tetmorph.csys()"), [x, np.cross(z, x), z], atol=1e-6)
    np.testing.assert_allclose(page.evaluate("window.tetmorph.csysOrigin()"), hole["center"], atol=1e-6)
    assert "hole_1" in page.inner_text("#csys-text")
    # 3 along the hole's axis and 20 degrees about it, typed in the local fields
    for k, v in (("tx", 0), ("ty", 0), ("tz", 3), ("ax", 0), ("ay", 0), ("az", 1), ("angle", 20)):
        page.fill(f"#{k}", str(v))
    page.click("#apply-move")
    settle(page)
    h = last_handle(page)
    np.testing.assert_allclose(h["translation"], 3 * z, atol=1e-5)
    w, *v = h["rotation"]["quaternion"]
    np.testing.assert_allclose(np.array(v) / np.sin(np.radians(10)), z, atol=1e-6)
    assert np.degrees(2 * np.arccos(w)) == pytest.approx(20, abs=1e-6)
    expected = library_positions(mesh, {"translation": (3 * z).tolist(),
                                        "rotation": {"axis": z.tolist(), "angle_deg": 20}, "pivot": h["pivot"]})
    np.testing.assert_allclose(positions(page), expected, atol=1e-4)


def test_typed_local_axes_are_made_orthonormal_and_drive_the_gizmo_and_the_fields(page):
    bracket_session(page)
    mesh = read_mesh(BRACKET)
    V = mesh.V
    # degenerate input: said in words, and the axes stay global
    for origin, xa, za, words in (("100 10 5", "1 0 0", "0 0 0", "z axis is zero"),
                                  ("100 10 5", "0 2 2", "0 1 1", "x axis is along the z axis"),
                                  ("100 10", "1 0 0", "0 0 1", "origin needs three numbers")):
        type_axes(page, origin, xa, za)
        page.wait_for_selector("#errors:not([hidden])")
        assert words in page.inner_text("#error-text")
        assert page.evaluate("window.tetmorph.csys()") is None and not page.is_checked("#local")
    # x not normal to z: made normal to it
    type_axes(page, "100 10 5", "1 1 0.5", "0 1 1", enter=True)
    assert page.is_checked("#local")
    e3 = np.array([0, 1, 1]) / np.sqrt(2)
    e1 = np.array([1, 1, 0.5]) - (np.array([1, 1, 0.5]) @ e3) * e3
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e3, e1)
    np.testing.assert_allclose(page.evaluate("window.tetmorph.csys()"), [e1, e2, e3], atol=1e-6)
    np.testing.assert_allclose(page.evaluate("window.tetmorph.csysOrigin()"), [100, 10, 5])
    # the gizmo's z arrow is the local z: a drag on it moves the handle along e3 only
    page.uncheck("#snap")
    centre = np.array(page.evaluate("window.tetmorph.pivot()")["position"])
    gx, gy, u = grab(page, centre, e3, "Z")
    drag_from(page, gx, gy, 60 * u[0], 60 * u[1])
    settle(page)
    h = last_handle(page)
    t = np.array(h["translation"])
    assert np.linalg.norm(t) > 1
    np.testing.assert_allclose(t / np.linalg.norm(t), e3, atol=1e-6)
    load = mesh.sets["LOAD"]
    np.testing.assert_allclose(positions(page)[load] - V[load], np.tile(t, (len(load), 1)), atol=1e-4)
    shown = [float(page.input_value(f"#{k}")) for k in ("tx", "ty", "tz")]
    np.testing.assert_allclose(shown, [0, 0, np.linalg.norm(t)], atol=1e-3)
    # and the numeric fields: 4 along the local x
    for k, v in (("tx", 4), ("ty", 0), ("tz", 0)):
        page.fill(f"#{k}", str(v))
    page.click("#apply-move")
    settle(page)
    h = last_handle(page)
    np.testing.assert_allclose(h["translation"], 4 * e1, atol=1e-5)
    expected = library_positions(mesh, {"translation": (4 * e1).tolist(), "pivot": h["pivot"]})
    np.testing.assert_allclose(positions(page), expected, atol=1e-4)
    assert re.search(r"typed", page.inner_text("#csys-text"))


def turn_on_ring(pg, ring_plane_dir, axis: str, normal) -> None:
    """Grab the gizmo's `axis` ring (normal to `normal`) where a direction in its plane meets it, and drag
    along normal x (to the eye) on screen, the direction the gizmo turns fastest for."""
    centre = np.array(pg.evaluate("window.tetmorph.pivot()")["position"])
    gx, gy, _ = grab(pg, centre, ring_plane_dir, axis)
    cam = pg.evaluate("window.tetmorph.camera()")
    w = np.cross(normal, np.array(cam["position"]) - np.array(cam["target"]))
    s0, s1 = (pg.evaluate("(p) => window.tetmorph.worldToPage(p)", list(map(float, centre + k * w))) for k in (0, 1))
    u = np.array([s1["x"] - s0["x"], s1["y"] - s0["y"]])
    u /= np.linalg.norm(u)
    drag_from(pg, gx, gy, 50 * u[0], 50 * u[1])
    settle(pg)


def assert_turned_about(pg, mesh, point, axis) -> None:
    """The service's MOVE turns the handle about `point` (its pivot), about `axis`, and the nodes followed."""
    h = last_handle(pg)
    np.testing.assert_allclose(h["pivot"], point, atol=1e-4)
    np.testing.assert_allclose(h["translation"], [0, 0, 0], atol=1e-4)
    w, *v = h["rotation"]["quaternion"]
    angle = np.degrees(2 * np.arccos(min(1.0, abs(w))))
    assert angle > 10
    np.testing.assert_allclose(abs(np.array(v) @ axis) / np.linalg.norm(v), 1, atol=1e-6)
    R = quaternion_rotation(h["rotation"]["quaternion"])
    load = mesh.sets["LOAD"]
    P = positions(pg)
    np.testing.assert_allclose(P[load], point + (mesh.V[load] - point) @ R.T, atol=1e-4)  # turned about it
    assert np.linalg.norm(P[load].mean(0) - mesh.V[load].mean(0)) > 1  # not about the handle's centre
    move = {"rotation": {"quaternion": h["rotation"]["quaternion"]}, "pivot": list(map(float, point))}
    expected = library_positions(mesh, move)
    np.testing.assert_allclose(P, expected, atol=1e-4)


def test_the_gizmo_rings_turn_about_a_picked_node_or_the_local_origin(page):
    bracket_session(page)
    mesh = read_mesh(BRACKET)
    V = mesh.V
    page.uncheck("#snap")
    # node A on the top face, well away from the handle (the x = 100 end)
    top = np.flatnonzero(mesh.boundary & (np.abs(V[:, 2] - 10) < 1e-9))
    a = int(top[np.argmin(np.linalg.norm(V[top] - [70, 10, 10], axis=1))])
    page.check("input[name=tool][value='pick']")
    p = page.evaluate("(i) => window.tetmorph.screenOf(i)", a)
    page.mouse.click(p["x"], p["y"])
    assert page.evaluate("window.tetmorph.measure()")["vertices"] == [a]
    page.check("input[name=tool][value='orbit']")
    page.select_option("#dpivot", "A")
    page.keyboard.press("e")  # rotate: the rings go to node A
    np.testing.assert_allclose(page.evaluate("window.tetmorph.pivot()")["position"], V[a], atol=1e-4)
    turn_on_ring(page, np.array([1, 1, 0]) / np.sqrt(2), "Z", np.array([0, 0, 1]))
    assert_turned_about(page, mesh, V[a], np.array([0, 0, 1]))
    # about the origin of typed local axes, on the local z ring
    page.click("#reset")
    page.click("#confirm-ok")
    page.wait_for_function("window.tetmorph.report() && window.tetmorph.report().reset === true")
    type_axes(page, "100 20 10", "1 0 0", "0 1 1")
    page.select_option("#dpivot", "origin")
    np.testing.assert_allclose(page.evaluate("window.tetmorph.pivot()")["position"], [100, 20, 10], atol=1e-9)
    e1, e2, e3 = (np.array(e) for e in page.evaluate("window.tetmorph.csys()"))
    turn_on_ring(page, (e1 + e2) / np.sqrt(2), "Z", e3)
    assert_turned_about(page, mesh, np.array([100.0, 20, 10]), e3)
    # the translate arrows are back on the handle's centre
    page.keyboard.press("w")
    h = last_handle(page)
    c = np.array(page.evaluate("window.tetmorph.pivot()")["centroid"])
    R = quaternion_rotation(h["rotation"]["quaternion"])
    o = np.array([100.0, 20, 10])
    np.testing.assert_allclose(page.evaluate("window.tetmorph.pivot()")["position"], o + R @ (c - o), atol=1e-4)
