"""The column basis of a block of right-hand sides: rank, per-column accuracy, degenerate blocks."""

from __future__ import annotations

import numpy as np
import pytest

from solver.linalg.column_basis import column_basis


def _relative_errors(D: np.ndarray, basis: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """|D_j - basis coef_j| / |D_j| per column, computed here (0 for zero columns)."""
    err = np.linalg.norm(D - basis @ coef, axis=0)
    norms = np.linalg.norm(D, axis=0)
    return np.where(norms > 0, err / np.where(norms > 0, norms, 1.0), err)


def _smooth_block(c: int = 3000, k: int = 16, seed: int = 0) -> np.ndarray:
    """Columns sampled from a smooth two-parameter family (like a DOE block's displacements)."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, c)
    cols = []
    for a, b in rng.uniform(-1, 1, (k, 2)):
        for q in range(3):
            cols.append(np.sin((q + 1) * a * s) + b * np.cos(2 * s) * s ** q + a * b * s)
    return np.array(cols).T


@pytest.mark.parametrize("tol", [1e-6, 1e-10, 1e-13])
def test_every_column_is_reproduced_within_the_stated_bound(tol):
    D = _smooth_block()
    b = column_basis(D, tol)
    assert 0 < b.rank < D.shape[1]  # a smooth family: far fewer directions than columns
    assert b.error <= tol
    rel = _relative_errors(D, b.basis, b.coefficients)
    assert rel.max() <= b.error + 1e-13  # the bound, up to the round-off of forming the product


def test_a_tighter_tolerance_keeps_more_directions():
    D = _smooth_block()
    ranks = [column_basis(D, t).rank for t in (1e-4, 1e-8, 1e-12)]
    assert ranks == sorted(ranks) and ranks[0] < ranks[-1]


def test_small_columns_are_reproduced_relative_to_their_own_size():
    D = _smooth_block(k=8)
    D[:, 5] *= 1e-9  # one variant moved a billionth as far as the others
    b = column_basis(D, 1e-10)
    assert _relative_errors(D, b.basis, b.coefficients)[5] <= 1e-10 + 1e-13


def test_exact_low_rank_and_full_rank_blocks():
    rng = np.random.default_rng(3)
    U, Vt = rng.normal(size=(500, 4)), rng.normal(size=(4, 30))
    low = column_basis(U @ Vt, 1e-10)
    assert low.rank == 4 and low.error < 1e-12
    F = rng.normal(size=(500, 12))
    full = column_basis(F, 1e-10)
    assert full.rank == 12 and full.error == 0.0
    np.testing.assert_allclose(full.basis @ full.coefficients, F, atol=1e-12)
    # the directions are orthogonal
    G = low.basis.T @ low.basis
    assert np.abs(G - np.diag(np.diag(G))).max() <= 1e-10 * np.abs(G).max()


def test_zero_columns_and_layouts():
    D = _smooth_block(k=4)
    D[:, [0, 7]] = 0.0
    b = column_basis(D, 1e-10)
    np.testing.assert_allclose(b.basis @ b.coefficients[:, [0, 7]], 0.0, atol=1e-12)
    f = column_basis(np.asfortranarray(D), 1e-10)
    assert f.rank == b.rank
    np.testing.assert_allclose(f.basis @ f.coefficients, b.basis @ b.coefficients, atol=1e-12)
    z = column_basis(np.zeros((50, 6)), 1e-10)
    assert z.rank == 0 and z.coefficients.shape == (0, 6) and z.basis.shape == (50, 0)
    e = column_basis(np.zeros((0, 3)), 1e-10)
    assert e.rank == 0


def test_bad_input_is_refused_with_what_is_wrong():
    with pytest.raises(ValueError, match="finite"):
        column_basis(np.array([[1.0, np.nan], [0.0, 1.0]]), 1e-10)
    with pytest.raises(ValueError, match="2-d"):
        column_basis(np.ones(4), 1e-10)
    with pytest.raises(ValueError, match="tol"):
        column_basis(np.ones((3, 2)), 0.0)
