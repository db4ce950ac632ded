"""The site's pictures of real morphs draw what their pages say, checked on the arrays they are drawn from."""

from __future__ import annotations

import ast
import csv
import json
import math
import re
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest
from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "scripts"))
import pictures  # noqa: E402 - docs/scripts is not a package

STUDY = ROOT / "tests" / "solver" / "workflows" / "data"


def _actor(p, row: int, col: int, name: str):
    """The actor ``name`` of panel (row, col) of a pictures scene."""
    p.subplot(row, col)
    return p.renderer.actors[name]


def _mesh(p, row: int, col: int, name: str):
    return _actor(p, row, col, name).mapper.dataset


def _panel(pixels: np.ndarray, p, row: int, col: int) -> np.ndarray:
    """The pixels of panel (row, col): the renderer's viewport of the window."""
    h, w = pixels.shape[:2]
    p.subplot(row, col)
    x0, y0, x1, y1 = p.renderer.GetViewport()  # from the bottom left, in fractions of the window
    return pixels[round((1 - y1) * h):round((1 - y0) * h), round(x0 * w):round(x1 * w)]


def _near(pixels: np.ndarray, rgb, tol: int = 40) -> np.ndarray:
    return (np.abs(pixels.astype(int) - np.array(rgb)).max(axis=-1) < tol)


def test_every_picture_is_a_file_of_docs_img_linked_from_a_page():
    pages = "".join(f.read_text() for f in (ROOT / "docs").rglob("*.md"))
    for uri in pictures.PICTURES:
        path = ROOT / "docs" / uri
        assert path.read_bytes().startswith(b"\x89PNG"), uri
        assert f"../{uri})" in pages, uri


def _turn(deg: float) -> np.ndarray:
    t = math.radians(deg)
    return np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1]])


@pytest.fixture(scope="module")
def sector():
    return pictures.sector_morphs()


def test_the_sector_picture_solves_the_pages_cyclic_spec_and_moves(sector):
    page = (ROOT / "docs" / "tutorials" / "sector-symmetry.md").read_text()
    spec = ast.literal_eval(re.search(r"^cyclic_spec = (\{.*?^\})", page, re.S | re.M).group(1))
    grow = ast.literal_eval(re.search(r"^grow = (\{.*\})\s+#", page, re.M).group(1))
    loop = re.search(r"^for move in \(grow, (\{.*?\})\):", page, re.M)
    assert sector.spec == spec
    assert sector.moves == [grow, ast.literal_eval(loop.group(1))]
    radius = np.hypot(*sector.V0[:, :2].T)
    assert abs(radius.min() - 10) < 1e-6 and abs(radius.max() - 30) < 1e-6  # the page's sector: bore 10, rim 30


def test_the_morphed_sectors_stay_periodic_and_the_drawn_marks_meet(sector):
    R = _turn(sector.angle_deg)
    distance, pair = cKDTree(sector.V0[sector.B]).query(sector.V0[sector.A] @ R.T)
    assert distance.max() < 1e-9 and len(sector.A) > 20  # face B is face A turned, node for node
    for V in sector.V:
        assert np.linalg.norm(V - sector.V0, axis=1).max() > 0.5  # the rim did move
        assert np.abs(V[sector.B[pair]] - V[sector.A] @ R.T).max() < 1e-9
    p = pictures.sector_scene(sector)
    assert p.shape == (1, 1 + len(sector.moves))
    R_back = _turn(-sector.angle_deg)
    for i, V in enumerate([sector.V0, *sector.V]):
        dots, crosses = (_mesh(p, 0, i, n).points for n in ("face A", "face B"))
        np.testing.assert_allclose(dots, V[sector.A], atol=1e-12)  # face A of the drawn shape
        np.testing.assert_allclose(crosses, V[sector.B] @ R_back.T, atol=1e-12)  # face B of the neighbour
        gap, _ = cKDTree(crosses).query(dots)
        assert gap.max() < 1e-6  # every dot of face A has the neighbour's point of face B on it
        shown = _mesh(p, 0, i, "sector")
        np.testing.assert_allclose(shown.point_data["displacement"], np.linalg.norm(V - sector.V0, axis=1),
                                   atol=1e-12)
    pixels = pictures.render(p)
    p.close()
    assert _near(_panel(pixels, p, 0, 0), (255, 165, 0), 30).sum() > 50  # the orange dots are seen


