"""Bores of any orientation are holes: kiefer's bracket and gmsh parts with oblique and blended bores.

Every expected bore is measured in the test from the node coordinates: the
boundary nodes on the nominal cylinder are selected, and their circle is fitted
here (a linear least-squares fit in the plane orthogonal to the axis).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from solver import read_mesh
from solver.constraints.features import feature_candidates
from solver.mesh import mesh_from_arrays
from tests.gmsh_parts import _arrays, symmetric_bar

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
KIEFER = SHARED / "data" / "tet" / "kiefer_fea_bracket.vtu"

#: kiefer's bores, all along z: centre (x, y) and nominal radius (inches).
KIEFER_BORES = [((0.0, 0.0), 0.375), ((0.0, 0.0), 0.25), ((1.675, 0.0), 0.125), ((-1.675, 0.0), 0.125),
                ((0.0, 1.675), 0.125), ((0.0, -1.675), 0.125)]


def _circle(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float, float]:
    """Centre, radius and largest residual of the least-squares circle through (x, y)."""
    M = np.column_stack([2 * x, 2 * y, np.ones_like(x)])
    (a, b, c), *_ = np.linalg.lstsq(M, x ** 2 + y ** 2, rcond=None)
    r = float(np.sqrt(c + a * a + b * b))
    return float(a), float(b), r, float(np.abs(np.hypot(x - a, y - b) - r).max())


def _basis(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e1 = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(d, e1)


def _check_hole(mesh, hole, axis: np.ndarray, point: np.ndarray, ids: np.ndarray, rel: float) -> None:
    """``hole`` is the cylinder through the nodes ``ids`` about ``axis`` through ``point``, within ``rel``."""
    e1, e2 = _basis(axis)
    X = mesh.V[ids] - point
    a, b, r, worst = _circle(X @ e1, X @ e2)
    assert worst <= rel * r  # the nodes are on one cylinder about this axis
    assert hole.kind == "hole"
    assert abs(hole.params["radius"] - r) <= rel * r
    assert abs(abs(float(np.dot(hole.params["axis"], axis))) - 1.0) <= rel
    c = hole.params["center"] - (point + a * e1 + b * e2)  # on the measured axis
    assert np.linalg.norm(c - np.dot(c, axis) * axis) <= rel * r
    np.testing.assert_array_equal(hole.ids, ids)


@pytest.fixture(scope="module")
def kiefer():
    if not SHARED.is_dir():
        pytest.skip(f"{SHARED} (the shared test meshes beside the repository) is absent")
    mesh = read_mesh(KIEFER)
    return mesh, feature_candidates(mesh)


def test_every_bore_of_kiefer_is_a_hole(kiefer):
    mesh, cands = kiefer
    holes = [c for c in cands if c.kind == "hole"]
    B = np.flatnonzero(mesh.boundary)
    z = np.array([0.0, 0.0, 1.0])
    assert len(holes) == len(KIEFER_BORES) and not [c for c in cands if c.kind == "boss"]
    for (cx, cy), r0 in KIEFER_BORES:
        on = B[np.abs(np.hypot(mesh.V[B, 0] - cx, mesh.V[B, 1] - cy) - r0) < 1e-4]
        assert on.size >= 80
        hole = min(holes, key=lambda h: np.hypot(*(h.params["center"][:2] - (cx, cy))) + abs(h.params["radius"] - r0))
        # the file holds five significant digits: the nodes are on their cylinder to about 1e-4 of r
        _check_hole(mesh, hole, z, np.array([cx, cy, 0.0]), on, 5e-4)
    bore = next(h for h in holes if abs(h.params["radius"] - 0.25) < 1e-3)  # the top bore, blended by a fillet
    assert bore.ids.size == 190


def _block_with_bore(size: float, axis: np.ndarray, fillet: float | None) -> tuple[np.ndarray, np.ndarray]:
    """A 40 x 30 x 20 block with a bore of radius 4 along ``axis`` through its centre, its rims
    filleted with radius ``fillet`` (tangent to the bore: no sharp edge around it)."""
    gmsh = pytest.importorskip("gmsh")
    c0 = np.array([20.0, 15.0, 10.0])
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        box = occ.addBox(0, 0, 0, 40, 30, 20)
        cyl = occ.addCylinder(*(c0 - 30 * axis), *(60 * axis), 4.0)
        (vol,), _ = occ.cut([(3, box)], [(3, cyl)])
        occ.synchronize()
        if fillet is not None:
            rims = {abs(t) for dim, s in gmsh.model.getBoundary([vol], oriented=False)
                    if gmsh.model.getType(dim, s) == "Cylinder"
                    for _, t in gmsh.model.getBoundary([(dim, s)], oriented=False)
                    if gmsh.model.getType(1, abs(t)) != "Line"}
            occ.fillet([vol[1]], sorted(rims), [fillet])
            occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        return _arrays(gmsh)
    finally:
        gmsh.finalize()


OBLIQUE = np.array([1.0, 0.6, 2.0]) / np.linalg.norm([1.0, 0.6, 2.0])


@pytest.mark.parametrize("size, axis, fillet", [(2.0, OBLIQUE, 1.5), (3.0, OBLIQUE, 1.5), (2.0, OBLIQUE, None),
                                                (2.0, np.array([0.0, 0.0, 1.0]), 1.5)])
def test_bore_of_any_orientation_is_a_hole(size, axis, fillet):
    mesh = mesh_from_arrays(*_block_with_bore(size, axis, fillet))
    cands = feature_candidates(mesh)
    holes = [c for c in cands if c.kind == "hole"]
    assert len(holes) == 1 and not [c for c in cands if c.kind == "boss"]
    c0 = np.array([20.0, 15.0, 10.0])
    d = mesh.V - c0
    dist = np.linalg.norm(d - np.outer(d @ axis, axis), axis=1)
    on = np.flatnonzero(mesh.boundary & (np.abs(dist - 4.0) < 4e-5))
    _check_hole(mesh, holes[0], axis, c0, on, 1e-5)


def test_bolt_holes_of_the_symmetric_bar():
    pytest.importorskip("gmsh")
    mesh = mesh_from_arrays(*symmetric_bar())
    holes = [c for c in feature_candidates(mesh) if c.kind == "hole"]
    assert len(holes) == 2
    z = np.array([0.0, 0.0, 1.0])
    for x in (30.0, 70.0):
        on = np.flatnonzero(mesh.boundary & (np.abs(np.hypot(mesh.V[:, 0] - x, mesh.V[:, 1] - 10) - 5) < 5e-5))
        hole = min(holes, key=lambda h: abs(h.params["center"][0] - x))
        _check_hole(mesh, hole, z, np.array([x, 10.0, 0.0]), on, 1e-5)
