"""The compiled tet kernels: tet_quality and the element check round alike, for every index type."""

from __future__ import annotations

import numpy as np

from solver.testing import cube_mesh
from solver.validity.check import tet_check
from solver.validity.quality import scaled_jacobians, tet_quality


def test_tet_quality_and_the_check_agree_bit_for_bit():
    rng = np.random.default_rng(8)
    V, T = cube_mesh(8)
    V = V + rng.normal(0.0, 0.04, V.shape)
    vol6, sj = tet_quality(V, T.astype(np.int64))
    vol6_32, sj_32 = tet_quality(V, T.astype(np.int32))
    assert np.array_equal(vol6, vol6_32) and np.array_equal(sj, sj_32)
    assert np.array_equal(tet_check(V, T).sj, sj)
    P = V[T]
    det = np.einsum("ij,ij->i", P[:, 1] - P[:, 0], np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]))
    assert np.allclose(vol6, det, rtol=1e-12, atol=1e-15)
    assert np.abs(sj).max() <= 1.0 and np.array_equal(np.sign(sj), np.sign(det))
    assert np.array_equal(scaled_jacobians(V, T.astype(np.uint16)), sj)  # other index types are widened
