"""Region editing and constraint diagnostics (issue 43), driven in a real browser as a person does:
rename and merge regions, pick nodes and elements by the deck's ids and ranges, flood fill a face
region up to a feature angle, undo and redo region edits with the keys, and see the nodes of
conflicting constraints and the cyclic faces' pairs.

Expected sets are computed here from the deck, read line by line (its own *NODE and *ELEMENT
numbers), or from the mesh's boundary faces with numpy. Every test failed on the editor before
region editing and the diagnostics were added (run against that build once: no #region-name, no
fill tool, no #diag list).
"""

from __future__ import annotations

from collections import defaultdict

import meshio
import numpy as np
from scipy.spatial import cKDTree

from solver import read_mesh
from tests.browser.conftest import (
    BRACKET,
    assign_set,
    create,
    numeric_move,
    positions,
    rest,
    settle,
    shared_file,
    steady_point,
    upload,
    use_spec,
)


def deck_numbers(deck) -> tuple[list[int], dict[int, list[int]]]:
    """The deck's node number of each vertex (its *NODE lines in order) and each C3D4 element's node numbers."""
    nodes, elements, key, solid = [], {}, "", False
    for line in deck.read_text().splitlines():
        s = line.strip()
        if s.startswith("**") or not s:
            continue
        if s.startswith("*"):
            key = s.split(",")[0].strip("* ").upper()
            solid = "C3D4" in s.upper()
            continue
        if key not in ("NODE", "ELEMENT"):
            continue
        f = [int(float(x)) for x in s.split(",")[:5]]
        if key == "NODE":
            nodes.append(f[0])
        elif key == "ELEMENT" and solid:
            elements[f[0]] = f[1:5]
    return nodes, elements


def in_ranges(x: int, ranges) -> bool:
    return any(lo <= x <= hi for lo, hi in ranges)


def region_ids(pg, name: str) -> list[int] | None:
    """The vertex ids the SPEC sends for a region (a named set resolved to its vertices)."""
    sel = pg.evaluate("window.tetmorph.spec()")["selections"].get(name)
    if sel is None:
        return None
    if "set" in sel:
        return sorted(pg.evaluate("(n) => window.tetmorph.set(n)", sel["set"]))
    return sorted(sel["ids"])


def names(pg) -> list[str]:
    return [r["name"] for r in pg.evaluate("window.tetmorph.regions()")]


def body_keys(pg, key: str) -> None:
    pg.evaluate("document.activeElement && document.activeElement.blur()")  # out of any field: keys act on the editor
    pg.keyboard.press(key)


