"""Issue 29, the rest of it: the undo history kept with the session on the service, morph domains,
and the gizmo in local axes, each driven in a real browser against a real server.

Every test here failed on the editor before its change (run against that build once).
"""

from __future__ import annotations

import time

import httpx
import numpy as np
import pytest

from solver import read_mesh
from tests.browser.conftest import (
    BRACKET,
    DATA,
    assign_set,
    bracket_session,
    create,
    drag,
    image,
    load_bracket,
    numeric_move,
    positions,
    report_row,
    settle,
    upload,
    use_spec,
)


def _service_history(base: str, sid: str) -> dict:
    r = httpx.get(f"{base}/v1/sessions/{sid}/history")
    assert r.status_code == 200, r.text
    return r.json()


def _tz(move: dict) -> float:
    """The z translation of the only handle of a MOVE the editor sent."""
    (h,) = move["handles"].values()
    return h["translation"][2]


def _wait_history(base: str, sid: str, applied: list[float], undone: list[float], timeout: float = 10) -> dict:
    """Wait until the service holds a history of these z translations (the editor saves it shortly after)."""
    deadline = time.monotonic() + timeout
    while True:
        doc = _service_history(base, sid)
        got = ([_tz(m) for m in doc["applied"]], [_tz(m) for m in doc["undone"]])
        if got == (applied, undone) or time.monotonic() > deadline:
            assert got == (applied, undone), doc
            return doc
        time.sleep(0.1)


def _open_from_sessions(pg, sid: str) -> None:
    pg.click("#sessions-btn")
    pg.click(f"#sessions-table tr[data-id={sid}] button[data-act=open]")
    pg.wait_for_function(f"window.tetmorph.session().id === '{sid}' && window.tetmorph.session().stream.open")


def _reopened(pg, sid: str) -> None:
    """After a reload: the address reopens the session (Sessions lists it as the open one)."""
    pg.wait_for_function(f"window.tetmorph.session().id === '{sid}' && window.tetmorph.session().stream"
                         " && window.tetmorph.session().stream.open", timeout=60000)
    pg.click("#sessions-btn")
    pg.wait_for_selector(f"#sessions-table tr[data-id={sid}] button[data-act=close]")
    pg.click("#sessions-close")


def _editor_history(pg, doc: dict | None = None) -> tuple[list, list]:
    """The MOVEs of the editor's history before and after the entry shown (entry 0, the rest, left out);
    with the service's history `doc`, once the editor holds as many entries (it reads them after the
    stream opens)."""
    if doc is not None:
        n = 1 + len(doc["applied"]) + len(doc["undone"])
        pg.wait_for_function(f"window.tetmorph.history().entries.length === {n}", timeout=10000)
    h = pg.evaluate("window.tetmorph.history()")
    moves = [e["move"] for e in h["entries"]]
    return moves[1:h["index"] + 1], moves[h["index"] + 1:]


def test_the_undo_history_is_kept_with_the_session_on_the_service(pages, server):
    page = pages(server)
    bracket_session(page)
    sid = page.evaluate("window.tetmorph.session().id")
    shapes = []
    for tz in (2, 4, 6):
        page.fill("#tz", str(tz))
        page.keyboard.press("Enter")
        settle(page)
        shapes.append(positions(page))
    page.click("#undo")
    settle(page)
    # on the service, independently of the page: two applied, the third undone
    doc = _wait_history(server, sid, [2, 4], [6])

    page.reload()
    page.wait_for_function("window.tetmorph !== undefined")
    _reopened(page, sid)
    assert _editor_history(page, doc) == (doc["applied"], doc["undone"])
    np.testing.assert_allclose(positions(page), shapes[1], atol=1e-4)
    page.click("#undo")
    settle(page)
    np.testing.assert_allclose(positions(page), shapes[0], atol=1e-5)
    doc = _wait_history(server, sid, [2], [4, 6])
    assert _editor_history(page) == (doc["applied"], doc["undone"])

    # another browser (nothing of the first one's storage) reopens it with the same history
    other = pages(server)
    _open_from_sessions(other, sid)
    assert _editor_history(other, doc) == (doc["applied"], doc["undone"])
    other.keyboard.press("Control+Shift+Z")
    settle(other)
    np.testing.assert_allclose(positions(other), shapes[1], atol=1e-5)
    _wait_history(server, sid, [2, 4], [6])


