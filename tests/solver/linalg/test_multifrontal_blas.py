"""The multifrontal LU's fronts on SciPy's BLAS (the path without MKL), against the default BLAS and SuperLU."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from solver.linalg import multifrontal as mf


def _grid_system(n: int, seed: int) -> sp.csc_matrix:
    """A 3D 7-point grid matrix with random off-diagonals, diagonally dominant by rows."""
    rng = np.random.default_rng(seed)
    idx = np.arange(n ** 3).reshape(n, n, n)
    rows, cols = [], []
    for ax in range(3):
        a = np.take(idx, np.arange(n - 1), axis=ax).ravel()
        b = np.take(idx, np.arange(1, n), axis=ax).ravel()
        rows += [a, b]
        cols += [b, a]
    r, c = np.concatenate(rows), np.concatenate(cols)
    A = sp.csr_matrix((-rng.uniform(0.1, 1.0, r.size), (r, c)), shape=(n ** 3, n ** 3))
    return sp.csc_matrix(A + sp.diags(np.asarray(abs(A).sum(axis=1)).ravel() + 1.0))


@pytest.fixture(scope="module")
def system():
    A = _grid_system(14, 9)  # 2,744 unknowns: fronts wider than one panel
    b = np.random.default_rng(10).standard_normal((A.shape[0], 4))
    return A, b, mf.symbolic(A), spla.spsolve(A, b)


@pytest.fixture
def scipy_blas():
    mf._hand_over_blas(None)
    try:
        yield
    finally:
        mf._hand_over_blas(mf._MKL)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("single", [False, True])
def test_scipy_blas_factor_matches_the_default_one_and_superlu(system, single, threads):
    A, b, sym, ref = system
    x_default = mf.lu_multifrontal(A, single=single, sym=sym, threads=threads).solve(b)
    mf._hand_over_blas(None)
    try:
        f = mf.lu_multifrontal(A, single=single, sym=sym, threads=threads)
    finally:
        mf._hand_over_blas(mf._MKL)
    assert f.single == single
    x = f.solve(b)
    tol = 1e-4 if single else 1e-12
    assert np.abs(x - ref).max() <= tol * np.abs(ref).max()
    assert np.abs(x - x_default).max() <= (1e-5 if single else 1e-13) * np.abs(ref).max()


def test_a_zero_pivot_is_refused_on_scipy_blas(scipy_blas):
    A = sp.csc_matrix(sp.block_diag([_grid_system(6, 11), sp.csc_matrix([[0.0, 1.0], [1.0, 0.0]])]))
    with pytest.raises(mf.Unsuitable, match="pivot"):
        mf.lu_multifrontal(A)
