"""Hard constraints beyond fixed and handle vertices (ECLS §3-5, Form features §3).

Real data: ``tests/data/plate.inp``, a gmsh OCC plate with four holes
(``make_plate.py``); the holes' walls are the node sets HOLE1..HOLE4, nodes
exactly on cylinders of radius 6 with axes along z.
"""
from __future__ import annotations

import numpy as np
import pytest

from solver import ConstraintError, SpecError, precompute, read_mesh
from solver.linalg import factorization as fz
from tests.solver.plate import BEND, EXACT, HOLES, PLATE, RADIUS, diag, plate_spec


def _procrustes(P0, P):
    """Best similarity P ~ s R P0 + t: returns (max residual, s, R)."""
    a, b = P0 - P0.mean(0), P - P.mean(0)
    U, S, Vt = np.linalg.svd(a.T @ b)
    R = (U @ Vt).T
    s = S.sum() / (a ** 2).sum()
    return float(np.abs(b - s * a @ R.T).max()), s, R


def _radii(P, axis_point, axis_dir):
    d = P - axis_point
    return np.linalg.norm(d - np.outer(d @ axis_dir, axis_dir), axis=1)


@pytest.fixture(scope="module")
def plate():
    return read_mesh(PLATE)


def test_plate_hole_nodes_are_on_their_cylinders(plate):
    for k, (x, y) in HOLES.items():
        ids = plate.sets[f"HOLE{k}"]
        r = _radii(plate.V[ids], np.array([x, y, 0.0]), np.array([0, 0, 1.0]))
        assert np.abs(r - RADIUS).max() < 1e-9


@pytest.mark.parametrize("method", EXACT)
def test_rigid_holes_stay_circles_of_their_radius_and_scale_exactly(plate, method):
    spec = plate_spec(features=[{"selection": "hole1", "mode": "rigid", "name": "H1"},
                           {"selection": "hole2", "mode": "rigid", "name": "H2"},
                           {"selection": "hole3", "mode": "keep_direction", "name": "H3"},
                           {"selection": "hole4", "mode": "rigid", "name": "H4"}],
                 constraints={"method": method})
    d = precompute(plate, spec)
    n0 = fz.STATS["factorizations"]
    r = d.solve({**BEND, "features": {"H4": {"scale": 1.25}}})
    assert fz.STATS["factorizations"] == n0  # a feature scale is a MOVE, not a refactorization
    assert r.report["inverted_elements"] == 0
    P = r.V
    for k, s_expected in ((1, 1.0), (2, 1.0), (4, 1.25)):
        ids = plate.sets[f"HOLE{k}"]
        err, s, R = _procrustes(plate.V[ids], P[ids])
        assert err <= 1e-9 * RADIUS
        assert abs(s - s_expected) <= 1e-9
        # still a circle (every wall node on a cylinder) of radius s * 6 about the rotated axis
        c0 = np.array([*HOLES[k], 0.0])
        axis_pt = P[ids].mean(0) + s * R @ (c0 - plate.V[ids].mean(0))
        radii = _radii(P[ids], axis_pt, R @ np.array([0, 0, 1.0]))
        assert np.abs(radii / (s_expected * RADIUS) - 1).max() <= 1e-9
    # the moved holes really moved and turned (the test is not vacuous)
    ids1 = plate.sets["HOLE1"]
    assert np.linalg.norm(P[ids1] - plate.V[ids1], axis=1).min() > 0.1
    # keep_direction: the hole translates, its axis keeps its direction
    ids3 = plate.sets["HOLE3"]
    D = P[ids3] - plate.V[ids3]
    assert np.abs(D - D.mean(0)).max() <= 1e-9 * RADIUS
    assert np.linalg.norm(D.mean(0)) > 0.1


def test_without_features_the_holes_deform(plate):
    """The same bend without features distorts the holes: the features are what holds them."""
    r = precompute(plate, plate_spec()).solve(BEND)
    errs = [_procrustes(plate.V[plate.sets[f"HOLE{k}"]], r.V[plate.sets[f"HOLE{k}"]])[0] for k in HOLES]
    assert max(errs) > 1e-3


