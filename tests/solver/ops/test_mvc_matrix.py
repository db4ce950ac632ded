"""Properties of the discrete operators: cotangent Laplacian, Voronoi areas, MVC."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from solver.ops.boundary_facets import boundary_facets
from solver.ops.mean_value_coordinates import mvc_triangle_weights
from solver.ops.mvc_matrix import mvc_matrix
from solver.testing import cube_mesh
from tests.conftest import load


@pytest.mark.parametrize("name", ["Armadillo13K.msh", "screw.msh", "wheelset.vtk", "cones_with_cavities.inp"])
def test_mvc_positive_partition_of_unity_reproduces_vertex(name):
    m = load(name)
    W, S = mvc_matrix(m.V, m.T, m.interior)
    I = np.flatnonzero(m.interior)
    assert I.size > 0
    Wi = W[I]
    assert Wi.data.min() > 0
    np.testing.assert_allclose(Wi.sum(axis=1).A.ravel(), 1.0, atol=1e-12)
    ext = np.linalg.norm(m.V.max(0) - m.V.min(0))
    assert np.abs(Wi @ m.V - m.V[I]).max() <= 1e-10 * ext
    assert np.all(S[I] > 0)


def test_mvc_near_face_case_gives_barycentric_weights():
    Q = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    x = np.array([[0.2, 0.3, 0.0]])
    w, on = mvc_triangle_weights(x, Q)
    assert on[0]
    np.testing.assert_allclose(w[0] / w[0].sum(), [0.5, 0.2, 0.3], atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.05, 0.95), st.floats(0.05, 0.95), st.floats(0.05, 0.95))
def test_mvc_reproduces_points_inside_a_cube(a, b, c):
    V, T = cube_mesh(1)
    F, _ = boundary_facets(T)
    x = np.array([a, b, c])
    w, on = mvc_triangle_weights(np.repeat(x[None], len(F), 0), V[F])
    tot = np.bincount(F.ravel(), w.ravel(), minlength=len(V))
    lam = tot / tot.sum()
    assert not on.any() and lam.min() > 0
    np.testing.assert_allclose(lam @ V, x, atol=1e-12)
