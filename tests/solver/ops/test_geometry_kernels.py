"""The compiled geometry kernels (src/core/geometry.cpp) against plain numpy / scipy computations."""
from __future__ import annotations

import threading

import numpy as np
import pytest
import tetmorph_core
from scipy.spatial.transform import Rotation

from solver.ops.boundary_facets import boundary_facets
from solver.ops.closest_point import TriangleSurface, closest_points
from solver.ops.displacement import displacement_maxima
from solver.ops.elements import corner_jacobians
from solver.ops.mean_value_coordinates import MVC_EPS, mvc_pair, mvc_triangle_weights
from solver.ops.mvc_matrix import mvc_matrix
from solver.ops.rotation import rotate_by_log
from solver.testing import cube_mesh


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip(np.einsum("...j,...j->...", p - a, ab) / np.einsum("...j,...j->...", ab, ab), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def _triangle_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Exact point-triangle distances (p (q, 1, 3) against triangles (1, k, 3)): plane or nearest edge."""
    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    h = np.einsum("...j,...j->...", p - a, n)
    x = p - h[..., None] * n
    inside = np.ones(h.shape, bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("...j,...j->...", np.cross(v - u, x - u), n) >= 0
    edges = np.minimum(np.minimum(_segment_distance(p, a, b), _segment_distance(p, b, c)),
                       _segment_distance(p, c, a))
    return np.where(inside, np.abs(h), edges)


def _surface() -> tuple[np.ndarray, np.ndarray]:
    V, T = cube_mesh(3)
    V = V + np.random.default_rng(3).uniform(-0.04, 0.04, V.shape)
    F, _ = boundary_facets(T)
    return V, np.asarray(F, np.int64)


def test_closest_points_match_an_exhaustive_search():
    V, F = _surface()
    Q = np.random.default_rng(0).uniform(-0.5, 1.5, (400, 3))
    q = len(Q)
    tri, bary, dist = np.full(q, -1, np.int64), np.zeros((q, 3)), np.full(q, np.inf)
    every = np.tile(np.arange(len(F), dtype=np.int64), q)  # every triangle a candidate of every point
    ptr = np.arange(q + 1, dtype=np.int64) * len(F)
    tetmorph_core.geometry_closest_best(Q, V, F, ptr, every, tri, bary, dist)
    exact = _triangle_distance(Q[:, None], V[F[:, 0]][None], V[F[:, 1]][None], V[F[:, 2]][None]).min(axis=1)
    np.testing.assert_allclose(dist, exact, rtol=0, atol=1e-12)
    assert bary.min() >= 0 and np.allclose(bary.sum(axis=1), 1.0)
    pts = np.einsum("qi,qij->qj", bary, V[F[tri]])
    np.testing.assert_allclose(np.linalg.norm(pts - Q, axis=1), dist, atol=1e-12)
    r = closest_points(V, F, Q)  # the KD-tree candidates find the same distances here
    np.testing.assert_allclose(r.dist, exact, atol=1e-12)


def test_rays_along_normals_hit_at_the_height_and_parallel_rays_miss():
    V, F = _surface()
    surf = TriangleSurface(V, F)
    rng = np.random.default_rng(1)
    t = rng.integers(0, len(F), 200)
    b = rng.dirichlet([4, 4, 4], len(t))
    P = V[F[t]]
    foot = np.einsum("qi,qij->qj", b, P)
    n = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    X0 = foot + 0.01 * n
    r = surf.along(X0, n)
    assert (r.tri >= 0).all()
    np.testing.assert_allclose(r.points, foot, atol=1e-12)
    np.testing.assert_allclose(r.dist, 0.01, atol=1e-12)
    far = np.full((3, 3), 10.0)  # away from the cube, along an axis that misses it
    miss = surf.along(far, np.tile([1.0, 0, 0], (3, 1)))
    assert (miss.tri == -1).all() and np.isinf(miss.dist).all()
    np.testing.assert_array_equal(miss.points, far)


def test_rotate_by_log_matches_scipy_rotations():
    rng = np.random.default_rng(2)
    v, r, s = rng.normal(size=(500, 3)), rng.normal(size=(500, 3)), rng.uniform(0.5, 2.0, 500)
    r[:5] = 0.0
    want = Rotation.from_rotvec(2.0 * r).apply(v)
    np.testing.assert_allclose(rotate_by_log(v, r), want, atol=1e-12)
    np.testing.assert_allclose(rotate_by_log(v, r, s), want * s[:, None], atol=1e-12)
    with pytest.raises(ValueError):
        rotate_by_log(v, r, s[:-1])


def test_displacement_maxima_match_numpy():
    rng = np.random.default_rng(4)
    V = rng.normal(size=(20000, 3))
    P = V + rng.normal(size=V.shape)
    owner = rng.integers(-2, 3, len(V))
    d = np.linalg.norm(P - V, axis=1)
    assert displacement_maxima(P, V, owner) == (d.max(), d[owner >= 0].max(), d[owner == -1].max(), True)
    P[123, 1] = np.inf
    overall, _, _, finite = displacement_maxima(P, V, owner)
    assert np.isnan(overall) and not finite


def test_corner_jacobians_of_a_sheared_hexahedron():
    X = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]])
    X[4:, 0] += 0.5  # shear: every corner Jacobian still 1, each vertical edge sqrt(1.25) long
    det, sj = corner_jacobians(X, np.arange(8)[None], "hexahedron")
    np.testing.assert_allclose([det[0], sj[0]], [1.0, 1.0 / np.sqrt(1.25)], atol=1e-15)
    det, sj = corner_jacobians(X, np.array([[0, 3, 2, 1, 4, 7, 6, 5]]), "hexahedron")  # mirrored: inverted
    np.testing.assert_allclose([det[0], sj[0]], [-1.0, -1.0 / np.sqrt(1.25)], atol=1e-15)


def test_mvc_pair_is_the_one_pair_form_of_the_batch_kernel():
    rng = np.random.default_rng(5)
    x, Q = rng.normal(size=(50, 3)), rng.normal(size=(50, 3, 3))
    x[0] = Q[0, 2]  # at a corner
    x[1] = Q[1].mean(axis=0)  # on the face
    W, on = mvc_triangle_weights(x, Q)
    w = np.empty(3)
    for k in range(len(x)):
        assert mvc_pair(x[k], Q[k, 0], Q[k, 1], Q[k, 2], MVC_EPS, w, np.empty((8, 3))) == on[k]
        np.testing.assert_array_equal(w, W[k])
    assert on[0] and on[1] and W[0].tolist() == [0.0, 0.0, 1.0]


def test_kernels_agree_across_thread_counts_and_concurrent_callers():
    V, T = cube_mesh(6)
    V = V + np.random.default_rng(6).uniform(-0.02, 0.02, V.shape)
    F, _ = boundary_facets(T)
    interior = np.ones(len(V), bool)
    interior[F.ravel()] = False
    before = tetmorph_core.get_num_threads()
    try:
        tetmorph_core.set_num_threads(1)
        W1, S1 = mvc_matrix(V, T, interior)
        tetmorph_core.set_num_threads(2)
        W2, S2 = mvc_matrix(V, T, interior)
    finally:
        tetmorph_core.set_num_threads(before)
    assert (W1 != W2).nnz == 0 and np.array_equal(S1, S2)
    out: list = [None] * 4

    def run(i: int) -> None:
        out[i] = mvc_matrix(V, T, interior)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all((r[0] != W1).nnz == 0 and np.array_equal(r[1], S1) for r in out)


def test_outputs_of_the_wrong_dtype_are_refused_not_copied():
    x, Q = np.zeros((2, 3)), np.ones((2, 3, 3))
    with pytest.raises(TypeError):
        tetmorph_core.geometry_mvc_weights(x, Q, MVC_EPS, np.empty((2, 3), np.float32), np.empty(2, np.bool_))