def test_pick_by_ids_rename_merge_and_undo_redo(page):
    upload(page, BRACKET)
    labels, elements = deck_numbers(BRACKET)
    vertex_of = {lab: i for i, lab in enumerate(labels)}
    assign_set(page, "FIXED", 1)
    fixed = region_ids(page, "FIXED")
    page.click("#sec-region-edit summary")
    # + fixed makes an empty fixed region; pick nodes 1-10 and 20 into it
    page.click("#add-fixed")
    page.fill("#pick-ids", "1-10, 20")
    page.click("#pick-apply")
    want = {i for i, lab in enumerate(labels) if in_ranges(lab, [(1, 10), (20, 20)])}
    assert len(want) == 11 and region_ids(page, "fixed2") == sorted(want)
    assert region_ids(page, "FIXED") == sorted(set(fixed) - want)  # a vertex is in one region at most
    assert "11 of 11 node ids found" in page.inner_text("#pick-note")
    # rename it
    page.fill("#region-name", "PICKED")
    page.click("#region-rename")
    assert "PICKED" in names(page) and "fixed2" not in names(page)
    # elements 137-140 and 150 (the deck's C3D4 numbers) into a handle: their corner nodes
    page.check("input[name=role][value='2']")
    page.fill("#pick-ids", "137-140 150")
    page.select_option("#pick-kind", "elements")
    page.click("#pick-apply")
    want_e = {vertex_of[n] for e, ns in elements.items() if in_ranges(e, [(137, 140), (150, 150)]) for n in ns}
    assert region_ids(page, "handle1") == sorted(want_e)
    picked, fixed_now = region_ids(page, "PICKED"), region_ids(page, "FIXED")
    assert picked == sorted(want - want_e) and fixed_now == sorted(set(fixed) - want - want_e)
    # merge PICKED into FIXED: one region holding both
    page.select_option("#merge-from", label="PICKED (fixed)")
    page.select_option("#merge-into", label="FIXED (fixed)")
    page.click("#region-merge")
    assert "PICKED" not in names(page)
    merged = region_ids(page, "FIXED")
    assert merged == sorted((set(fixed) | want) - want_e)
    # Ctrl+Z undoes the region edits one by one, back to the exact sets; Ctrl+Shift+Z and Ctrl+Y redo
    assert "merge PICKED into FIXED" in page.inner_text("#region-keys")
    body_keys(page, "Control+z")
    assert region_ids(page, "FIXED") == fixed_now and region_ids(page, "PICKED") == picked
    body_keys(page, "Control+z")  # the element pick
    assert region_ids(page, "handle1") is None and region_ids(page, "PICKED") == sorted(want)
    assert region_ids(page, "FIXED") == sorted(set(fixed) - want)
    body_keys(page, "Control+z")  # the rename
    assert region_ids(page, "fixed2") == sorted(want) and "PICKED" not in names(page)
    body_keys(page, "Control+Shift+z")
    assert region_ids(page, "PICKED") == sorted(want)
    body_keys(page, "Control+y")
    body_keys(page, "Control+y")
    assert region_ids(page, "FIXED") == merged and "PICKED" not in names(page)
    assert region_ids(page, "handle1") == sorted(want_e)
    # the panel's buttons do the same
    page.click("#region-undo")
    assert region_ids(page, "FIXED") == fixed_now and region_ids(page, "PICKED") == picked
    page.click("#region-redo")
    assert region_ids(page, "FIXED") == merged


def _flood(F: np.ndarray, V: np.ndarray, seed: int, angle: float) -> set[int]:
    """Boundary faces reached from ``seed`` across shared edges where the normal turns by less than ``angle``."""
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    around = defaultdict(list)
    for f, tri in enumerate(F.tolist()):
        for k in range(3):
            around[frozenset((tri[k], tri[(k + 1) % 3]))].append(f)
    cos, seen, stack = np.cos(np.radians(angle)), {seed}, [seed]
    while stack:
        f = stack.pop()
        tri = F[f].tolist()
        for k in range(3):
            for g in around[frozenset((tri[k], tri[(k + 1) % 3]))]:
                if g not in seen and N[f] @ N[g] > cos:
                    seen.add(g)
                    stack.append(g)
    return seen


def test_flood_fill_a_face_up_to_a_feature_angle(page):
    upload(page, BRACKET)
    mesh = read_mesh(BRACKET)
    F, V = mesh.F, mesh.V
    # a face of the x = 100 end, which faces the camera of the first view
    end = np.flatnonzero(np.all(np.abs(V[F][:, :, 0] - 100) < 1e-9, axis=1))
    c = V[F[end]].mean(axis=1)
    seed = int(end[np.argmin(np.linalg.norm(c - c.mean(0), axis=1))])
    page.check("input[name=tool][value='fill']")
    for angle, name in ((30, "fixed1"), (100, "fixed2")):
        page.fill("#fill-angle", str(angle))
        if angle == 100:
            page.click("#add-fixed")
        p = steady_point(page, V[F[seed]].mean(0))  # read once the tool's panel is laid out
        page.mouse.click(p["x"], p["y"])
        faces = _flood(F, V, seed, angle)
        want = sorted(set(F[sorted(faces)].ravel().tolist()))
        if angle == 30:
            # a flat end bounded by square edges: exactly its faces, every node on x = 100
            assert faces == set(end.tolist())
            assert want == sorted(set(F[end].ravel().tolist()))
            assert region_ids(page, name) == want
        else:  # across the square edges: more than the end, the end's nodes now in fixed2
            assert len(faces) > len(end)
            assert region_ids(page, name) == want
        assert page.get_attribute("#fill-note", "data-faces") == str(len(faces))
    # one step back: the 30° fill's region as it was
    body_keys(page, "Control+z")
    assert region_ids(page, "fixed1") == sorted(set(F[end].ravel().tolist()))