@pytest.mark.parametrize("method", EXACT)
@pytest.mark.parametrize("solve", ["auto", "joint"])
def test_on_plane_on_line_and_sliding_are_exact(plate, method, solve):
    spec = plate_spec(sliding=[{"selection": "bottom", "normal": [0, 0, 1]}],
                 motion=[{"name": "c1", "selection": "hole1", "plane": {"normal": [1, 1, 0]}},
                         {"name": "c2", "selection": "hole2", "line": {"direction": [0, 0, 1]}}],
                 constraints={"method": method}, solve=solve)
    d = precompute(plate, spec)
    n0 = fz.STATS["factorizations"]
    tol = 1e-12 * diag(plate)
    normal = np.array([1.0, 1.0, 0]) / np.sqrt(2)
    for k, (p1, p2) in enumerate((([50, 0, 0], [110, 30, 0]), ([56, 2, 3], [104, 25, 7]))):
        mv = {"handles": {"tip": {"translation": [4.0 * k, 3, 0],
                                  "rotation": {"axis": [0, 0, 1], "angle_deg": 8}}},
              "motion": {"c1": {"point": p1}, "c2": {"point": p2}}}
        P = d.solve(mv).V
        c1 = P[plate.sets["HOLE1"]].mean(0)
        c2 = P[plate.sets["HOLE2"]].mean(0)
        assert abs((c1 - p1) @ normal) <= tol
        assert np.abs(c2[:2] - np.array(p2[:2])).max() <= tol
        assert np.abs(P[plate.sets["BOTTOM"], 2]).max() <= tol
        # the sliding nodes do slide
        assert np.abs(P[plate.sets["BOTTOM"], :2] - plate.V[plate.sets["BOTTOM"], :2]).max() > 0.5
    assert fz.STATS["factorizations"] == n0


def test_sliding_nodes_that_are_also_fixed_are_redundant_not_conflicting(plate):
    spec = plate_spec(sliding=[{"selection": "bottom", "normal": [0, 0, 1]}])
    rep = precompute(plate, spec).solve(
        {"handles": {"tip": {"translation": [3, 1, 0]}}}).report
    both = np.intersect1d(plate.sets["BOTTOM"], np.union1d(plate.sets["FIXED"], plate.sets["LOAD"]))
    assert len(rep["redundant_constraints"]) == both.size
    assert {e["kind"] for e in rep["redundant_constraints"]} == {"sliding"}
    assert rep["conflicting_constraints"] == []
    # lifting the handle makes the same rows conflict: the handle wins, the conflict is named
    rep = precompute(plate, spec).solve({"handles": {"tip": {"translation": [0, 0, 2]}}}).report
    assert len(rep["conflicting_constraints"]) == np.intersect1d(both, plate.sets["LOAD"]).size
    assert all(abs(e["residual"] - 2) < 1e-9 for e in rep["conflicting_constraints"])
    assert rep["constraint_residual_max"] <= 1e-12 * diag(plate)


@pytest.mark.parametrize("method", EXACT)
def test_two_positions_for_one_vertex_conflict_and_the_rest_stays_exact(plate, method):
    v = int(plate.sets["FIXED"][5])
    spec = plate_spec(points=[{"name": "pull", "vertices": [v], "target": (plate.V[v] + [1, 0, 0]).tolist()}],
                 features=[{"selection": "hole1", "mode": "rigid", "name": "H1"}],
                 constraints={"method": method})
    r = precompute(plate, spec).solve(BEND)
    (c,) = r.report["conflicting_constraints"]
    assert (c["kind"], c["name"], c["index"], c["vertices"]) == ("point", "pull", 0, [v])
    assert abs(c["residual"] - 1.0) < 1e-9
    assert r.report["constraint_residual_max"] <= 1e-11 * diag(plate)
    # the fixed vertex, listed first, wins: to the bit by elimination, to round-off by KKT
    assert np.abs(r.V[v] - plate.V[v]).max() <= (0.0 if method == "null_space" else 1e-12 * diag(plate))
    assert np.isfinite(r.V).all()
    with pytest.raises(ConstraintError) as e:
        precompute(plate, {**spec, "conflicts": "reject"})
    assert e.value.code == "conflicting_constraints"
    assert e.value.details["conflicting_constraints"][0]["name"] == "pull"


def test_conflict_created_by_a_move_is_rejected_when_asked(plate):
    v = int(plate.sets["FIXED"][5])
    spec = plate_spec(points=[{"name": "p", "vertices": [v]}], conflicts="reject")
    d = precompute(plate, spec)  # consistent at rest: accepted
    assert d.solve(BEND).report["redundant_constraints"][0]["name"] == "p"
    with pytest.raises(ConstraintError) as e:
        d.solve({**BEND, "points": {"p": [0, 0, 0]}})
    assert e.value.code == "conflicting_constraints"
    assert e.value.details["report"]["conflicting_constraints"][0]["kind"] == "point"


def test_duplicated_constraint_is_redundant_and_changes_nothing(plate):
    feats = [{"selection": "hole1", "mode": "rigid", "name": "H1"}]
    base = precompute(plate, plate_spec(features=feats)).solve(BEND)
    dup = precompute(plate, plate_spec(features=feats + [{"selection": "hole1", "mode": "rigid",
                                                        "name": "H1again"}])).solve(BEND)
    kinds = {(e["system"], e["name"]) for e in dup.report["redundant_constraints"]}
    assert kinds == {("positions", "H1again"), ("rotations", "H1again")}
    assert dup.report["conflicting_constraints"] == []
    assert np.abs(dup.V - base.V).max() <= 1e-12 * diag(plate)


