"""Properties of the discrete operators: cotangent Laplacian, Voronoi areas, MVC."""
from __future__ import annotations

import numpy as np
import pytest

from solver.ops.boundary_facets import boundary_facets
from solver.testing import cube_mesh


def test_boundary_facets_of_cube_grid():
    V, T = cube_mesh(3)
    F, FT = boundary_facets(T)
    assert len(F) == 6 * 9 * 2
    # outward: signed volume of the closed surface equals the box volume
    P = V[F]
    vol = np.einsum("ij,ij->i", P[:, 0], np.cross(P[:, 1], P[:, 2])).sum() / 6
    assert vol == pytest.approx(1.0)
