"""Morph domains (SPEC ``domain``) and the REPORT's handle and free displacements.

Every node outside the domain, corner or mid-side, must keep its rest position bit for bit; the
nodes are found in the test from the rest coordinates, not from the solver's constraint set.
"""

from __future__ import annotations

import numpy as np
import pytest

from solver import precompute, read_mesh
from solver.constraints.selection import select
from solver.errors import SpecError
from tests.conftest import DATA, bend_move, bend_spec, load

DECK = DATA / "ccx_bracket.inp"  # C3D10, 100 x 20 x 10 bar, bore HOLE at x = 55..65
#: A box around the bore: the domain the bore's move may change.
BOX = {"box": {"min": [40.0, -1.0, -1.0], "max": [80.0, 21.0, 11.0]}}
MOVE = {"handles": {"bore": {"translation": [-3.0, 1.0, 0.0]}}}


def _spec(domain=True):
    spec = {"selections": {"clamp": {"set": "FIXED"}, "bore": {"set": "HOLE"}, "near": BOX},
            "fixed": ["clamp"], "handles": {"bore": "bore"}}
    if domain:
        spec["domain"] = "near"
    return spec


@pytest.mark.parametrize("precision", ["exact", "mixed"])
def test_every_node_outside_the_domain_keeps_its_rest_position(precision):
    mesh = read_mesh(DECK)
    V0 = mesh.V
    used = np.zeros(mesh.n, bool)
    used[mesh.T10.ravel()] = True  # corner and mid-side nodes of every element
    lo, hi = np.array(BOX["box"]["min"]), np.array(BOX["box"]["max"])
    inside = ((V0 >= lo) & (V0 <= hi)).all(axis=1)
    outside = used & ~inside
    assert outside.sum() > 1000 and (used & inside).sum() > 500  # both sides are substantial

    r = precompute(mesh, {**_spec(), "precision": precision}).solve(MOVE)
    assert np.array_equal(r.V[outside], V0[outside])  # bit for bit, mid-side nodes included
    bore = select(mesh, {"set": "HOLE"}, "bore")
    np.testing.assert_allclose(r.V[bore], V0[bore] + [-3.0, 1.0, 0.0], rtol=0, atol=1e-12)
    moved = np.linalg.norm(r.V - V0, axis=1)
    free_inside = used & inside
    free_inside[bore] = False
    assert moved[free_inside].max() > 0.5  # the domain itself morphs
    assert r.report["inverted_elements"] == 0

    # without the domain the same MOVE reaches beyond the box
    far = precompute(mesh, _spec(domain=False)).solve(MOVE)
    assert np.abs(far.V[outside] - V0[outside]).max() > 0.1


def test_a_handle_outside_the_domain_is_refused_naming_it():
    mesh = read_mesh(DECK)
    spec = _spec()
    spec["selections"]["near"] = {"box": {"min": [58.0, -1.0, -1.0], "max": [80.0, 21.0, 11.0]}}  # cuts the bore
    with pytest.raises(SpecError) as e:
        precompute(mesh, spec)
    assert e.value.code == "handle_outside_domain"
    hole = select(mesh, {"set": "HOLE"}, "bore")
    n_out = int((mesh.V[hole, 0] < 58.0).sum())
    assert f"{n_out} vertices outside the domain 'near'" in str(e.value)


@pytest.mark.parametrize("domain", ["nowhere", 3, ["near"]])
def test_a_domain_that_names_no_selection_is_refused(domain):
    mesh = read_mesh(DECK)
    with pytest.raises(SpecError) as e:
        precompute(mesh, {**_spec(), "domain": domain})
    assert "SPEC.domain" in str(e.value)


def test_the_domain_round_trips_through_the_spec_document():
    from solver.constraints.spec import parse_spec

    s = parse_spec(_spec())
    assert s.domain == "near" and parse_spec(s.to_dict()).domain == "near"
    assert "domain" not in parse_spec(_spec(domain=False)).to_dict()


def test_the_report_states_the_largest_handle_and_free_displacements():
    """On a bend of cube_big_tetra a free node moves further than the handle: the REPORT says so."""
    mesh = load("tet/cube_big_tetra.mesh")
    spec = bend_spec(mesh)
    r = precompute(mesh, spec).solve(bend_move(mesh, angle=20.0, frac=0.03))
    disp = np.linalg.norm(r.V - mesh.V, axis=1)
    fixed = select(mesh, spec["selections"]["fix"], "fix")
    hand = select(mesh, spec["selections"]["hand"], "hand")
    free = np.ones(mesh.n, bool)
    free[fixed] = free[hand] = False
    rep = r.report
    assert rep["max_handle_displacement"] == pytest.approx(disp[hand].max(), rel=1e-12)
    assert rep["max_free_displacement"] == pytest.approx(disp[free].max(), rel=1e-12)
    assert rep["max_displacement"] == pytest.approx(disp.max(), rel=1e-12)
    assert rep["max_free_displacement"] > rep["max_handle_displacement"]  # the surprise it is there to show


def test_a_spec_without_handles_reports_no_handle_displacement():
    mesh = read_mesh(DECK)
    spec = {"selections": {"clamp": {"set": "FIXED"}, "p": {"ids": [int(select(mesh, {"set": "LOAD"}, "p")[0])]}},
            "fixed": ["clamp"], "points": [{"name": "tip", "vertices": [int(select(mesh, {"set": "LOAD"}, "p")[0])]}]}
    r = precompute(mesh, spec).solve({"points": {"tip": (mesh.V[select(mesh, {"set": "LOAD"}, "p")[0]]
                                                         + [0.0, 0.0, 1.0]).tolist()}})
    assert "max_handle_displacement" not in r.report
    assert r.report["max_free_displacement"] == pytest.approx(np.linalg.norm(r.V - mesh.V, axis=1).max(), rel=1e-12)