def test_a_painted_morph_domain_holds_the_rest_at_rest_and_a_far_moving_free_node_is_warned_of(page):
    mesh = read_mesh(BRACKET)  # a 100 x 20 x 10 bar, FIXED at x = 0, LOAD at x = 100
    V = mesh.V
    load_bracket(page)
    assign_set(page, "FIXED", 1)
    assign_set(page, "LOAD", 2)
    page.keyboard.press("1")  # the front view: x to the right, z up
    # paint the domain with a box through the mesh around the part beyond x = 55
    inside = np.flatnonzero(V[:, 0] > 55)
    page.wait_for_timeout(1000)  # the view's camera has arrived
    pts = np.array([[p["x"], p["y"]] for p in
                    page.evaluate("(ids) => ids.map((i) => window.tetmorph.screenOf(i))", inside.tolist())])
    x0, y0 = pts.min(0) - [2, 20]
    x1, y1 = pts.max(0) + 20
    page.check("input[name=role][value='3']")
    page.check("input[name=tool][value='box']")
    drag(page, x0, y0, x1, y1)
    page.check("input[name=tool][value='orbit']")
    assert page.inner_text("#domain-count").startswith("domain: ")
    assert page.inner_text("#domain-count") != "domain: whole mesh"
    # the domain is drawn: a node of it in no region wears the domain's tint, one outside it does not
    free_in = int(next(i for i in inside if mesh.boundary[i] and not np.isin(i, mesh.sets["LOAD"])))
    free_out = int(next(i for i in np.flatnonzero(V[:, 0] < 40) if mesh.boundary[i]))
    assert page.evaluate(f"window.tetmorph.surfaceColor({free_in})") != page.evaluate(
        f"window.tetmorph.surfaceColor({free_out})")
    create(page)
    sid = page.evaluate("window.tetmorph.session().id")
    spec = httpx.get(f"{page.base}/v1/sessions/{sid}").json()["spec"]
    domain = np.asarray(spec["selections"][spec["domain"]]["ids"])
    assert set(inside[mesh.referenced[inside]].tolist()) <= set(domain.tolist())
    assert not np.any(V[domain, 0] < 50)  # the box left the first half out
    numeric_move(page, axis=(0, 1, 0), angle=20)
    settle(page)
    P = positions(page)
    d = np.linalg.norm(P - V, axis=1)
    outside = np.setdiff1d(np.arange(len(V)), domain)
    assert d[outside].max() < 1e-4  # everything outside the domain stayed at rest
    assert d[domain].max() > 1.0
    handle = mesh.sets["LOAD"]
    free = np.setdiff1d(np.arange(len(V)), np.concatenate([handle, mesh.sets["FIXED"]]))
    assert d[free].max() > d[handle].max() * 1.05  # measured: a free node moves farther than the handle
    page.wait_for_selector("#report tr[data-key=free_exceeds]", timeout=10000)
    warning = report_row(page, "free_exceeds")
    assert warning is not None and "free node moves" in warning
    assert float(report_row(page, "max_free_displacement").split()[0]) == pytest.approx(d[free].max(), rel=1e-2)


