"""One shared precompute, many threads: every result identical to the bit to the sequential one.

The contract of :class:`solver.Deformer`: after the precompute nothing a solve
touches is written, so concurrent solves (the service serves one session
from several threads) give exactly the results of solving one by one.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from solver import precompute
from tests.conftest import bend_move, bend_spec, load

THREADS = 8


def _moves(mesh, n: int) -> list[dict]:
    return [bend_move(mesh, angle=4.0 + 3.0 * k, frac=0.005 * k) for k in range(n)]


def _strip(report: dict) -> dict:
    return {k: v for k, v in report.items() if k != "timings"}


def _run(d, moves, inversion="warn"):
    r = d.solve(moves, inversion=inversion)
    f = d.safe_fraction(moves)
    return r.V, _strip(r.report), f


def _check(mesh, spec, moves, inversion="warn"):
    d = precompute(mesh, spec)
    seq = [_run(d, m, inversion) for m in moves]
    with ThreadPoolExecutor(THREADS) as pool:
        par = list(pool.map(lambda m: _run(d, m, inversion), moves * 2))  # every move twice, interleaved
    for k, (V, rep, f) in enumerate(par):
        V0, rep0, f0 = seq[k % len(moves)]
        assert np.array_equal(V, V0), f"move {k % len(moves)}: positions differ from the sequential solve"
        assert rep == rep0
        assert f == f0
    return d, seq


@pytest.mark.parametrize("name", ["tet/tractor_wheel_coarse.INP", "mixed.msh"])
def test_concurrent_solves_equal_sequential_ones_to_the_bit(name):
    mesh = load(name)
    d, seq = _check(mesh, bend_spec(mesh), _moves(mesh, THREADS))
    if mesh.T10 is not None:  # the quadratic path ran: mid-side placement and its relaxation
        assert any(rep["midside_relaxed"] is not None for _, rep, _ in seq)
    assert d.factorizations > 0 and not any(rep["refactorized"] for _, rep, _ in seq)


def test_concurrent_clamped_moves_on_a_thin_walled_part_equal_sequential_ones():
    mesh = load("Armadillo13K.msh")
    d = precompute(mesh, bend_spec(mesh))
    assert d.data.walls is not None and d.data.walls.E.shape[0] > 0  # thin-wall rows are part of the solve
    moves = [bend_move(mesh, angle=60.0 + 15.0 * k, frac=0.1) for k in range(THREADS)]
    _, seq = _check(mesh, bend_spec(mesh), moves, inversion="clamp")
    clamped = [rep for _, rep, _ in seq if rep["clamped"]]
    assert clamped, "the large moves invert elements, so clamp must have scaled some of them"
    assert all(rep["inverted_elements"] == 0 and 0 <= rep["applied_fraction"] < 1 for rep in clamped)
