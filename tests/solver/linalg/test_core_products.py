"""The compiled residual, layout and product kernels against plain numpy/scipy, for every dtype they take."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from solver.linalg.layout import c_copy, fortran_copy
from solver.linalg.products import gradient, product, shifted_product, stacked_differences
from solver.linalg.residual import block_residual, corrected, coupled_residual_norms


def _matrix(n: int, c: int, rng, index=np.int32) -> sp.csr_matrix:
    M = sp.random(n, c, density=6.0 / c, random_state=np.random.RandomState(0), format="csr") + sp.eye(n, c)
    M = sp.csr_matrix(M)
    M.indptr, M.indices = M.indptr.astype(index), M.indices.astype(index)
    return M


def _norms(R: np.ndarray, X: np.ndarray, width: int) -> tuple[np.ndarray, np.ndarray]:
    b = R.shape[1] // width
    r = np.sqrt((R.reshape(len(R), b, width) ** 2).sum(axis=2).max(axis=0))
    x = np.sqrt((X.astype(np.float64).reshape(len(X), b, width) ** 2).sum(axis=2).max(axis=0))
    return r, x


@pytest.mark.parametrize("index", [np.int32, np.int64])
@pytest.mark.parametrize("m", [3, 12])
@pytest.mark.parametrize("single", [False, True])
def test_block_residual_matches_numpy(index, m, single):
    rng = np.random.default_rng(3)
    A = _matrix(500, 500, rng, index)
    X = rng.standard_normal((500, m))
    if single:
        X = X.astype(np.float32)
    B = A @ X.astype(np.float64) + rng.standard_normal((500, m))
    ref = B - A @ X.astype(np.float64)
    r_ref, x_ref = _norms(ref, X, 3)
    R, r, x = block_residual(A, B, X, 3)
    assert R is not None and np.abs(R - ref).max() <= 1e-13 * np.abs(ref).max()
    assert np.allclose(r, r_ref, rtol=1e-13) and np.allclose(x, x_ref, rtol=1e-6 if single else 1e-13)
    none, r2, x2 = block_residual(A, B, X, 3, store=False)
    assert none is None and np.array_equal(r, r2) and np.array_equal(x, x2)


@pytest.mark.parametrize("index", [np.int32, np.int64])
def test_coupled_norms_with_mixed_index_types(index):
    rng = np.random.default_rng(4)
    A, M = _matrix(300, 300, rng, index), _matrix(300, 80, rng, np.int64 if index == np.int32 else np.int32)
    D = rng.standard_normal((80, 6))
    r0 = rng.standard_normal((300, 3))
    X = rng.standard_normal((300, 6)).astype(np.float32)
    B = M @ D + np.tile(r0, (1, 2))
    r_ref, x_ref = _norms(B - A @ X.astype(np.float64), X, 3)
    r, x = coupled_residual_norms(A, M, r0, D, X, 3)
    assert np.allclose(r, r_ref, rtol=1e-12) and np.allclose(x, x_ref, rtol=1e-6)  # X squared in float32


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("w", [3, 2])
def test_corrected_subtracts_in_the_rows(dtype, w):
    rng = np.random.default_rng(5)
    P = rng.standard_normal((50, w))
    rows = rng.choice(50, 20, replace=False)
    X = rng.standard_normal((20, 3 * w)).astype(dtype)
    ref = P.copy()
    ref[rows] -= X[:, w:2 * w].astype(np.float64)
    assert np.array_equal(corrected(P, rows, X, w), ref)
    Q = P.copy()
    assert corrected(Q, rows, X, w, overwrite=True) is Q and np.array_equal(Q, ref)


@pytest.mark.parametrize("src", [np.float32, np.float64])
@pytest.mark.parametrize("dst", [np.float32, np.float64])
def test_tiled_copies_of_every_float_pair(src, dst):
    b = np.random.default_rng(6).standard_normal((1000, 7)).astype(src)
    f = fortran_copy(b, dst)
    assert f.flags.f_contiguous and f.dtype == dst and np.array_equal(f, b.astype(dst))
    c = c_copy(f, dst)
    assert c.flags.c_contiguous and c.dtype == dst and np.array_equal(c, f)
    ints = fortran_copy(np.arange(12).reshape(4, 3), dst)  # other dtypes: numpy's copy
    assert ints.flags.f_contiguous and np.array_equal(ints, np.arange(12).reshape(4, 3))


def test_products_take_int64_indices_and_agree_with_scipy():
    rng = np.random.default_rng(7)
    M32 = _matrix(200, 90, rng)
    M64 = _matrix(200, 90, rng, np.int64)
    X = rng.standard_normal((90, 3))
    for M in (M32, M64):
        assert np.abs(product(M, X) - M32 @ X).max() <= 1e-14 * np.abs(M32 @ X).max()
    A32, A64 = _matrix(120, 90, rng), _matrix(120, 90, rng, np.int64)
    c, x = rng.standard_normal((120, 3)), rng.standard_normal((90, 3))
    assert np.array_equal(gradient(A32, sp.csr_matrix(A32.T), c, x), gradient(A64, sp.csr_matrix(A64.T), c, x))
    P, cols = rng.standard_normal((150, 3)), rng.choice(150, 90, replace=False)
    rest, r0 = rng.standard_normal((90, 3)), rng.standard_normal((200, 3))
    ref = M32 @ (P[cols] - rest) + r0
    assert np.abs(shifted_product(M64, cols, P, rest, r0) - ref).max() <= 1e-14 * np.abs(ref).max()
    D = stacked_differences([P, P[:, ::-1]], cols, rest[:, :3], order="F")
    assert np.array_equal(D, np.hstack([P[cols] - rest, P[cols][:, ::-1] - rest]))
