"""Stacked solves and the boundary-first stage give the single solve's results."""

from __future__ import annotations

import numpy as np
import pytest

from solver import precompute
from solver.deform.positions import MIXED_TOL
from tests.conftest import bend_move, bend_spec, load


@pytest.mark.parametrize("name", ["Armadillo13K.msh", "tet/cube_big_tetra.mesh", "tet/tractor_wheel_coarse.INP"])
def test_solve_many_equals_one_by_one(name):
    mesh = load(name)
    d = precompute(mesh, bend_spec(mesh))
    moves = [bend_move(mesh, angle=a, frac=f) for a, f in ((5, 0.0), (15, 0.02), (25, 0.04), (-10, 0.01))]
    many = d.solve_many(moves)
    diag = d.data.constraints.diag
    for mv, r in zip(moves, many, strict=True):
        one = d.solve(mv)
        tol = 1e-9 * diag  # round-off of a multi-column solve; single precision: its stated accuracy
        if one.report.get("interior_precision") == "single":
            tol = max(tol, 10 * MIXED_TOL * one.report["max_displacement"])
        assert np.abs(r.V - one.V).max() <= tol
        assert r.report["inverted_elements"] == one.report["inverted_elements"]
        assert r.report["constraint_residual_max"] <= 1e-12 * diag


@pytest.mark.parametrize("name", ["Armadillo13K.msh", "tet/cube_big_tetra.mesh"])
def test_boundary_stage_is_the_final_boundary_and_completes_to_the_solve(name):
    mesh = load(name)
    d = precompute(mesh, bend_spec(mesh))
    mv = bend_move(mesh, angle=20.0, frac=0.02)
    stage = d.solve_boundary(mv)
    full = d.solve(mv)
    ids = stage.ids
    assert np.array_equal(ids, np.union1d(np.flatnonzero(mesh.boundary), d.data.constraints.constrained))
    assert np.array_equal(stage.P[ids], full.V[ids])  # the boundary frame is already final
    interior = np.setdiff1d(np.flatnonzero(mesh.referenced), ids)
    assert np.array_equal(stage.P[interior], mesh.V[interior])  # not solved yet
    done = d.solve(stage)
    assert np.array_equal(done.V, full.V)
    assert {k: v for k, v in done.report.items() if k != "timings"} == \
        {k: v for k, v in full.report.items() if k != "timings"}