def test_the_doe_picture_has_one_panel_per_row_of_the_pages_plan_on_one_scale():
    with open(STUDY / "plate_plan.csv") as f:
        header, *rows = list(csv.reader(f))
    values = np.array(rows, dtype=float)
    d = pictures.doe_variants()
    assert tuple(d.columns) == tuple(header) and np.array_equal(d.values, values)
    assert len(d.V) == len(rows)
    shapes = json.loads((STUDY / "plate_shapes.json").read_text())["shapes"]
    plate = meshio.read(ROOT / "tests" / "data" / "plate.inp")
    np.testing.assert_allclose(d.V0, plate.points, atol=0)
    hole1 = plate.point_sets["HOLE1"]
    for V, row in zip(d.V, values, strict=True):  # hole 1 moves by hole1_x times its shape's translation
        shift = row[header.index("hole1_x")] * np.array(shapes["hole1_x"]["handles"]["hole1"]["translation"])
        np.testing.assert_allclose(V[hole1] - plate.points[hole1], np.tile(shift, (len(hole1), 1)), atol=1e-9)
    assert np.abs(d.V[0] - plate.points).max() < 1e-9  # row 1 is all zeros: the rest shape
    p = pictures.doe_scene(d)
    per_row = p.shape[1] - 1  # the last column holds the colour bar
    largest = max(np.linalg.norm(V - plate.points, axis=1).max() for V in d.V)
    for i, (V, row) in enumerate(zip(d.V, values, strict=True)):
        actor = _actor(p, i // per_row, i % per_row, "variant")
        np.testing.assert_allclose(actor.mapper.dataset.points, V, atol=1e-12)
        lo, hi = actor.mapper.scalar_range  # one colour scale for every panel
        assert lo == 0 and abs(hi - largest) < 1e-9
        title = " ".join(_actor(p, i // per_row, i % per_row, "title").GetText(7).split())
        assert title.startswith(f"row {i + 1}:")
        for name, v in zip(header, row, strict=True):
            assert f"{name} {v:g}" in title
    assert len(p.scalar_bars) == 1
    p.close()


def _node_jacobians(V: np.ndarray, T10: np.ndarray) -> np.ndarray:
    """det dx/dxi of every tet10 at its ten nodes (corners 0..3, then edges 01, 12, 02, 03, 13, 23)."""
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
    L = np.vstack([np.eye(4), [[0.5 * (k in e) for k in range(4)] for e in edges]])  # barycentric nodes
    dL = np.array([[-1.0, -1, -1], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    out = np.empty((len(T10), 10))
    X = V[T10]
    for n in range(10):
        grad = [(4 * L[n, c] - 1) * dL[c] for c in range(4)]
        grad += [4 * (L[n, j] * dL[i] + L[n, i] * dL[j]) for i, j in edges]
        J = np.einsum("mka,kb->mab", X, np.array(grad))  # (m, 3 xyz, 3 xi)
        out[:, n] = np.linalg.det(J)
    return out


def test_the_inversion_picture_reddens_exactly_the_elements_with_a_non_positive_jacobian():
    page = (ROOT / "docs" / "guide" / "validity.md").read_text()
    shown = re.search(r"with the MOVE `(\{.*?\})`", page, re.S).group(1)
    assert json.loads(" ".join(shown.split())) == pictures.INVERSION_MOVE
    m = pictures.inversion_morphs()
    deck = meshio.read(ROOT / "tests" / "data" / "ccx_bracket.inp")
    T10 = deck.cells_dict["tetra10"]
    assert np.all(_node_jacobians(deck.points, T10) > 0)  # valid at rest
    bad = np.flatnonzero((_node_jacobians(m.V, T10) <= 0).any(axis=1))
    assert len(bad) > 10
    assert np.array_equal(np.sort(m.inverted), bad)
    assert not (_node_jacobians(m.V_clamped, T10) <= 0).any()  # clamped: none inverted
    assert np.linalg.norm(m.V_clamped - deck.points, axis=1).max() > 5  # ... and it did move
    p = pictures.inversion_scene(m)
    assert p.shape == (1, 2)
    red = _mesh(p, 0, 0, "inverted")
    assert np.array_equal(np.sort(red.cell_data["element"]), bad)  # red: exactly the non-positive Jacobians
    np.testing.assert_allclose(red.points, m.V, atol=0)
    assert red.n_cells == len(bad)
    assert "inverted" not in p.renderers[1].actors  # clamped: nothing red
    assert tuple(_actor(p, 0, 0, "inverted").prop.color)[:3] == pytest.approx(pictures.RED, abs=0.01)
    pixels = pictures.render(p)
    p.close()
    warn, clamp = (_panel(pixels, p, 0, c) for c in (0, 1))
    reddish = (np.array(pictures.RED) * 255).astype(int)
    assert _near(warn, reddish, 60).sum() > 200  # red is seen where it inverts ...
    assert _near(clamp, reddish, 60).sum() == 0  # ... and nowhere on the clamped shape


def test_the_bracket_picture_colours_the_morph_by_its_displacement():
    V0, V, F = pictures.bracket_morph()
    deck = meshio.read(ROOT / "tests" / "data" / "ccx_bracket.inp")
    np.testing.assert_allclose(V0, deck.points, atol=0)
    hole = deck.point_sets["HOLE"]
    np.testing.assert_allclose(V[hole] - V0[hole], np.tile([-4.0, 0, 0], (len(hole), 1)), atol=1e-9)
    fixed = np.concatenate([deck.point_sets["FIXED"], deck.point_sets["LOAD"]])
    assert np.abs(V[fixed] - V0[fixed]).max() < 1e-9
    p = pictures.displacement_scene(V0, V, F, "moved")
    rest, moved = _mesh(p, 0, 0, "rest"), _mesh(p, 0, 1, "moved")
    np.testing.assert_allclose(rest.points, V0, atol=0)
    np.testing.assert_allclose(moved.points, V, atol=0)
    np.testing.assert_allclose(moved.point_data["displacement"], np.linalg.norm(V - V0, axis=1), atol=1e-12)
    largest = np.linalg.norm(V - V0, axis=1).max()
    assert largest >= 4 and _actor(p, 0, 1, "moved").mapper.scalar_range == pytest.approx((0.0, largest), abs=1e-9)
    pixels = pictures.render(p)
    p.close()
    yellow = (253, 231, 37)  # viridis at 1: the bore, moved the most
    assert _near(_panel(pixels, p, 0, 1), yellow, 40).sum() > 100
    assert _near(_panel(pixels, p, 0, 0), yellow, 40).sum() == 0


def test_the_target_picture_puts_the_pages_top_face_on_its_scan():
    from scipy.interpolate import LinearNDInterpolator

    V0, V, F, scope = pictures.target_morph()
    deck = meshio.read(ROOT / "tests" / "data" / "plate.inp")
    np.testing.assert_allclose(V0, deck.points, atol=0)
    top = scope["top"]
    height = LinearNDInterpolator(scope["xy"], scope["z"])  # the scan the page wrote, as a height field
    assert np.abs(V[top, 2] - height(V[top, :2])).max() < 1e-9
    clamp = deck.point_sets["FIXED"]
    assert np.array_equal(V[clamp], V0[clamp])
    largest = np.linalg.norm(V - V0, axis=1).max()
    assert round(largest, 1) == 1.8  # "up to 1.8 mm above the design", as the page and the picture's alt say
    assert "up to 1.8 mm" in (ROOT / "docs" / "tutorials" / "target-surface.md").read_text()
    p = pictures.displacement_scene(V0, V, F, "on the scan")
    np.testing.assert_allclose(_mesh(p, 0, 1, "moved").points, V, atol=0)
    assert _actor(p, 0, 1, "moved").mapper.scalar_range == pytest.approx((0.0, largest), abs=1e-9)
    pixels = pictures.render(p)
    p.close()
    yellow = (253, 231, 37)  # viridis at 1: the top of the dome
    assert _near(_panel(pixels, p, 0, 1), yellow, 40).sum() > 100
    assert _near(_panel(pixels, p, 0, 0), yellow, 40).sum() == 0


def _draws_the_variants(p, d) -> None:
    """An edit scene ``p`` draws ``d``: the rest shape in panel (0, 0), each variant in its panel with its
    displacement on one colour range and its title; ``p`` is closed."""
    np.testing.assert_allclose(_mesh(p, 0, 0, "rest").points, d.V0, atol=0)
    largest = max(np.linalg.norm(V - d.V0, axis=1).max() for V in d.V)
    for k, (V, title) in enumerate(zip(d.V, d.titles, strict=True), start=1):
        actor = _actor(p, 0, k, "variant")
        np.testing.assert_allclose(actor.mapper.dataset.points, V, atol=1e-12)
        np.testing.assert_allclose(actor.mapper.dataset.point_data["displacement"],
                                   np.linalg.norm(V - d.V0, axis=1), atol=1e-12)
        assert actor.mapper.scalar_range == (0.0, largest)
        assert " ".join(_actor(p, 0, k, "title").GetText(7).split()) == title
    p.close()


def test_the_daily_edits_picture_draws_the_pages_edits_exactly():
    import edit_pictures

    d = edit_pictures.edit_variants()
    page = (ROOT / "docs" / "tutorials" / "alter-dimensions.md").read_text()
    assert "tests/data/make_ccx_bracket.py 4.0" in page and "img/tutorial-alter-dimensions.png" in page
    bore_nodes = np.flatnonzero(np.isclose(np.hypot(d.V0[:, 0] - 60, d.V0[:, 1] - 10), 5.0, atol=1e-6))
    bore, wall, twist = d.V
    np.testing.assert_allclose(np.hypot(bore[bore_nodes, 0] - 60, bore[bore_nodes, 1] - 10), 7.0, rtol=1e-12)
    back = np.abs(d.V0[:, 1] - 20) < 1e-6
    np.testing.assert_allclose(wall[back, 1], 22.0, rtol=1e-12)
    assert np.abs(wall[~back, 1]).max() < 22.0
    skin = np.unique(d.F)
    skin = skin[(d.V0[skin, 0] > 0.001) & (np.hypot(d.V0[skin, 1] - 10, d.V0[skin, 2] - 5) > 0)]
    turn = np.degrees(np.angle(np.exp(1j * (np.arctan2(twist[skin, 2] - 5, twist[skin, 1] - 10)
                                            - np.arctan2(d.V0[skin, 2] - 5, d.V0[skin, 1] - 10)))))
    np.testing.assert_allclose(turn, 0.1 * d.V0[skin, 0], atol=1e-9)
    _draws_the_variants(edit_pictures.edit_scene(d), d)


# ------------------------------------------------------------------------ the guide's daily edits, one per edit
def _signed_volumes(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    a, b, c, d = (V[T[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6.0


def _plane_normal(P: np.ndarray) -> np.ndarray:
    return np.linalg.svd(P - P.mean(axis=0))[2][2]


def _check_bracket_radius(V0, bore, small):
    on = np.flatnonzero(np.isclose(np.hypot(V0[:, 0] - 60, V0[:, 1] - 10), 5.0, atol=1e-6))
    for V, r in ((bore, 7.5), (small, 3.0)):
        np.testing.assert_allclose(np.hypot(V[on, 0] - 60, V[on, 1] - 10), r, rtol=1e-12)
        np.testing.assert_allclose(V[on, 2], V0[on, 2], atol=1e-12)  # heights kept


def _skin(V0, F):
    skin = np.unique(F)
    return skin[V0[skin, 0] > 0.001]


def _check_bracket_twist_bend(V0, F, twist, bend):
    skin = _skin(V0, F)
    skin = skin[np.hypot(V0[skin, 1] - 10, V0[skin, 2] - 5) > 0]
    turn = np.degrees(np.angle(np.exp(1j * (np.arctan2(twist[skin, 2] - 5, twist[skin, 1] - 10)
                                            - np.arctan2(V0[skin, 2] - 5, V0[skin, 1] - 10)))))
    np.testing.assert_allclose(turn, 0.6 * V0[skin, 0], atol=1e-9)
    kappa = math.radians(0.2)  # the axis on an arc of radius 1/kappa, each section rigid and normal to it
    theta, h = kappa * V0[skin, 0], V0[skin, 2] - 5
    np.testing.assert_allclose(bend[skin, 0], np.sin(theta) / kappa - h * np.sin(theta), atol=1e-9)
    np.testing.assert_allclose(bend[skin, 1], V0[skin, 1], atol=1e-9)
    np.testing.assert_allclose(bend[skin, 2], 5 + (1 - np.cos(theta)) / kappa + h * np.cos(theta), atol=1e-9)
    assert abs(math.degrees(kappa * 100) - 20) < 1e-12


def _check_bracket_map(V0, F, crown):
    skin = _skin(V0, F)
    top, bottom = skin[np.abs(V0[skin, 2] - 10) < 1e-6], skin[np.abs(V0[skin, 2]) < 1e-6]
    np.testing.assert_allclose(np.hypot(crown[top, 1] - 10, crown[top, 2] + 20), 30.0, rtol=1e-12)
    np.testing.assert_allclose(crown[top, 0], V0[top, 0], atol=1e-12)
    assert round(10 - crown[top, 2].min(), 1) == 1.5  # "the top's long edges drop by 1.5 mm"
    assert np.abs(crown[bottom, 2]).max() < 1e-9  # the bottom slides on its plane


def _check_bracket_offset(V0, wall):
    back = np.abs(V0[:, 1] - 20) < 1e-6
    np.testing.assert_allclose(wall[back, 1], 24.0, rtol=1e-12)
    assert np.abs(wall[np.abs(V0[:, 1]) < 1e-6, 1]).max() < 1e-9  # the front face slides on its plane
    on = np.flatnonzero(np.isclose(np.hypot(V0[:, 0] - 60, V0[:, 1] - 10), 5.0, atol=1e-6))
    np.testing.assert_allclose(np.hypot(wall[on, 0] - 60, wall[on, 1] - 10), 5.0, rtol=1e-12)


def _check_bracket_lattice(V0, F, lifted):
    skin = np.unique(F)
    inside = skin[V0[skin, 0] >= 70]
    u = (V0[inside, 0] - 70) / 31  # Bernstein of degree 2 in x, every (j, k) of the last layer raised 8
    np.testing.assert_allclose(lifted[inside] - V0[inside], np.column_stack([0 * u, 0 * u, 8 * u ** 2]), atol=1e-9)
    assert round(float(np.abs(lifted - V0).max()), 1) == 7.5  # "the end curls up by 7.5 mm"


def _check_l_fillet(V0, big, small):
    arc = np.flatnonzero(np.isclose(np.hypot(V0[:, 0] - 11, V0[:, 1] - 11), 5.0, atol=1e-6)
                         & (V0[:, 0] < 11 - 1e-6) & (V0[:, 1] < 11 - 1e-6))
    assert len(arc) > 10
    frac0 = np.arctan2(11 - V0[arc, 0], 11 - V0[arc, 1])
    h = (np.abs(V0[:, 1] - 6) < 1e-9) & (V0[:, 0] > 11 - 1e-9)  # the flange's and the web's inner faces
    v = (np.abs(V0[:, 0] - 6) < 1e-9) & (V0[:, 1] > 11 - 1e-9)
    for V, r in ((big, 10.0), (small, 2.5)):
        c = 6 + r  # the new axis, at r from both inner faces
        np.testing.assert_allclose(np.hypot(V[arc, 0] - c, V[arc, 1] - c), r, rtol=1e-12)
        np.testing.assert_allclose(np.arctan2(c - V[arc, 0], c - V[arc, 1]), frac0, atol=1e-9)  # same place on it
        assert np.abs(V[h, 1] - 6).max() < 1e-9 and np.abs(V[v, 0] - 6).max() < 1e-9  # the faces stay flat


def _check_l_distance_angle(V0, moved, turned):
    bore = np.isclose(np.hypot(V0[:, 1] - 35, V0[:, 2] - 10), 3.0, atol=1e-6) & (V0[:, 0] < 6 + 1e-9)
    top, end = np.abs(V0[:, 1] - 50) < 1e-9, np.abs(V0[:, 0] - 60) < 1e-9
    assert abs(np.linalg.norm(V0[bore].mean(0) - V0[top].mean(0)) - 15.0) < 0.1
    assert np.linalg.norm(moved[bore].mean(0) - moved[top].mean(0)) == pytest.approx(10.0, abs=1e-9)
    shift = moved[bore] - V0[bore]
    assert np.abs(shift - shift[0]).max() < 1e-12 and shift[0, 1] > 4.9  # rigidly, toward the top
    a, b = _plane_normal(turned[top]), _plane_normal(turned[end])
    a, b = a * np.sign(a[1]), b * np.sign(b[0])  # outward: the top's +y, the end's +x
    assert math.degrees(math.acos(float(a @ b))) == pytest.approx(105.0, abs=1e-9)
    assert np.array_equal(turned[end], V0[end])
    assert turned[top, 0].mean() < V0[top, 0].mean() - 5  # about the fillet's axis: the web leans back


GUIDE_CHECKS = {"img/guide-edit-radius.png": ("Radius of a bore", lambda d: _check_bracket_radius(d.V0, *d.V)),
                "img/guide-edit-twist-bend.png": ("Twist and bend",
                                                  lambda d: _check_bracket_twist_bend(d.V0, d.F, *d.V)),
                "img/guide-edit-map.png": ("Map onto", lambda d: _check_bracket_map(d.V0, d.F, *d.V)),
                "img/guide-edit-offset.png": ("Offset of a face set", lambda d: _check_bracket_offset(d.V0, *d.V)),
                "img/guide-edit-lattice.png": ("Morph volume", lambda d: _check_bracket_lattice(d.V0, d.F, *d.V)),
                "img/guide-edit-fillet.png": ("Fillet radius", lambda d: _check_l_fillet(d.V0, *d.V)),
                "img/guide-edit-distance-angle.png": ("Distance and angle",
                                                      lambda d: _check_l_distance_angle(d.V0, *d.V))}


@pytest.mark.parametrize("uri", list(GUIDE_CHECKS))
def test_each_daily_edit_of_the_guide_is_pictured_from_its_solved_edit(uri):
    import daily_edit_pictures

    assert set(GUIDE_CHECKS) == set(daily_edit_pictures.GUIDE_EDITS)
    heading, check = GUIDE_CHECKS[uri]
    page = (ROOT / "docs" / "guide" / "constraints.md").read_text()
    section = re.search(rf"^### {heading}.*?(?=^#)", page, re.S | re.M).group(0)
    assert f"](../{uri})" in section  # the picture sits in its edit's own subsection
    assert pictures.PICTURES[uri] is daily_edit_pictures.GUIDE_PNGS[uri]
    d = daily_edit_pictures.guide_edit(uri)
    check(d)
    for V in d.V:  # no element inverted, nor flattened, measured here
        if d.T10 is None:
            assert _signed_volumes(V, d.T).min() > 0.05 * _signed_volumes(d.V0, d.T).min()
        else:
            assert _node_jacobians(V, d.T10).min() > 0
        assert np.linalg.norm(V - d.V0, axis=1).max() > 1.0  # large enough to see
    _draws_the_variants(daily_edit_pictures.guide_edit_scene(d), d)
