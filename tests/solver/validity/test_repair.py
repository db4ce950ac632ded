"""Mesh validity: safe fraction of an inverting MOVE and the ``clamp`` policy."""
from __future__ import annotations

import numpy as np
import pytest

from solver import precompute
from solver.validity.quality import signed_volumes
from tests.conftest import bend_move, bend_spec, load


@pytest.fixture(scope="module")
def armadillo():
    """The paper's method unchanged (no thin-wall rows), so that these moves invert elements."""
    m = load("Armadillo13K.msh")
    return m, precompute(m, bend_spec(m, thin_walls=False))


_move = bend_move


def test_repair_untangles_a_few_elements_and_keeps_constraints_exact(armadillo):
    m, d = armadillo
    mv = _move(m, 20, 0.1)
    plain = d.solve(mv)
    assert 0 < plain.report["inverted_elements"] <= 5  # 1 measured
    r = d.solve(mv, repair=True)
    rep = r.report["repair"]
    assert rep["success"] and rep["accepted"] and r.report["inverted_elements"] == 0
    assert (signed_volumes(r.V, m.T) > 0).all()
    assert sorted(rep["repaired_elements"]) == sorted(plain.report["inverted_ids"])
    # only free interior vertices moved: boundary and constrained vertices are bit-identical
    moved = np.flatnonzero(np.any(r.V != plain.V, axis=1))
    assert moved.size == rep["moved_vertices"] > 0
    assert d.data.constraints.movable[moved].all() and not m.boundary[moved].any()
    assert r.report["constraint_residual_max"] == plain.report["constraint_residual_max"]
    assert r.report["safe_fraction"] == 1.0  # the repaired result is valid


def test_repair_is_never_worse_and_says_why_it_stops(armadillo):
    m, d = armadillo
    mv = _move(m, 30, 0.2)
    plain = d.solve(mv)
    r = d.solve(mv, repair=True)
    rep = r.report["repair"]
    assert rep["inverted_after"] <= rep["inverted_before"] == plain.report["inverted_elements"]
    assert r.report["inverted_elements"] == rep["inverted_after"]
    if not rep["success"]:
        assert "stay inverted" in rep["reason"] and rep["unrepaired_ids"]
    if not rep["accepted"]:
        np.testing.assert_array_equal(r.V, plain.V)
