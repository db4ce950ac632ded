"""The supernodal LU back-substitution: solutions against scipy's, its supernodes, and the fallback to PARDISO."""

from __future__ import annotations

import threading

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from solver import SolveOptions, precompute
from solver.linalg import factorization as fz
from solver.linalg.pardiso import PardisoFactor, nested_dissection
from solver.linalg.supernodal import SupernodalFactor, Unsuitable, lu_supernodal
from tests.conftest import bend_move, bend_spec, load


@pytest.fixture(scope="module")
def mean_value_system():
    """The interior mean-value matrix of the Armadillo tet mesh (4,151 free interior vertices)."""
    mesh = load("Armadillo13K.msh")
    pos = precompute(mesh, bend_spec(mesh)).data.positions
    return sp.csc_matrix(pos.Mff)


@pytest.mark.parametrize("k", [1, 2, 3, 5, 9, 10, 48])
def test_double_precision_solve_matches_scipy(mean_value_system, k):
    A = mean_value_system
    f = lu_supernodal(A)
    b = np.random.default_rng(k).standard_normal((A.shape[0], k))
    x = f.solve(b)
    ref = spla.spsolve(A, b).reshape(b.shape)
    assert x.shape == b.shape and x.dtype == np.float64
    assert np.abs(x - ref).max() <= 1e-12 * np.abs(ref).max()
    assert np.abs(A @ x - b).max() <= 1e-12 * np.abs(b).max()


def test_vector_right_hand_side_keeps_its_shape(mean_value_system):
    A = mean_value_system
    b = np.arange(A.shape[0], dtype=float)
    x = lu_supernodal(A).solve(b)
    assert x.shape == b.shape
    assert np.abs(A @ x - b).max() <= 1e-12 * np.abs(b).max()


def test_single_precision_solve_is_within_float32_accuracy(mean_value_system):
    A = mean_value_system
    f = lu_supernodal(A, single=True)
    b = np.random.default_rng(3).standard_normal((A.shape[0], 3))
    x = f.solve(b)
    ref = spla.spsolve(A, b)
    err = np.abs(x - ref).max() / np.abs(ref).max()
    assert 0.0 < err <= 1e-5  # not exact (float32 blocks), but close
    assert f.nbytes < lu_supernodal(A).nbytes


def test_supernodes_hold_the_factor_pattern(mean_value_system):
    """Every supernode's columns share one pattern below the block, and the blocks hold every factor entry."""
    A = mean_value_system
    perm = nested_dissection(A)
    lu = spla.splu(sp.csc_matrix(A[perm][:, perm]), permc_spec="NATURAL", diag_pivot_thresh=0.0,
                   options={"SymmetricMode": True})
    f = SupernodalFactor(lu.L, lu.U, perm)
    starts = f._arrays[0]
    L = sp.csc_matrix(lu.L)
    for s in range(starts.size - 1):
        c0, c1 = starts[s], starts[s + 1]
        below = [set(L.indices[L.indptr[c]:L.indptr[c + 1]][L.indices[L.indptr[c]:L.indptr[c + 1]] >= c1])
                 for c in range(c0, c1)]
        assert all(b == below[0] for b in below)
    # the blocks reproduce L U: one solve equals SuperLU's own
    b = np.random.default_rng(1).standard_normal((A.shape[0], 3))
    y = np.empty_like(b)
    y[perm] = lu.solve(b[perm])
    assert np.abs(f.solve(b) - y).max() <= 1e-12 * np.abs(y).max()
    assert f.supernodes < A.shape[0]


def test_concurrent_solves_on_one_factor_agree(mean_value_system):
    A = mean_value_system
    f = lu_supernodal(A)
    bs = [np.random.default_rng(j).standard_normal((A.shape[0], 3)) for j in range(4)]
    want = [f.solve(b) for b in bs]
    got: list[np.ndarray | None] = [None] * 4

    def run(j: int) -> None:
        for _ in range(5):
            got[j] = f.solve(bs[j])

    threads = [threading.Thread(target=run, args=(j,)) for j in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for w, g in zip(want, got, strict=True):
        assert g is not None and np.array_equal(w, g)


def _zero_pivot_system(A: sp.csc_matrix) -> sp.csc_matrix:
    """Two copies of ``A`` (above ``LU_SMALL`` unknowns) around a 2x2 swap: a zero pivot in any order."""
    swap = sp.csc_matrix([[0.0, 1.0], [1.0, 0.0]])
    return sp.csc_matrix(sp.block_diag([A, swap, A]))


def test_a_system_that_needs_pivoting_is_refused_and_goes_to_pardiso(mean_value_system):
    B = _zero_pivot_system(mean_value_system)
    assert B.shape[0] > fz.LU_SMALL
    with pytest.raises(Unsuitable):
        lu_supernodal(B)
    f = fz.lu(B, "zero-pivot test system")
    assert isinstance(f, PardisoFactor)
    b = np.random.default_rng(5).standard_normal((B.shape[0], 3))
    x = f.solve(b)
    assert np.abs(B @ x - b).max() <= 1e-9 * np.abs(b).max()


def test_not_structurally_symmetric_is_refused():
    n = 50
    A = sp.lil_matrix(sp.identity(n) * 4.0)
    for i in range(n - 1):
        A[i, i + 1] = -1.0  # upper only: U has entries outside the pattern of L^T
    A = sp.csc_matrix(A)
    with pytest.raises(Unsuitable):
        lu_supernodal(A)


def test_interior_backend_choice_leaves_positions_unchanged():
    """The 25k-unknown interior of cube_big_tetra: supernodal and PARDISO exact solves agree to round-off."""
    mesh = load("tet/cube_big_tetra.mesh")
    spec = {**bend_spec(mesh), "precision": "exact"}
    move = bend_move(mesh, angle=15.0, frac=0.02)
    ours = precompute(mesh, spec)
    assert ours.data.positions.lu_backend == "supernodal"
    peer = precompute(mesh, spec, options=SolveOptions(sweeps=False))
    assert peer.data.positions.lu_backend == "pardiso"
    a, b = ours.solve(move), peer.solve(move)
    disp = np.abs(b.V - mesh.V).max()
    assert disp > 0
    assert np.abs(a.V - b.V).max() <= 1e-9 * disp
    assert a.report["inverted_elements"] == b.report["inverted_elements"]


def test_a_factor_with_dropped_zeros_is_swept_on_one_thread():
    """An exported L without the fill its tree implies must not be split: a column would reach the other part."""
    Ld = np.eye(4)
    Ld[1, 0] = Ld[2, 0] = Ld[3, 0] = Ld[3, 1] = Ld[3, 2] = 1.0
    A = sp.csc_matrix(2.0 * Ld)  # L's column 1 reaches row 3 but not row 2, so the tree misses an edge
    lu = spla.splu(A, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    f = SupernodalFactor(lu.L, lu.U, np.arange(4))
    rng = np.random.default_rng(0)
    for _ in range(300):  # a race shows up in a fraction of the solves
        b = rng.standard_normal((4, 3))
        assert np.abs(f.solve(b) - np.linalg.solve(A.toarray(), b)).max() <= 1e-12


def test_a_factor_without_a_diagonal_entry_is_refused():
    L = sp.csc_matrix(np.array([[1.0, 0.0], [1.0, 0.0]]))  # column 1 has no diagonal entry
    U = sp.csc_matrix(np.array([[2.0, 1.0], [0.0, 0.0]]))
    with pytest.raises(Unsuitable):
        SupernodalFactor(L, U, np.arange(2))
