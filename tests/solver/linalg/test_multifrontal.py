"""The multifrontal LU: its structure against an independent dense LU, its solutions, and what it refuses."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from solver import precompute
from solver.linalg import factorization as fz
from solver.linalg.multifrontal import PANEL, lu_multifrontal, symbolic
from solver.linalg.pardiso import PardisoFactor
from solver.linalg.supernodal import SupernodalFactor, Unsuitable
from tests.conftest import bend_spec, load


@pytest.fixture(scope="module")
def mean_value_system():
    """The interior mean-value matrix of the Armadillo tet mesh (4,151 free interior vertices)."""
    mesh = load("Armadillo13K.msh")
    return sp.csc_matrix(precompute(mesh, bend_spec(mesh)).data.positions.Mff)


def _grid_system(n: int, seed: int, symmetric_pattern: bool = True) -> sp.csc_matrix:
    """A 3D 7-point grid matrix with random off-diagonals, diagonally dominant by rows."""
    rng = np.random.default_rng(seed)
    m = n ** 3
    idx = np.arange(m).reshape(n, n, n)
    rows, cols = [], []
    for ax in range(3):
        a = np.take(idx, np.arange(n - 1), axis=ax).ravel()
        b = np.take(idx, np.arange(1, n), axis=ax).ravel()
        rows += [a, b] if symmetric_pattern else [a]
        cols += [b, a] if symmetric_pattern else [b]
    r, c = np.concatenate(rows), np.concatenate(cols)
    v = -rng.uniform(0.1, 1.0, r.size)
    A = sp.csr_matrix((v, (r, c)), shape=(m, m))
    d = np.asarray(abs(A).sum(axis=1)).ravel() + 1.0
    return sp.csc_matrix(A + sp.diags(d))


def test_structure_holds_every_entry_of_an_independent_dense_lu():
    A = _grid_system(7, 1)
    sym = symbolic(A)
    P = sym.perm
    L, U = _dense_lu_no_pivoting(A[P][:, P].toarray())
    n = A.shape[0]
    col_super = np.repeat(np.arange(sym.starts.size - 1), np.diff(sym.starts))
    allowed = np.zeros((n, n), bool)
    for s in range(sym.starts.size - 1):
        cols = np.arange(sym.starts[s], sym.starts[s + 1])
        rows = np.r_[cols, sym.R[sym.rstart[s]:sym.rstart[s + 1]]]
        allowed[np.ix_(rows, cols)] = True  # L's columns of the supernode
    assert np.all(allowed[np.abs(L) > 1e-14])  # every nonzero of L within the supernode patterns
    assert np.all(allowed.T[np.abs(U) > 1e-14])  # and of U within their transpose
    assert np.all(np.diff(col_super) >= 0) and sym.starts[-1] == n
    parent_ok = [(p == -1) or (p > s) for s, p in enumerate(sym.sparent)]
    assert all(parent_ok)  # postorder: parents after children


def _dense_lu_no_pivoting(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    M = M.copy()
    n = M.shape[0]
    for k in range(n):
        M[k + 1:, k] /= M[k, k]
        M[k + 1:, k + 1:] -= np.outer(M[k + 1:, k], M[k, k + 1:])
    return np.tril(M, -1) + np.eye(n), np.triu(M)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("symmetric_pattern", [True, False])
def test_double_precision_solves_match_scipy(threads, symmetric_pattern):
    A = _grid_system(14, 2, symmetric_pattern)  # 2,744 unknowns; fronts wider than one panel
    f = lu_multifrontal(A, threads=threads)
    assert isinstance(f, SupernodalFactor) and not f.single
    assert (np.diff(f._arrays[0]) + np.diff(f._arrays[1])).max() > PANEL
    b = np.random.default_rng(3).standard_normal((A.shape[0], 5))
    x = f.solve(b)
    ref = spla.spsolve(A, b)
    assert np.abs(x - ref).max() <= 1e-12 * np.abs(ref).max()


def test_single_precision_factor_is_close_and_half_the_size(mean_value_system):
    A = mean_value_system
    f, f64 = lu_multifrontal(A, single=True), lu_multifrontal(A)
    assert f.single and f._arrays[4].dtype == np.float32
    b = np.random.default_rng(4).standard_normal((A.shape[0], 3))
    ref = spla.spsolve(A, b)
    err = np.abs(f.solve(b) - ref).max() / np.abs(ref).max()
    assert 0.0 < err <= 1e-4
    assert np.abs(f64.solve(b) - ref).max() <= 1e-12 * np.abs(ref).max()
    assert f.nbytes < 0.6 * f64.nbytes


def test_two_threads_and_one_give_the_same_factor_to_round_off(mean_value_system):
    A = mean_value_system
    b = np.random.default_rng(5).standard_normal((A.shape[0], 3))
    x1, x2 = lu_multifrontal(A, threads=1).solve(b), lu_multifrontal(A, threads=2).solve(b)
    assert np.abs(x1 - x2).max() <= 1e-13 * np.abs(x1).max()


def test_a_zero_pivot_is_refused_and_lu_falls_back_to_pardiso(mean_value_system):
    swap = sp.csc_matrix([[0.0, 1.0], [1.0, 0.0]])  # a zero pivot in any order: only a row exchange solves it
    A = sp.csc_matrix(sp.block_diag([mean_value_system, swap, mean_value_system]))
    with pytest.raises(Unsuitable, match="pivot"):
        lu_multifrontal(A)
    f = fz.lu(A, "zero-pivot test system")
    assert isinstance(f, PardisoFactor)
    b = np.ones(A.shape[0])
    assert np.abs(A @ f.solve(b) - b).max() <= 1e-9


def test_growth_without_pivoting_is_caught_by_the_probe():
    n = 6000  # above LU_SMALL, so fz.lu would try it
    rng = np.random.default_rng(6)
    A = sp.lil_matrix(sp.identity(n) * 1.0)
    for i in range(0, n - 1, 2):  # 2x2 blocks [[eps, 1], [1, 1]]: a tiny pivot, huge growth
        A[i, i] = 1e-13 * (1 + rng.random())
        A[i, i + 1] = 1.0
        A[i + 1, i] = 1.0
    A = sp.csc_matrix(A)
    with pytest.raises(Unsuitable, match="probe"):
        lu_multifrontal(A)
    assert isinstance(fz.lu(A, "growth test"), PardisoFactor)


def test_the_interior_lu_of_a_mesh_is_the_multifrontal_factor(mean_value_system):
    A = sp.csc_matrix(sp.block_diag([mean_value_system, mean_value_system]))  # above LU_SMALL
    assert A.shape[0] > fz.LU_SMALL
    f = fz.lu(A, "interior", single=True)
    assert isinstance(f, SupernodalFactor) and f.single
    b = np.random.default_rng(8).standard_normal(A.shape[0])
    dense = sla.lu_factor(mean_value_system.toarray())  # A is two copies of it: solve each half densely
    n = mean_value_system.shape[0]
    ref = np.concatenate([sla.lu_solve(dense, b[:n]), sla.lu_solve(dense, b[n:])])
    assert np.abs(f.solve(b) - ref).max() <= 1e-4 * np.abs(ref).max()