def test_the_gizmo_moves_along_the_local_axes(page):
    bracket_session(page)
    mesh = read_mesh(BRACKET)
    V = mesh.V
    load = mesh.sets["LOAD"]  # the x = 100 end face: local axes in its plane, none along a global one
    a = load[np.argmin(V[load, 1] + V[load, 2])]
    b = load[np.argmax(V[load, 1] - V[load, 2])]
    c = load[np.argmax(V[load, 1] + V[load, 2])]
    page.check("input[name=tool][value='pick']")
    for i in (a, b, c):
        p = page.evaluate("(i) => window.tetmorph.screenOf(i)", int(i))
        page.mouse.click(p["x"], p["y"])
    page.click("#csys-from-picks")
    page.check("input[name=tool][value='orbit']")
    page.uncheck("#snap")
    e1 = (V[b] - V[a]) / np.linalg.norm(V[b] - V[a])
    # along the local x axis on screen, from the gizmo's centre, until the pointer is over its x arrow
    centre = np.array(page.evaluate("window.tetmorph.pivot()")["position"])
    s0 = page.evaluate("window.tetmorph.pivotScreen()")
    s1 = page.evaluate("(p) => window.tetmorph.worldToPage(p)", (centre + 5 * e1).tolist())
    u = np.array([s1["x"] - s0["x"], s1["y"] - s0["y"]])
    u /= np.linalg.norm(u)
    grab = None
    for r in range(15, 160, 3):
        x, y = s0["x"] + r * u[0], s0["y"] + r * u[1]
        page.mouse.move(x, y)
        if page.evaluate("window.tetmorph.gizmoAxis()") == "X":
            grab = (x, y)
            break
    assert grab is not None, "no x arrow of the gizmo along the local x axis"
    page.mouse.down()
    for k in range(1, 11):
        page.mouse.move(grab[0] + 6 * k * u[0], grab[1] + 6 * k * u[1])
        time.sleep(0.03)
    page.mouse.up()
    settle(page)
    sid = page.evaluate("window.tetmorph.session().id")
    (h,) = httpx.get(f"{page.base}/v1/sessions/{sid}").json()["last_move"]["handles"].values()
    t = np.array(h["translation"])
    assert np.linalg.norm(t) > 1
    np.testing.assert_allclose(t / np.linalg.norm(t), e1, atol=1e-6)  # along the local x only
    # the fields, in local axes, say so
    tx, ty, tz = (float(page.input_value(f"#{k}")) for k in ("tx", "ty", "tz"))
    assert tx == pytest.approx(np.linalg.norm(t), abs=1e-3) and ty == 0 and tz == 0
    # and the handle's nodes moved by it (from the positions, against the mesh file)
    np.testing.assert_allclose(positions(page)[load] - V[load], np.tile(t, (len(load), 1)), atol=1e-4)


def test_a_target_surface_is_set_up_in_the_panel_and_drawn(page, tmp_path):
    # a stored surface on the service: a square in the plane x = 110, beyond the bracket's end face
    stl = tmp_path / "wall.stl"
    corners = [(110, -5, -5), (110, 25, -5), (110, 25, 15), (110, -5, 15)]
    tris = [(0, 1, 2), (0, 2, 3)]
    stl.write_text("solid wall\n" + "".join(
        "facet normal 1 0 0\n outer loop\n" + "".join(f"  vertex {x} {y} {z}\n" for x, y, z in (corners[i] for i in t))
        + " endloop\nendfacet\n" for t in tris) + "endsolid wall\n")
    with stl.open("rb") as f:
        r = httpx.post(f"{page.base}/v1/meshes", files={"file": ("wall.stl", f)})
    assert r.status_code == 201, r.text
    wall = r.json()["id"]
    load_bracket(page)
    before = image(page.locator("#canvas").screenshot())
    page.click("#sec-symmetry summary")
    page.wait_for_selector(f"#tgt-surface option[value={wall}]", state="attached")
    page.select_option("#tgt-set", "LOAD")
    page.select_option("#tgt-surface", wall)
    page.click("#tgt-add")
    spec = page.evaluate("window.tetmorph.spec()")
    assert spec["targets"] == [{"name": "target1", "selection": "LOAD", "surface": {"mesh_id": wall},
                                "method": "closest"}]
    assert spec["selections"]["LOAD"] == {"set": "LOAD"}
    page.wait_for_function("window.tetmorph.targetSurfaces() === 1")
    # drawn: the view changed where the square's centre is on screen
    page.wait_for_timeout(200)
    after = image(page.locator("#canvas").screenshot())
    box = page.eval_on_selector("#canvas", "c => { const r = c.getBoundingClientRect(); return [r.left, r.top]; }")
    p = page.evaluate("(p) => window.tetmorph.worldToPage(p)", [110, 10, 5])
    x, y = int(p["x"] - box[0]), int(p["y"] - box[1])
    assert np.abs(after[y - 3:y + 4, x - 3:x + 4] - before[y - 3:y + 4, x - 3:x + 4]).max() > 20
    page.click("#tgt-list button[data-k='0']")
    assert "targets" not in page.evaluate("window.tetmorph.spec()")
    page.wait_for_function("window.tetmorph.targetSurfaces() === 0")


