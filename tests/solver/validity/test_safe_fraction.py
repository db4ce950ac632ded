"""Mesh validity: safe fraction of an inverting MOVE and the ``clamp`` policy."""
from __future__ import annotations

import json

import numpy as np
import pytest

from solver import precompute
from solver.cli import main
from solver.linalg import factorization as fz
from solver.validity.quality import signed_volumes
from tests.conftest import DATA, bend_move, bend_spec, load, longest_axis


@pytest.fixture(scope="module")
def armadillo():
    """The paper's method unchanged (no thin-wall rows), so that these moves invert elements."""
    m = load("Armadillo13K.msh")
    return m, precompute(m, bend_spec(m, thin_walls=False))


_move = bend_move


def test_safe_move_has_fraction_one(armadillo):
    m, d = armadillo
    r = d.solve(_move(m, 10, 0.05))
    assert r.report["inverted_elements"] == 0
    assert r.report["safe_fraction"] == 1.0 and r.report["clamped"] is False


def test_inverting_move_gets_a_safe_fraction_and_clamp_inverts_nothing(armadillo):
    m, d = armadillo
    mv = _move(m, 45, 0.1)
    n0 = fz.STATS["factorizations"]
    r = d.solve(mv)
    assert r.report["inverted_elements"] > 0  # 77 measured
    f = r.report["safe_fraction"]
    assert 0.0 < f < 1.0
    c = d.solve(mv, inversion="clamp")
    assert fz.STATS["factorizations"] == n0  # bisection only back-substitutes
    assert c.report["clamped"] and c.report["applied_fraction"] == f
    assert c.report["inverted_elements"] == 0
    assert (signed_volumes(c.V, m.T) > 0).all()
    assert c.report["inverted_elements_unclamped"] == r.report["inverted_elements"]
    # the clamped result is the scaled MOVE's result, and the bracket above it inverts
    scaled = d.scaled_move(d.parse_move(mv), f)
    np.testing.assert_array_equal(c.V, d.solve(scaled).V)
    assert d.solve(d.scaled_move(d.parse_move(mv), min(1.0, f + 2.0 / 1024))).report["inverted_elements"] > 0
    # the applied move is the scaled one: translation f t, angle f theta
    assert np.allclose(c.move.handles["h"].translation, f * np.asarray(mv["handles"]["h"]["translation"]))


def test_scaled_move_ends_are_rest_and_the_move(armadillo):
    m, d = armadillo
    mv = d.parse_move(_move(m, 30, 0.1))
    _, diag = longest_axis(m)
    # pivot + (p0 - pivot): the rest shape to round-off
    np.testing.assert_allclose(d.solve(d.scaled_move(mv, 0.0)).V, m.V, rtol=0, atol=1e-14 * diag)
    np.testing.assert_allclose(d.solve(d.scaled_move(mv, 1.0)).V, d.solve(mv).V, atol=1e-12)


def test_constraint_targets_are_interpolated_too():
    plate = load("plate.inp")
    spec = {"selections": {"fix": {"set": "FIXED"}, "load": {"set": "LOAD"}, "h1": {"set": "HOLE1"}},
            "fixed": ["fix"], "handles": {"tip": "load"},
            "points": [{"name": "c", "selection": "h1"}],
            "features": [{"selection": "h1", "mode": "rigid", "name": "H1"}]}
    d = precompute(plate, spec)
    c0 = plate.V[plate.sets["HOLE1"]].mean(0)
    mv = d.parse_move({"handles": {"tip": {"translation": [0, 0, 30]}}, "points": {"c": (c0 + [0, 0, 8]).tolist()},
                       "features": {"H1": {"scale": 1.5}}})
    half = d.scaled_move(mv, 0.5)
    np.testing.assert_allclose(half.points["c"], c0 + [0, 0, 4])
    assert half.features["H1"] == pytest.approx(1.5 ** 0.5)
    P = d.solve(half).V
    np.testing.assert_allclose(P[plate.sets["HOLE1"]].mean(0), c0 + [0, 0, 4], atol=1e-10)


def test_cli_clamp(tmp_path, capsys):
    m = load("Armadillo13K.msh")
    spec, move = tmp_path / "spec.json", tmp_path / "move.json"
    spec.write_text(json.dumps(bend_spec(m, thin_walls=False)))
    move.write_text(json.dumps(_move(m, 45, 0.1)))
    out, rep = tmp_path / "out.vtu", tmp_path / "rep.json"
    assert main(["morph", str(DATA / "Armadillo13K.msh"), "--spec", str(spec), "--move", str(move),
                 "--output", str(out), "--report", str(rep), "--inversion", "clamp"]) == 0
    report = json.loads(rep.read_text())
    assert report["clamped"] and report["inverted_elements"] == 0
    assert "clamped to" in capsys.readouterr().err
