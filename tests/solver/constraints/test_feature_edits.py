"""A fillet's radius, the distance and the angle between two features, as exact constraints.

The part is an L bracket meshed here by gmsh (tests/gmsh_parts.py): flanges 6 thick, an inner fillet
of radius 5 about x = y = 11 between the faces y = 6 (INNER_H) and x = 6 (INNER_V), a bore of radius 3
along x through the vertical flange, its end FIXED (x = 60) and LOAD (y = 50). Every property is
measured here from the solved positions: radii about the new axis, distances to the fitted planes,
centroids, plane normals fitted by SVD, the rotation of the moving feature fitted by Kabsch.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver import SpecError, precompute, read_mesh
from tests.gmsh_parts import filleted_bracket

R0, T = 5.0, 6.0


@pytest.fixture(scope="module", params=[1, 2], ids=["tet4", "tet10"])
def bracket(request, tmp_path_factory):
    path = tmp_path_factory.mktemp("bracket") / f"bracket{request.param}.msh"
    filleted_bracket(path, size=3.0, order=request.param)
    return read_mesh(path)


def sets(*names: str) -> dict:
    return {n.lower(): {"set": n} for n in names}


def fillet_spec(**extra) -> dict:
    return {"selections": sets("FIXED", "FILLET", "INNER_H", "INNER_V"), "fixed": ["fixed"],
            "fillet": [{"name": "corner", "selection": "fillet", "faces": ["inner_h", "inner_v"]}], **extra}


def refused(call, *args, **kwargs) -> SpecError:
    with pytest.raises(SpecError) as e:
        call(*args, **kwargs)
    return e.value


def plane_normal(P: np.ndarray) -> np.ndarray:
    """The unit normal of the plane fitted to points (k, 3) by SVD."""
    return np.linalg.svd(P - P.mean(axis=0))[2][2]


def kabsch(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """The rotation R with Q - mean(Q) = R (P - mean(P)), least squares."""
    H = (P - P.mean(axis=0)).T @ (Q - Q.mean(axis=0))
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    return Vt.T @ D @ U.T


# ----------------------------------------------------------------------------------------------- fillet
def test_fillet_nodes_land_on_the_new_arc_and_the_faces_stay_on_their_planes(bracket):
    d = precompute(bracket, fillet_spec())
    ids = d.data.constraints.sel_ids["fillet"]
    h, v = d.data.constraints.sel_ids["inner_h"], d.data.constraints.sel_ids["inner_v"]
    P0 = bracket.V[ids]
    assert (bracket.T10 is None) == bool(bracket.referenced[ids].all())  # tet10: mid-side nodes among them
    frac0 = np.arctan2(T + R0 - P0[:, 0], T + R0 - P0[:, 1]) / (np.pi / 2)  # 0 on y = 6, 1 on x = 6
    for move, r in (({"radius": 7.0}, 7.0), ({"radius": 3.5}, 3.5), ({"delta": 1.5}, R0 + 1.5)):
        res = d.solve({"fillet": {"corner": move}})
        P, c = res.V[ids], T + r  # the new axis: x = y = 6 + r, at r from both faces
        assert np.abs(np.hypot(P[:, 0] - c, P[:, 1] - c) - r).max() <= 1e-12 * r
        frac = np.arctan2(c - P[:, 0], c - P[:, 1]) / (np.pi / 2)
        assert np.abs(frac - np.clip(frac0, 0, 1)).max() <= 1e-9 and np.abs(P[:, 2] - P0[:, 2]).max() <= 1e-12
        assert np.abs(res.V[h, 1] - T).max() <= 1e-12 * 60 and np.abs(res.V[v, 0] - T).max() <= 1e-12 * 60
        assert res.report["inverted_elements"] == 0 and res.report["constraint_residual_max"] <= 1e-12 * 80
        near = h[np.abs(bracket.V[h, 0] - (T + R0)) < 1e-9]  # the rest tangent line slides with the fillet
        np.testing.assert_allclose(res.V[near, 0], c, atol=1e-12 * 60)
    half = d.scaled_move({"fillet": {"corner": {"radius": 9.0}}}, 0.5)
    assert half.to_dict()["fillet"]["corner"]["radius"] == pytest.approx(R0 + 0.5 * (9.0 - R0), rel=1e-9)


def test_fillet_refusals_name_their_cause(bracket):
    d = precompute(bracket, fillet_spec())
    e = refused(d.solve, {"fillet": {"corner": {"radius": 50.0}}})
    assert e.code == "fillet_too_large" and e.details["field"] == "MOVE.fillet.corner.radius"
    assert e.details["bound"] == pytest.approx(44.0, rel=1e-6)  # the vertical face reaches 44 from the corner
    e = refused(d.solve, {"fillet": {"corner": {"delta": -6.0}}})
    assert e.details["field"] == "MOVE.fillet.corner.delta" and "positive" in e.message
    spec = fillet_spec()
    spec["selections"]["bore"] = {"set": "BORE"}
    spec["fillet"][0]["faces"] = ["inner_h", "bore"]
    e = refused(precompute, bracket, spec)
    assert e.code == "not_planar" and e.details["field"] == "fillet[0]" and e.details["face"] == "bore"
    spec["selections"]["outer_h"] = {"set": "OUTER_H"}
    spec["fillet"][0]["faces"] = ["inner_h", "outer_h"]
    assert refused(precompute, bracket, spec).code == "parallel_faces"
    spec["selections"]["more"] = {"box": {"min": [0, 0, 0], "max": [60, 20, 20]}, "boundary_only": True}
    spec["fillet"][0].update(selection="more", faces=["inner_h", "inner_v"])
    e = refused(precompute, bracket, spec)
    assert e.code == "off_arc" and e.details["field"] == "fillet[0]" and len(e.details["ids"]) > 0
    assert "two selections" in refused(precompute, bracket, {**spec, "fillet": [
        {"name": "c", "selection": "fillet", "faces": ["inner_h", "inner_h"]}]}).message


# --------------------------------------------------------------------------------------------- distance
def test_a_bore_moves_rigidly_to_the_distance_asked(bracket):
    spec = {"selections": sets("FIXED", "BORE", "LOAD", "FILLET"), "fixed": ["fixed"],
            "distance": [{"name": "pitch", "selection": "bore", "reference": "load"}]}
    d = precompute(bracket, spec)
    b, ld = d.data.constraints.sel_ids["bore"], d.data.constraints.sel_ids["load"]
    rest = np.linalg.norm(bracket.V[b].mean(axis=0) - bracket.V[ld].mean(axis=0))
    assert d.data.constraints.edits[0].nominal == pytest.approx(rest, rel=1e-12) and abs(rest - 15.0) < 0.1
    res = d.solve({"distance": {"pitch": {"distance": 13.0}}})
    got = np.linalg.norm(res.V[b].mean(axis=0) - res.V[ld].mean(axis=0))
    assert abs(got - 13.0) <= 1e-12 * 15 and res.report["inverted_elements"] == 0
    move = res.V[b] - bracket.V[b]
    assert np.abs(move - move[0]).max() <= 1e-12 and np.abs(res.V[ld] - bracket.V[ld]).max() == 0.0
    spec["distance"] = [{"name": "height", "selection": "bore", "reference": "fillet", "direction": [0, 2, 0]}]
    d = precompute(bracket, spec)
    res = d.solve({"distance": {"height": {"delta": -3.0}}})
    h = d.data.constraints.sel_ids["fillet"]
    got = res.V[b, 1].mean() - res.V[h, 1].mean()
    assert abs(got - (bracket.V[b, 1].mean() - bracket.V[h, 1].mean() - 3.0)) <= 1e-12 * 30
    np.testing.assert_allclose(res.V[b][:, [0, 2]], bracket.V[b][:, [0, 2]], atol=1e-13)
    overlap = {**spec, "distance": [{"name": "x", "selection": "bore", "reference": "bore"}]}
    assert "another selection than" in refused(precompute, bracket, overlap).message


# ------------------------------------------------------------------------------------------------ angle
def test_a_face_turns_rigidly_to_the_angle_asked(bracket):
    spec = {"selections": sets("FIXED", "LOAD"),  # the reference, held at rest, holds the part
            "angle": [{"name": "tilt", "selection": "load", "reference": "fixed"}]}
    d = precompute(bracket, spec)
    ld, fx = d.data.constraints.sel_ids["load"], d.data.constraints.sel_ids["fixed"]
    assert d.data.constraints.edits[0].nominal == pytest.approx(90.0, abs=1e-9)
    for move, want in (({"angle_deg": 97.0}, 97.0), ({"delta_deg": -4.0}, 86.0)):
        res = d.solve({"angle": {"tilt": move}})
        a, b = plane_normal(res.V[ld]), plane_normal(res.V[fx])
        a, b = a * np.sign(a[1]), b * np.sign(b[0])  # outward: LOAD's +y, FIXED's +x (a few degrees off)
        got = math.degrees(math.acos(float(a @ b)))
        assert abs(got - want) <= 1e-9 and res.report["inverted_elements"] == 0
        Rm = kabsch(bracket.V[ld], res.V[ld])  # rigid: the face's shape is kept
        assert np.abs((bracket.V[ld] - bracket.V[ld].mean(0)) @ Rm.T - (res.V[ld] - res.V[ld].mean(0))).max() <= 1e-12
        np.testing.assert_allclose(res.V[ld].mean(axis=0), bracket.V[ld].mean(axis=0), atol=1e-12)  # about it
    e = refused(d.solve, {"angle": {"tilt": {"angle_deg": 181.0}}})
    assert e.details["field"] == "MOVE.angle.tilt.angle_deg"
    assert "exactly one of angle_deg" in refused(d.solve, {"angle": {"tilt": {}}}).message


def test_a_bore_axis_turns_about_a_given_axis(bracket):
    spec = {"selections": sets("FIXED", "BORE"),
            "angle": [{"name": "skew", "selection": "bore", "reference": "fixed"}]}
    e = refused(precompute, bracket, spec)  # the bore's axis is parallel to FIXED's normal: no cross product
    assert e.code == "parallel_features" and e.details["field"] == "angle[0]"
    spec["angle"][0]["axis"] = [0, 0, 1]
    d = precompute(bracket, spec)
    b = d.data.constraints.sel_ids["bore"]
    assert d.data.constraints.edits[0].nominal == pytest.approx(0.0, abs=1e-6)
    res = d.solve({"angle": {"skew": {"angle_deg": 8.0}}})
    Rm = kabsch(bracket.V[b], res.V[b])
    axis = Rm @ np.array([1.0, 0.0, 0.0])  # the bore's axis at rest is x
    assert abs(math.degrees(math.acos(axis[0])) - (8.0 - d.data.constraints.edits[0].nominal)) <= 1e-9
    assert abs(axis[2]) <= 1e-12 and res.report["inverted_elements"] == 0
    spec["angle"][0]["axis"] = [1, 0, 0]
    assert refused(precompute, bracket, spec).code == "axis_does_not_turn"
    spec["angle"][0]["axis"] = [1, 0, 1]  # turning x about (1, 0, 1) reaches 0 to 90 degrees from x
    d = precompute(bracket, spec)
    e = refused(d.solve, {"angle": {"skew": {"angle_deg": 120.0}}})
    assert e.code == "angle_out_of_reach" and e.details["bound"][1] == pytest.approx(90.0, abs=1e-6)
    res = d.solve({"angle": {"skew": {"angle_deg": 40.0}}})
    axis = kabsch(bracket.V[b], res.V[b]) @ np.array([1.0, 0.0, 0.0])
    assert abs(math.degrees(math.acos(axis[0])) - 40.0) <= 1e-9