def _node_v(mesh) -> int:
    V = mesh.V
    return int(np.flatnonzero(np.abs(V[:, 0]) < 1e-9)[0])  # a node of the FIXED end (x = 0)


def test_conflicting_constraints_are_listed_by_node_and_framed(page):
    upload(page, BRACKET)
    mesh = read_mesh(BRACKET)
    labels, _ = deck_numbers(BRACKET)
    v = _node_v(mesh)
    assert v in mesh.sets["FIXED"].tolist()
    spec = {"selections": {"FIXED": {"set": "FIXED"}, "LOAD": {"set": "LOAD"}}, "fixed": ["FIXED"],
            "handles": {"LOAD": "LOAD"}, "points": [{"name": "pull", "vertices": [v],
                                                     "target": (mesh.V[v] + [0, 0, 1]).tolist()}]}
    use_spec(page, spec)
    create(page)
    page.wait_for_selector("#diag:not([hidden]) #diag-list li")
    items = page.locator("#diag-list li")
    assert items.count() == 1
    li = items.nth(0)
    assert li.get_attribute("data-node") == str(v) and li.get_attribute("data-status") == "conflicting"
    text = li.inner_text()
    assert f"node {labels[v]} (vertex {v})" in text and "FIXED" in text and "point pull" in text
    assert "residual 1" in text
    li.click()
    cam = page.evaluate("window.tetmorph.camera()")
    np.testing.assert_allclose(cam["target"], mesh.V[v], atol=1e-4)
    assert page.locator("#regions li.flagged").count() == 1
    assert "FIXED" in page.inner_text("#regions li.flagged")
    # the same SPEC refused ("conflicts": "reject"): the refusal's nodes, with the service's regions
    use_spec(page, {**spec, "conflicts": "reject"})
    page.click("#create")
    page.wait_for_function("window.tetmorph.error() && window.tetmorph.error().code === 'conflicting_constraints'")
    page.wait_for_selector("#diag-list li[data-node]")
    assert page.locator("#diag-list li").count() == 1
    text = page.inner_text("#diag-list li")
    assert f"vertex {v}" in text and "FIXED, point pull" in text and "residual 1" in text
    assert "refused" in page.inner_text("#diag-note")


def test_the_cyclic_faces_pairs_are_drawn_with_their_gap(page):
    deck = shared_file("tet/segmenttet.inp")  # *TIE, CYCLIC SYMMETRY of left, right; N=12 about x
    upload(page, deck)
    page.click("#sec-symmetry summary")
    page.wait_for_selector("#cyc-offers li button")
    page.locator("#cyc-offers li button").click()
    before = page.locator("#canvas").screenshot()
    page.check("#cyc-pairs")
    (drawn,) = page.evaluate("window.tetmorph.cyclicPairs()")
    (c,) = page.evaluate("window.tetmorph.spec()")["cyclic"]
    m = meshio.read(deck)
    A, B = m.points[m.point_sets[c["faces"][0]]], m.points[m.point_sets[c["faces"][1]]]
    a = np.radians(c["angle_deg"])
    R = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    gap = cKDTree(B).query(A @ R.T)[0]
    assert drawn["pairs"] == len(A)
    assert abs(drawn["max"] - gap.max()) < 1e-5 * max(1.0, gap.max())
    assert f"{len(A):,} pairs" in page.inner_text("#cyc-pairs-note")
    assert page.locator("#canvas").screenshot() != before  # drawn in the view


def test_region_keys_leave_a_move_undo_alone(page):
    """After a region edit then a move, Ctrl+Z undoes the move; the panel says so."""
    upload(page, BRACKET)
    assign_set(page, "FIXED", 1)
    assign_set(page, "LOAD", 2)
    create(page)
    numeric_move(page, t=(0, 0, 2))
    settle(page)
    assert "last move" in page.text_content("#region-keys")  # the section may be closed
    body_keys(page, "Control+z")
    page.wait_for_function("window.tetmorph.report() && window.tetmorph.report().reset === true")
    np.testing.assert_array_equal(positions(page), rest(page))
    assert region_ids(page, "LOAD") == sorted(page.evaluate("window.tetmorph.set('LOAD')"))
