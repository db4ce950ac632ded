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


def test_quality_metrics_of_the_regular_tet_and_a_sliver():
    from solver.validity.quality import aspect_ratios, dihedral_angles, element_quality

    reg = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    T = np.array([[0, 2, 1, 3]])
    np.testing.assert_allclose(dihedral_angles(reg, T), np.degrees(np.arccos(1 / 3)), atol=1e-12)
    np.testing.assert_allclose(aspect_ratios(reg, T), 1.0, atol=1e-12)
    # right-angle corner tet: dihedral angles 90 (x3) and arccos(1/sqrt(3)) (x3)
    corner = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    d = np.sort(dihedral_angles(corner, np.array([[0, 1, 2, 3]]))[0])
    np.testing.assert_allclose(d, [np.degrees(np.arccos(1 / np.sqrt(3)))] * 3 + [90.0] * 3, atol=1e-10)
    # a flat sliver: dihedral angles at 0 and 180, aspect ratio capped, all finite
    flat = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    q = element_quality(flat, np.array([[0, 1, 2, 3]]))
    assert all(np.isfinite(v).all() for v in q.values())
    assert q["min_dihedral_deg"][0] < 1e-6 and q["max_dihedral_deg"][0] > 180 - 1e-6
    assert q["aspect_ratio"][0] == 1e12


def test_full_quality_report_and_cell_data(armadillo, tmp_path):
    import meshio

    from solver import write_mesh
    from solver.validity.quality import METRICS

    m, d = armadillo
    r = d.solve(_move(m, 45, 0.1), quality="full")
    q = r.report["quality"]
    assert set(q["before"]) == set(q["after"]) == set(METRICS)
    assert q["after"]["volume"]["min"] < 0 < q["before"]["volume"]["min"]  # this move inverts
    h = q["after"]["scaled_jacobian"]["histogram"]
    assert sum(h["counts"]) == m.T.shape[0] and len(h["edges"]) == len(h["counts"]) + 1
    assert int((r.cell_quality["volume"] <= 0).sum()) <= r.report["inverted_elements"]
    json.dumps(r.report, allow_nan=False)  # the REPORT stays strict JSON
    out = tmp_path / "q.vtu"
    write_mesh(m, r.V, out, quality=True)
    back = meshio.read(out)
    sj = np.concatenate([np.asarray(a) for a, c in zip(back.cell_data["quality:scaled_jacobian"], back.cells, strict=True)
                         if c.type == "tetra"])
    np.testing.assert_allclose(sj, r.cell_quality["scaled_jacobian"])
    with pytest.raises(Exception, match="quality"):
        d.solve(_move(m, 10, 0.01), quality="all")


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


def _kiefer_corners():
    """kiefer_fea_bracket.vtu (../shared, tetra10) as linear tets on its corner nodes."""
    import meshio

    from solver import mesh_from_arrays
    from tests.conftest import shared_file

    m0 = meshio.read(shared_file("tet/kiefer_fea_bracket.vtu"))
    T10 = np.concatenate([c.data for c in m0.cells if c.type == "tetra10"])
    return mesh_from_arrays(np.asarray(m0.points, float), T10[:, :4])


def test_thin_wall_rows_remove_the_inversions_of_one_tet_thick_walls():
    """The issue's case: fixed lowest 10%, handle highest 10% moved 15% of the diagonal and turned 30°."""
    mesh = _kiefer_corners()
    spec = bend_spec(mesh)
    ax, diag = longest_axis(mesh)
    mv = {"handles": {"h": {"translation": (0.15 * diag * np.eye(3)[(ax + 1) % 3]).tolist(),
                            "rotation": {"axis": np.eye(3)[(ax + 2) % 3].tolist(), "angle_deg": 30}}}}
    paper = precompute(mesh, {**spec, "thin_walls": False})
    r0 = paper.solve(mv).report
    inv = np.asarray(r0["inverted_ids"])
    assert r0["inverted_elements"] >= 20  # 33 measured
    assert mesh.boundary[mesh.T[inv]].all(axis=1).sum() >= 10  # 13 in walls with no interior vertex
    d = precompute(mesh, spec)  # thin_walls on by default
    r1 = d.solve(mv).report
    assert r1["inverted_elements"] == 0 and r1["min_scaled_jacobian"] > 0.02
    # the rows only touch cross-wall edges of tets without an interior vertex
    E, w = d.data.walls.E, d.data.walls.w
    allb = mesh.T[mesh.boundary[mesh.T].all(axis=1)]
    edges = {tuple(sorted(e)) for t in allb for e in ((t[0], t[1]), (t[0], t[2]), (t[0], t[3]),
                                                         (t[1], t[2]), (t[1], t[3]), (t[2], t[3]))}
    assert {tuple(e) for e in E.tolist()} <= edges and (w > 0).all()
    F = mesh.F
    surface_edges = {tuple(sorted(e)) for f in F for e in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
    assert not ({tuple(e) for e in E.tolist()} & surface_edges)