def _spec_domain(pg) -> np.ndarray:
    """The morph domain of the open session's SPEC on the service, as vertex ids."""
    sid = pg.evaluate("window.tetmorph.session().id")
    spec = httpx.get(f"{pg.base}/v1/sessions/{sid}").json()["spec"]
    return spec, spec["selections"][spec["domain"]]


def test_a_morph_domain_painted_with_the_brush_takes_the_ball_under_it(page):
    mesh = read_mesh(BRACKET)
    V = mesh.V
    load_bracket(page)
    assign_set(page, "FIXED", 1)
    assign_set(page, "LOAD", 2)
    page.check("input[name=role][value='3']")
    page.check("input[name=tool][value='brush']")
    page.focus("#brush")
    page.keyboard.press("End")  # the largest brush: 15 % of the diagonal
    r = 0.15 * np.linalg.norm(V.max(0) - V.min(0))
    assert f"r {r:.3g}" in page.inner_text("#brush-size")
    load = mesh.sets["LOAD"]  # the end face x = 100; brush its middle node
    n = int(load[np.argmin(np.linalg.norm(V[load] - [100, 10, 5], axis=1))])
    p = page.evaluate("(i) => window.tetmorph.screenOf(i)", n)
    page.mouse.click(p["x"], p["y"])
    page.check("input[name=tool][value='orbit']")
    assert page.inner_text("#domain-count") != "domain: whole mesh"
    create(page)
    spec, sel = _spec_domain(page)
    domain = np.asarray(sel["ids"])
    d = np.linalg.norm(V - V[n], axis=1)  # the ball about the point brushed (within a pixel of node n)
    assert set(np.flatnonzero(d < r - 0.5)) <= set(domain.tolist())
    assert d[domain].max() <= r + 0.5
    assert not mesh.boundary[domain].all()  # the nodes inside the ball too, not only the surface
    numeric_move(page, t=(0, 0, 2))
    settle(page)
    moved = np.linalg.norm(positions(page) - V, axis=1)
    assert moved[np.setdiff1d(np.arange(len(V)), domain)].max() < 1e-4  # outside the ball: at rest
    np.testing.assert_allclose(positions(page)[load] - V[load], np.tile([0, 0, 2], (len(load), 1)), atol=1e-4)


def test_a_morph_domain_from_a_named_set_is_sent_as_the_set_and_kept_on_reopen(page):
    deck = DATA / "mixed.msh"  # a 40 x 10 x 14 bar: hexahedra x < 20, tets x > 20 (set TET), wedges on top
    mesh = read_mesh(deck)
    V = mesh.V
    upload(page, deck)
    spec = {"selections": {"FIXED": {"set": "FIXED"}, "end": {"box": {"min": [39.9, -1, -1], "max": [41, 11, 10.01]}}},
            "fixed": ["FIXED"], "handles": {"end": "end"}}
    use_spec(page, spec)
    page.check("input[name=role][value='3']")
    page.select_option("#sets", "TET")
    page.click("#set-apply")
    tet = mesh.sets["TET"]
    assert page.inner_text("#domain-count").startswith(f"domain: {len(tet)} vertices")
    got = page.evaluate("window.tetmorph.spec()")
    assert got["selections"][got["domain"]] == {"set": "TET"}
    create(page)
    stored, sel = _spec_domain(page)
    assert sel == {"set": "TET"}
    numeric_move(page, t=(0, 0, 0.5))
    settle(page)
    moved = np.linalg.norm(positions(page) - V, axis=1)
    assert moved[np.setdiff1d(np.arange(len(V)), tet)].max() < 1e-4  # the hexahedra and wedges at rest
    end = np.flatnonzero((V[:, 0] >= 39.9) & (V[:, 2] <= 10.01))
    np.testing.assert_allclose(positions(page)[end] - V[end], np.tile([0, 0, 0.5], (len(end), 1)), atol=1e-4)
    assert 0.01 < moved[np.setdiff1d(tet, end)].max()  # the domain's free nodes followed
    sid = page.evaluate("window.tetmorph.session().id")
    page.reload()
    page.wait_for_function("window.tetmorph !== undefined")
    _reopened(page, sid)
    again = page.evaluate("window.tetmorph.spec()")
    assert again["selections"][again["domain"]] == {"set": "TET"}
    assert page.inner_text("#domain-count").startswith(f"domain: {len(tet)} vertices")
