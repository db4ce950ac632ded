"""A mesh with a flat tet at rest loads and morphs; the flat tet is reported apart, not as inverted."""

from __future__ import annotations

import numpy as np

from solver import mesh_from_arrays, precompute, read_mesh
from tests.conftest import DATA, bend_move, bend_spec
from tests.solver.mesh.test_validate import _flat_on_face


def test_a_flat_tet_at_rest_is_listed_and_not_counted_as_inverted():
    plate = read_mesh(DATA / "plate.inp")
    V, T = _flat_on_face(plate)
    m = mesh_from_arrays(V, T)
    flat = len(T) - 1
    r = precompute(m, bend_spec(m)).solve(bend_move(m, angle=10.0, frac=0.02))
    P = r.V[T]
    vol = np.einsum("ij,ij->i", P[:, 1] - P[:, 0], np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]))
    others = np.delete(vol, flat)
    assert (others > 0).all()  # independent: nothing else inverted either
    assert r.report["inverted_elements"] == 0
    assert r.report["degenerate_at_rest"] == {"count": 1, "ids": [flat]}