def test_points_on_edges_faces_and_relative_constraints(plate):
    i, j, k = (int(x) for x in plate.T[100, :3])
    a, b = (int(x) for x in plate.sets["HOLE2"][:2])
    spec = plate_spec(points=[{"name": "e", "edge": [i, j], "t": 0.25},
                         {"name": "f", "face": [i, j, k], "barycentric": [0.2, 0.3, 0.5]}],
                 relative=[{"name": "keep", "vertices": [a, b], "mode": "rotate"}], solve="joint")
    d = precompute(plate, spec)
    ue, uf = plate.V[i] + [1, 2, 0.5], plate.V[k] + [0.5, 0.5, 0.5]
    r = d.solve({**BEND, "points": {"e": ue.tolist(), "f": uf.tolist()}})
    P = r.V
    tol = 1e-11 * diag(plate)
    assert np.abs(0.25 * P[i] + 0.75 * P[j] - ue).max() <= tol
    assert np.abs(0.2 * P[i] + 0.3 * P[j] + 0.5 * P[k] - uf).max() <= tol
    assert abs(np.linalg.norm(P[a] - P[b]) - np.linalg.norm(plate.V[a] - plate.V[b])) <= tol
    # an explicit offset replaces the rotated one
    r = d.solve({"relative": {"keep": {"offset": [0, 0, 1]}}})
    assert np.abs(r.V[a] - r.V[b] - [0, 0, 1]).max() <= tol


def test_split_refuses_constraints_on_interior_vertices(plate):
    inner = int(np.flatnonzero(plate.interior)[0])
    spec = plate_spec(points=[{"name": "p", "vertices": [inner]}])
    with pytest.raises(SpecError) as e:
        precompute(plate, {**spec, "solve": "split"})
    assert "interior" in str(e.value)
    assert precompute(plate, spec).solve_mode == "joint"  # auto picks the joint solve


@pytest.mark.parametrize("bad, msg", [
    ({"features": [{"selection": "nope"}]}, "unknown selection"),
    ({"features": [{"selection": "hole1", "mode": "wobbly"}]}, "mode"),
    ({"points": [{"name": "p", "vertices": [1, 2], "weights": [1.0]}]}, "weights"),
    ({"points": [{"name": "p", "edge": [1, 2], "t": 2}]}, "SPEC.points[0].t: Input should be less than or equal to 1"),
    ({"points": [{"name": "p", "vertices": [10 ** 9]}]}, "out of range"),
    ({"motion": [{"name": "m", "selection": "hole1", "plane": {"normal": [0, 0, 0]}}]}, "non-zero"),
    ({"motion": [{"name": "m", "selection": "hole1"}]}, "plane or line"),
    ({"sliding": [{"selection": "bottom"}]}, "normal"),
    ({"conflicts": "ignore"}, "conflicts"),
])
def test_bad_constraint_specs_are_named(plate, bad, msg):
    with pytest.raises(SpecError) as e:
        precompute(plate, plate_spec(**bad))
    assert msg in str(e.value)


def test_move_names_must_exist(plate):
    d = precompute(plate, plate_spec(features=[{"selection": "hole1", "name": "H1"}]))
    with pytest.raises(SpecError, match="unknown features"):
        d.solve({"features": {"H9": {"scale": 2}}})
    with pytest.raises(SpecError, match="scale"):
        d.solve({"features": {"H1": {"scale": -1}}})


@pytest.mark.parametrize("mode", ["rigid", "keep_direction"])
def test_feature_on_a_real_scan_mesh(mode):
    """Armadillo13K (polyfem data): a mid-body patch of the surface kept rigid through a bend."""
    from tests.conftest import bend_spec, load, longest_axis, slab

    m = load("Armadillo13K.msh")
    ax, diag = longest_axis(m)
    spec = bend_spec(m)
    spec["selections"]["patch"] = slab(m, 0.45, 0.55, boundary_only=True)
    spec["features"] = [{"selection": "patch", "mode": mode, "name": "patch"}]
    axis = [0.0, 0.0, 0.0]
    axis[(ax + 1) % 3] = 1.0
    mv = {"handles": {"h": {"translation": (0.1 * diag * np.eye(3)[(ax + 2) % 3]).tolist(),
                            "rotation": {"axis": axis, "angle_deg": 30}}}}
    d = precompute(m, spec)
    P = d.solve(mv).V
    ids = d.data.constraints.blocks[[b.kind for b in d.data.constraints.blocks].index("feature")].vertices
    err, s, R = _procrustes(m.V[ids], P[ids])
    assert err <= 1e-9 * diag and abs(s - 1) <= 1e-9
    turned = np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)))
    if mode == "keep_direction":  # a pure translation
        D = P[ids] - m.V[ids]
        assert np.abs(D - D.mean(0)).max() <= 1e-9 * diag
    else:
        assert 1.0 < turned < 30.0  # it turns with the rotation field, part of the handle's 30°
    free = precompute(m, bend_spec(m)).solve(mv).V
    assert _procrustes(m.V[ids], free[ids])[0] > 1e-3 * diag  # without the feature the patch bends
