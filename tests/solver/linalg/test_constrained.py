"""Hard constraints beyond fixed and handle vertices (ECLS §3-5, Form features §3).

Real data: ``tests/data/plate.inp``, a gmsh OCC plate with four holes
(``make_plate.py``); the holes' walls are the node sets HOLE1..HOLE4, nodes
exactly on cylinders of radius 6 with axes along z.
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings

from solver import precompute, read_mesh
from solver.linalg.constrained import constrained_solver
from tests.solver.linalg.strategies import constraint_rows
from tests.solver.plate import BEND, EXACT, PLATE, diag, plate_spec

# --------------------------------------------------------------------- engine


@pytest.fixture(scope="module")
def plate():
    return read_mesh(PLATE)


@pytest.mark.parametrize("solve", ["auto", "joint"])
def test_three_methods_agree_and_the_penalty_residual_shrinks(plate, solve):
    extra = dict(features=[{"selection": "hole1", "mode": "rigid", "name": "H1"},
                           {"selection": "hole4", "mode": "keep_direction", "name": "H4"}],
                 motion=[{"name": "c2", "selection": "hole2", "plane": {"normal": [0, 0, 1]}}],
                 points=[{"name": "e", "edge": [int(plate.sets["HOLE3"][0]), int(plate.sets["HOLE3"][1])],
                          "t": 0.3}])
    mv = {**BEND, "features": {"H1": {"scale": 0.9}}, "motion": {"c2": {"point": [0, 0, 3]}}}
    P = {m: precompute(plate, plate_spec(**extra, constraints={"method": m}, solve=solve)).solve(mv).V
         for m in EXACT}
    dg = diag(plate)
    assert np.abs(P["null_space"] - P["kkt"]).max() <= 1e-8 * dg
    if solve == "joint":
        # the penalty residual shrinks as beta^-2 and the result approaches the exact one; past
        # beta ~ 1e4 a rigid feature's rows make the penalised system too ill-conditioned for
        # that to continue (measured; README), so the check stops there
        residuals, errors = [], []
        for beta in (1e2, 1e3, 1e4):
            r = precompute(plate, plate_spec(**extra, constraints={"method": "penalty", "penalty_weight": beta},
                                        solve=solve)).solve(mv)
            residuals.append(r.report["constraint_residual_max"])
            errors.append(np.abs(r.V - P["null_space"]).max())
        assert residuals[0] > 50 * residuals[1] > 2500 * residuals[2]
        assert errors[0] > errors[1] and errors[1] <= 1e-5 * dg


@settings(max_examples=30, deadline=None)
@given(constraint_rows())
def test_null_space_and_kkt_agree_on_random_problems(case):
    C, rng = case
    N = C.shape[1]
    A = sp.csr_matrix(np.vstack([np.eye(N), rng.standard_normal((N, N))]))
    c = rng.standard_normal((2 * N, 2))
    d = C @ rng.standard_normal((N, 2))
    x = {m: constrained_solver(sp.csr_matrix(C), A=A, method=m).solve(np.zeros((N, 2)), d, c)
         for m in EXACT}
    assert np.abs(x["null_space"] - x["kkt"]).max() < 1e-8 * max(1.0, np.abs(x["kkt"]).max())
    assert np.abs(C @ x["null_space"] - d).max() < 1e-9 * max(1.0, np.abs(d).max())
