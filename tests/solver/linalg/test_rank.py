"""Hard constraints beyond fixed and handle vertices (ECLS §3-5, Form features §3).

Real data: ``tests/data/plate.inp``, a gmsh OCC plate with four holes
(``make_plate.py``); the holes' walls are the node sets HOLE1..HOLE4, nodes
exactly on cylinders of radius 6 with axes along z.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from hypothesis import given, settings

from solver.linalg.constrained import rank_analysis
from tests.solver.linalg.strategies import constraint_rows

# --------------------------------------------------------------------- engine


@settings(max_examples=60, deadline=None)
@given(constraint_rows())
def test_rank_analysis_keeps_a_basis_in_priority_order(case):
    C, rng = case
    ra = rank_analysis(sp.csr_matrix(C))
    Ck = C[ra.kept]
    rank = np.linalg.matrix_rank(C)
    assert ra.kept.sum() == rank == np.linalg.matrix_rank(Ck)
    # priority: each kept row is independent of the rows before it, each dropped one is not
    for i in range(C.shape[0]):
        before = np.linalg.matrix_rank(C[:i]) if i else 0
        assert ra.kept[i] == (np.linalg.matrix_rank(C[: i + 1]) > before)
    Z = ra.Z.toarray()
    assert Z.shape == (C.shape[1], C.shape[1] - rank)
    assert np.abs(C @ Z).max(initial=0) < 1e-10
    assert np.abs(Z.T @ Z - np.eye(Z.shape[1])).max(initial=0) < 1e-10
    x = rng.standard_normal(C.shape[1])
    d = C @ x  # consistent targets
    xp = ra.Xp @ np.where(ra.kept, d, 0.0)
    assert np.abs(C @ xp - d).max() < 1e-9 * max(1.0, np.abs(d).max())
