"""The mixed-precision interior solve: how close it is, measured, and hard constraints exact either way.

The REPORT states the relative mean-value residual of a mixed-precision
update; here it is recomputed from the output positions with the
mean-value matrix built independently (:func:`solver.ops.mvc_matrix.mvc_matrix`),
and the positions are compared with the double-precision solve.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from solver import SolveOptions, precompute, read_mesh
from solver.deform.positions import MIXED_TOL
from solver.ops.mvc_matrix import mvc_matrix
from tests.conftest import DATA, bend_move, bend_spec, load


@pytest.fixture(scope="module")
def bracket(tmp_path_factory):
    """The CAD bracket of tests/data/make_bracket.py meshed by gmsh at 69k tets (6,342 free interior vertices)."""
    path = tmp_path_factory.mktemp("bracket") / "bracket.inp"
    subprocess.run([sys.executable, str(DATA / "make_bracket.py"), "1.1", str(path)], check=True)
    return read_mesh(path)


@pytest.mark.parametrize("name", ["tet/cube_big_tetra.mesh", "bracket"])
def test_mixed_precision_is_within_its_stated_accuracy_of_the_exact_solve(name, request):
    mesh = request.getfixturevalue("bracket") if name == "bracket" else load(name)
    spec = bend_spec(mesh)
    move = bend_move(mesh, angle=20.0, frac=0.03)
    d = precompute(mesh, spec)
    mixed = d.solve(move)
    exact = precompute(mesh, {**spec, "precision": "exact"}).solve(move)
    rep = mixed.report
    assert rep["interior_precision"] == "single" and exact.report["interior_precision"] == "double"
    assert "mean_value_residual" not in exact.report
    # independent residual: every free interior vertex's mean-value row at the output positions
    fi = d.data.positions.free_interior
    assert fi.size > 5000  # large enough for the single-precision factor
    W, _ = mvc_matrix(mesh.V, mesh.T, mesh.interior)
    res = mixed.V[fi] - (W @ mixed.V)[fi]
    disp = np.linalg.norm(mixed.V[fi] - mesh.V[fi], axis=1).max()
    rel = float(np.linalg.norm(res, axis=1).max() / disp)
    assert rel <= MIXED_TOL
    assert rel == pytest.approx(rep["mean_value_residual"], rel=0.05, abs=1e-12)
    # distance to the double-precision solution, relative to the displacement
    gap = float(np.linalg.norm(mixed.V - exact.V, axis=1).max() / disp)
    assert gap <= 10 * MIXED_TOL
    # hard constraints exact whatever the interior precision
    fixed = d.data.constraints.fixed
    assert np.array_equal(mixed.V[fixed], mesh.V[fixed])
    assert rep["constraint_residual_max"] <= 1e-12 * d.data.constraints.diag
    assert rep["inverted_elements"] == exact.report["inverted_elements"]


def test_the_report_is_plain_json(bracket):
    import json

    r = precompute(bracket, bend_spec(bracket)).solve(bend_move(bracket, angle=10.0, frac=0.01))
    assert r.report["interior_precision"] == "single"
    json.dumps(r.report, allow_nan=False)  # only Python numbers, bools and strings: no numpy scalars


def test_a_refinement_step_brings_the_interior_closer_to_the_exact_solve(monkeypatch):
    """With the tolerance at 0 every mixed solve refines once: its residual drops and it nears the exact solve."""
    from solver.deform import positions

    mesh = load("tet/cube_big_tetra.mesh")
    spec = bend_spec(mesh)
    moves = [bend_move(mesh, angle=a, frac=0.02) for a in (10.0, 20.0)]
    exact = precompute(mesh, {**spec, "precision": "exact"})
    d = precompute(mesh, spec)
    plain = [d.solve(m) for m in moves]
    monkeypatch.setattr(positions, "MIXED_TOL", 0.0)
    refined = [d.solve(moves[0])] + list(d.solve_many(moves))  # one update, and two stacked
    fi = d.data.positions.free_interior
    W, _ = mvc_matrix(mesh.V, mesh.T, mesh.interior)  # the mean-value rows, built independently

    def residual(V: np.ndarray) -> float:
        return float(np.linalg.norm(V[fi] - (W @ V)[fi], axis=1).max())

    for r, p, m in zip(refined, [plain[0], *plain], [moves[0], *moves], strict=True):
        assert r.report["interior_refined"] is True and p.report["interior_refined"] is False
        assert residual(r.V) < residual(p.V)
        ref = exact.solve(m).V
        assert np.abs(r.V - ref).max() < np.abs(p.V - ref).max()


@pytest.mark.parametrize("backend", ["supernodal", "pardiso"])
def test_stacked_solves_through_the_column_basis_match_separate_solves(backend, monkeypatch):
    """A block of MOVEs solved through its column basis: each as its own solve, within the stated accuracy.

    ``pardiso``: the interior factor of systems above 40,000 unknowns (float32 solutions), here forced.
    """
    from solver.deform import positions

    options = SolveOptions(sweeps=backend != "pardiso")
    mesh = load("tet/cube_big_tetra.mesh")
    d = precompute(mesh, bend_spec(mesh), options=options)
    assert d.data.positions.lu_backend == backend
    moves = [bend_move(mesh, angle=a, frac=f) for a, f in  # (0, 0): a row at rest, columns of round-off
             [(20, 0.03), (-10, 0.01), (5, -0.02), (15, 0.0), (0, 0.02), (-20, -0.03), (8, 0.015), (0, 0.0)]]
    singles = [d.solve(m) for m in moves]
    ranks: list[int] = []
    basis = positions.column_basis

    def spy(D, tol, scale=None):
        b = basis(D, tol, scale)
        ranks.append(b.rank)
        return b

    monkeypatch.setattr(positions, "column_basis", spy)
    many = d.solve_many(moves)  # below BASIS_MIN: the direct stacked solve
    assert ranks == []
    monkeypatch.setattr(positions, "BASIS_MIN", 0)
    through = d.solve_many(moves)
    assert ranks and ranks[0] + 3 < positions.BASIS_GAIN * 3 * len(moves)  # fewer columns solved
    calls = len(ranks)
    fi = d.data.positions.free_interior
    W, _ = mvc_matrix(mesh.V, mesh.T, mesh.interior)
    fixed = d.data.constraints.fixed
    for i, (one, direct, r) in enumerate(zip(singles, many, through, strict=True)):
        disp = np.linalg.norm(one.V[fi] - mesh.V[fi], axis=1).max()
        if i == len(moves) - 1:  # the row at rest: the rest shape to round-off of the coordinates
            assert np.abs(r.V - mesh.V).max() <= 1e-12 * d.data.constraints.diag
            continue
        for other in (direct, r):
            assert np.linalg.norm(other.V - one.V, axis=1).max() <= 10 * MIXED_TOL * disp
        res = float(np.linalg.norm(r.V[fi] - (W @ r.V)[fi], axis=1).max() / disp)  # independent residual
        assert res <= MIXED_TOL
        assert r.report["interior_refined"] is False  # met by the basis solve itself, not by a refinement step
        assert np.array_equal(r.V[fixed], mesh.V[fixed])
        assert r.report["inverted_elements"] == one.report["inverted_elements"]
    off = precompute(mesh, bend_spec(mesh), options=dataclasses.replace(options, basis=False))
    off.solve_many(moves)
    assert len(ranks) == calls  # switched off
