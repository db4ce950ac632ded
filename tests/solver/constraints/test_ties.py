"""Assemblies: coincident nodes of different parts tied by hard constraints (positions and rotations).

The assembly is bracket.inp (gmsh) and its mirror image about its x = 100 end face: two
parts whose end faces meet node for node, as parts of a CAE assembly do.
"""
from __future__ import annotations

import numpy as np
import pytest

from solver import ConstraintError, SpecError, mesh_from_arrays, precompute, read_mesh, write_mesh
from tests.conftest import DATA, shared_file


@pytest.fixture(scope="module")
def assembly():
    m = read_mesh(DATA / "bracket.inp")
    V2 = m.V.copy()
    V2[:, 0] = 200.0 - V2[:, 0]  # mirror about x = 100
    T2 = m.T[:, [0, 2, 1, 3]] + m.n  # a mirror flips orientation: swap two vertices back
    return mesh_from_arrays(np.vstack([m.V, V2]), np.vstack([m.T, T2])), m.n


def _spec(**extra):
    return {"selections": {"left": {"box": {"min": [-1, -1, -1], "max": [0, 21, 11]}},
                           "right": {"box": {"min": [200, -1, -1], "max": [201, 21, 11]}}},
            "fixed": ["left"], "handles": {"h": "right"}, **extra}


BEND = {"handles": {"h": {"translation": [0, 0, 25], "rotation": {"axis": [0, 1, 0], "angle_deg": -20}}}}


def test_coincident_nodes_of_two_parts_are_found_and_move_together(assembly):
    mesh, n1 = assembly
    assert mesh.body_labels.max() == 1  # two parts
    d = precompute(mesh, _spec())
    ties = d.data.constraints.ties
    load = read_mesh(DATA / "bracket.inp").sets["LOAD"]
    assert len(ties) == load.size  # every node of the shared face, once
    assert (ties[:, 0] < n1).all() and (ties[:, 1] >= n1).all()
    r = d.solve(BEND)
    assert np.abs(r.V[ties[:, 0]] - r.V[ties[:, 1]]).max() <= 1e-12 * 200
    assert r.report["inverted_elements"] == 0
    # the parts did move
    assert np.abs(r.V[ties[:, 0]] - mesh.V[ties[:, 0]]).max() > 1.0


def test_without_ties_the_parts_separate(assembly):
    mesh, _ = assembly
    ties = precompute(mesh, _spec()).data.constraints.ties
    P = precompute(mesh, _spec(ties=False)).solve(BEND).V
    assert np.abs(P[ties[:, 0]] - P[ties[:, 1]]).max() > 0.5  # the ties are what holds them


def test_a_part_held_only_by_ties_is_determined(assembly):
    mesh, n1 = assembly
    # a third copy beyond the second, tied to it and held by nothing else
    V3 = mesh.V[n1:].copy()
    V3[:, 0] = 400.0 - V3[:, 0]
    T3 = mesh.T[len(mesh.T) // 2:][:, [0, 2, 1, 3]] - n1 + mesh.n
    three = mesh_from_arrays(np.vstack([mesh.V, V3]), np.vstack([mesh.T, T3]))
    spec = _spec()
    # the handle is the second part's x = 200 face only: the third part touches it but is not selected
    fixed_face = read_mesh(DATA / "bracket.inp").sets["FIXED"]
    spec["selections"]["right"] = {"ids": (n1 + fixed_face).tolist()}
    with pytest.raises(ConstraintError) as e:
        precompute(three, {**spec, "ties": False})
    assert e.value.code == "unconstrained_component"
    d = precompute(three, spec)
    r = d.solve(BEND)
    assert np.abs(r.V[d.data.constraints.ties[:, 0]] - r.V[d.data.constraints.ties[:, 1]]).max() <= 1e-12 * 400


def test_explicit_ties_and_bad_ones(assembly):
    mesh, n1 = assembly
    auto = precompute(mesh, _spec()).data.constraints.ties
    d = precompute(mesh, _spec(ties=auto[:5].tolist()))
    assert len(d.data.constraints.ties) == 5
    with pytest.raises(SpecError):
        precompute(mesh, _spec(ties=[[0, 10 ** 9]]))
    with pytest.raises(SpecError, match="ties"):
        precompute(mesh, _spec(ties="sometimes"))


def test_material_regions_are_sets_and_stay_conforming(tmp_path):
    """cube_cylinder.mesh: a cylinder region (medit:ref 2) through a cube (ref 1), one conforming
    mesh. Regions become node sets, usable as selections; a bend moves the interface nodes once
    for both regions, and the written Medit file keeps the regions."""
    from solver.validity.quality import signed_volumes

    mesh = read_mesh(shared_file("tet/cube_cylinder.mesh"))
    a, b = mesh.sets["medit:ref=1"], mesh.sets["medit:ref=2"]
    assert a.size == 8816 and b.size == 2442 and np.intersect1d(a, b).size == 768
    spec = {"selections": {"bottom": {"plane": {"point": [0, 0, 0], "normal": [0, 0, 1], "tolerance": 1e-9}},
                           "core": {"set": "medit:ref=2", "boundary_only": True},
                           "top": {"plane": {"point": [0, 0, 1], "normal": [0, 0, 1], "tolerance": 1e-9}}},
            "fixed": ["bottom"], "handles": {"top": "top"}}
    with pytest.raises(SpecError):  # the core's boundary overlaps both end faces
        precompute(mesh, {**spec, "handles": {"top": "top", "core": "core"}})
    d = precompute(mesh, spec)
    r = d.solve({"handles": {"top": {"translation": [0.1, 0, 0], "rotation": {"axis": [0, 1, 0], "angle_deg": 15}}}})
    assert r.report["inverted_elements"] == 0 == int((signed_volumes(r.V, mesh.T) <= 0).sum())
    out = tmp_path / "out.mesh"
    write_mesh(mesh, r.V, out)
    back = read_mesh(out)
    assert np.abs(back.V - r.V).max() <= 1e-12
    for k in ("medit:ref=1", "medit:ref=2"):
        assert np.array_equal(back.sets[k], mesh.sets[k])
