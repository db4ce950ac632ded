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


def _panels(fig) -> list:
    return [ax for ax in fig.axes if ax.name == "3d"]


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
    fig = pictures.sector_figure(sector)
    panels = _panels(fig)
    assert len(panels) == 1 + len(sector.moves)
    for ax, V in zip(panels, [sector.V0, *sector.V], strict=True):
        dots, crosses = (np.column_stack(c._offsets3d) for c in ax.collections[1:3])
        np.testing.assert_allclose(dots, V[sector.A], atol=0)  # face A of the drawn shape
        gap, _ = cKDTree(crosses).query(dots)
        assert gap.max() < 1e-9  # every dot of face A has the neighbour's cross of face B on it


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
    fig = pictures.doe_figure(d)
    panels = _panels(fig)
    assert len(panels) == len(rows)
    for i, (ax, row) in enumerate(zip(panels, values, strict=True)):
        title = " ".join(ax.get_title().split())
        assert title.startswith(f"row {i + 1}:")
        for name, v in zip(header, row, strict=True):
            assert f"{name} {v:g}" in title
    bars = [ax for ax in fig.axes if ax.name != "3d"]
    assert len(bars) == 1  # one colour scale for every panel
    largest = max(np.linalg.norm(V - plate.points, axis=1).max() for V in d.V)
    lo, hi = bars[0].get_ylim()  # a vertical colour bar spans its scale
    assert lo == 0 and abs(hi - largest) < 1e-9


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
    fig = pictures.inversion_figure(m)
    panels = _panels(fig)
    assert len(panels) == 2
    for ax, n in zip(panels, (len(bad), 0), strict=True):
        rgba = ax.collections[0].get_facecolor()
        red = (rgba[:, 0] > 0.3) & (rgba[:, 1] < 0.1) & (rgba[:, 3] == 1)
        assert red.sum() == 4 * n  # the four faces of every inverted element, and nothing else
