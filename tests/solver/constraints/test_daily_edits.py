"""The daily edits as exact constraints: radius, twist, map, offset and lattice.

Every property is measured here from the solved positions with a few lines of numpy: radii about
the axis, angles about it, distances to the geometry, displacements along normals, Bernstein sums.
The parts are tests/data/plate.inp (a 160 x 80 x 4 plate with four bores of radius 6, sets FIXED,
LOAD, TOP, BOTTOM, HOLE1..4) and small gmsh parts meshed here.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver import SpecError, precompute, read_mesh
from solver.mesh import mesh_from_arrays
from solver.testing import cube_mesh
from tests.conftest import load
from tests.gmsh_parts import _arrays

#: HOLE1's axis: the plate's first bore, along z (tests/data/make_plate.py).
BORE = np.array([160.0 / 3.0, 80.0 / 3.0, 0.0])
Z = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def plate():
    return load("plate.inp")


def diagonal(mesh) -> float:
    return float(np.linalg.norm(mesh.V.max(axis=0) - mesh.V.min(axis=0)))


def about(P: np.ndarray, point: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Axial coordinate, radius and angle of points about an axis (angle from a fixed radial direction)."""
    X = P - point
    s = X @ axis
    W = X - np.outer(s, axis)
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    return s, np.linalg.norm(W, axis=1), np.arctan2(W @ e2, W @ e1)


def turn(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The signed angle from ``a`` to ``b``, in (-pi, pi]."""
    return np.angle(np.exp(1j * (b - a)))


def bore_spec(**extra) -> dict:
    return {"selections": {"clamp": {"set": "FIXED"}, "hole1": {"set": "HOLE1"}}, "fixed": ["clamp"],
            "radius": [{"name": "bore", "selection": "hole1",
                        "axis": {"point": BORE.tolist(), "direction": [0, 0, 1]}}], **extra}


def refused(call, *args, **kwargs) -> SpecError:
    with pytest.raises(SpecError) as e:
        call(*args, **kwargs)
    return e.value


def plate_with_bore(path, order: int = 2, size: float = 3.0) -> None:
    """A 40 x 20 x 6 block with a bore of radius 4 along z at (20, 10), physical surfaces FIXED (x = 0) and BORE."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        box = occ.addBox(0, 0, 0, 40, 20, 6)
        cyl = occ.addCylinder(20, 10, -1, 0, 0, 8, 4)
        occ.cut([(3, box)], [(3, cyl)])
        occ.synchronize()
        groups: dict[str, list[int]] = {"FIXED": [], "BORE": []}
        for dim, tag in gmsh.model.getEntities(2):
            x, y, z = occ.getCenterOfMass(dim, tag)
            if abs(x) < 1e-6:
                groups["FIXED"].append(tag)
            elif math.hypot(x - 20, y - 10) < 5 and 0.1 < z < 5.9:
                groups["BORE"].append(tag)
        for name, tags in groups.items():
            gmsh.model.addPhysicalGroup(2, tags, name=name)
        gmsh.model.addPhysicalGroup(3, [t for _, t in gmsh.model.getEntities(3)], name="SOLID")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def shaft(size: float = 2.5, radius: float = 5.0, length: float = 40.0):
    """A cylinder of ``radius`` along z from z = 0 to ``length``, meshed in tets: a mesh."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addCylinder(0, 0, 0, 0, 0, length, radius)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        V, T = _arrays(gmsh)
    finally:
        gmsh.finalize()
    return mesh_from_arrays(V, T)


# ------------------------------------------------------------------------------------------------ radius
@pytest.mark.parametrize("solve", ["split", "joint"])
def test_every_bore_node_goes_to_the_new_radius_keeping_its_height_and_angle(plate, solve):
    d = precompute(plate, bore_spec(solve=solve, precision="exact"))
    ids = d.data.constraints.sel_ids["hole1"]
    s0, r0, a0 = about(plate.V[ids], BORE, Z)
    for move, want in (({"radius": 7.5}, np.full(ids.size, 7.5)), ({"delta": -0.75}, r0 - 0.75)):
        r = d.solve({"radius": {"bore": move}})
        s, rad, ang = about(r.V[ids], BORE, Z)
        assert np.abs(rad - want).max() <= 1e-12 * 6.0
        assert np.abs(s - s0).max() <= 1e-12 * 6.0 and np.abs(turn(a0, ang)).max() <= 1e-12
        assert r.report["constraint_residual_max"] <= 1e-12 * diagonal(plate)
        assert r.report["inverted_elements"] == 0 and r.report["solve_mode"] == solve
        assert r.report["max_handle_displacement"] == pytest.approx(np.abs(want - r0).max(), rel=1e-9)
    others = np.setdiff1d(np.flatnonzero(plate.referenced), ids)
    grown = d.solve({"radius": {"bore": {"radius": 7.5}}}).V
    assert np.abs(grown[others] - plate.V[others]).max() > 0.1  # the part around the bore follows
    np.testing.assert_array_equal(d.solve({"radius": {"bore": {"delta": 0.0}}}).V, plate.V)  # rest, bit for bit
    half = d.scaled_move({"radius": {"bore": {"radius": 8.0}}}, 0.25)  # a clamped radius: one cylinder still
    r0n = d.data.constraints.edits[0].nominal
    assert half.to_dict()["radius"] == {"bore": {"radius": pytest.approx(r0n + 0.25 * (8.0 - r0n))}}
    _, rad, _ = about(d.solve(half).V[ids], BORE, Z)
    assert np.abs(rad - (r0n + 0.25 * (8.0 - r0n))).max() <= 1e-12 * 6.0


def test_the_axis_is_fitted_to_the_bore_when_not_given(plate):
    spec = bore_spec()
    del spec["radius"][0]["axis"]
    d = precompute(plate, spec)
    e = d.data.constraints.edits[0]
    assert abs(abs(float(e.direction @ Z)) - 1.0) <= 1e-9
    off = e.point - BORE
    assert np.linalg.norm(off - (off @ Z) * Z) <= 1e-6 and e.nominal == pytest.approx(6.0, rel=1e-6)
    ids = d.data.constraints.sel_ids["hole1"]
    _, rad, _ = about(d.solve({"radius": {"bore": {"radius": 5.0}}}).V[ids], e.point, e.direction)
    assert np.abs(rad - 5.0).max() <= 1e-12 * 5.0
    flat = refused(precompute, plate, {**spec, "selections": {**spec["selections"], "hole1": {"set": "TOP"}}})
    assert flat.code == "not_a_cylinder" and flat.details["field"] == "radius[0]"


def test_the_rest_radius_is_stated_with_the_parameter_that_sets_it(plate):
    spec = bore_spec(twist=[{"name": "t", "selection": "hole2", "axis": {"point": [0, 0, 0], "direction": [1, 0, 0]}}])
    spec["selections"]["hole2"] = {"set": "HOLE2"}
    d = precompute(plate, spec)
    ids = d.data.constraints.sel_ids["hole1"]
    _, r0, _ = about(plate.V[ids], BORE, Z)  # measured here: the mean radius of the bore's nodes
    assert d.edit_dimensions == [{"kind": "radius", "name": "bore", "parameter": "radius",
                                  "rest": pytest.approx(float(r0.mean()), rel=1e-12)}]  # a twist has none


def test_nodes_on_the_axis_are_refused():
    mesh = mesh_from_arrays(*cube_mesh(2))  # nodes at 0, 0.5, 1: the axis x = y = 0.5 holds some
    spec = {"selections": {"skin": {"box": {"min": [0, 0, 0], "max": [1, 1, 1]}, "boundary_only": True}},
            "radius": [{"name": "r", "selection": "skin", "axis": {"point": [0.5, 0.5, 0], "direction": [0, 0, 2]}}]}
    e = refused(precompute, mesh, spec)
    on = np.flatnonzero((np.abs(mesh.V[:, 0] - 0.5) < 1e-12) & (np.abs(mesh.V[:, 1] - 0.5) < 1e-12) & mesh.boundary)
    assert e.code == "node_on_axis" and e.details["field"] == "radius[0]"
    assert sorted(e.details["ids"]) == on.tolist() and "SPEC.radius[0] ('r')" in e.message


def test_quadratic_mid_side_nodes_land_on_the_new_cylinder(tmp_path):
    plate_with_bore(tmp_path / "bore.msh", order=2)
    mesh = read_mesh(tmp_path / "bore.msh")
    assert mesh.T10 is not None
    d = precompute(mesh, {"selections": {"clamp": {"set": "FIXED"}, "bore": {"set": "BORE"}}, "fixed": ["clamp"],
                          "radius": [{"name": "b", "selection": "bore",
                                      "axis": {"point": [20, 10, 0], "direction": [0, 0, 1]}}]})
    ids = d.data.constraints.sel_ids["bore"]
    mid = ids[~mesh.referenced[ids]]
    assert mid.size > 50  # the bore's set holds its faces' mid-side nodes
    r = d.solve({"radius": {"b": {"radius": 4.6}}})
    _, rad, _ = about(r.V[ids], np.array([20.0, 10.0, 0.0]), Z)
    assert np.abs(rad - 4.6).max() <= 1e-12 * 4.6
    assert r.report["constraint_residual_max"] <= 1e-12 * diagonal(mesh) and r.report["inverted_elements"] == 0


def test_bad_radius_moves_are_named(plate):
    d = precompute(plate, bore_spec())
    cases = [({"radius": {"hole": {"radius": 7.0}}}, "MOVE.radius", "invalid_spec"),
             ({"radius": {"bore": {"radius": 7.0, "delta": 1.0}}}, "MOVE.radius.bore", "invalid_spec"),
             ({"radius": {"bore": {"radius": -1.0}}}, "MOVE.radius.bore.radius", "invalid_spec"),
             ({"radius": {"bore": {"delta": -6.5}}}, "MOVE.radius.bore.delta", "invalid_spec"),
             ({"radius": {"bore": {"delta": 1e6}}}, "MOVE.radius.bore.delta", "out_of_range"),
             ({"radius": {"bore": {"radius": True}}}, "MOVE.radius.bore.radius", "invalid_spec")]
    for move, field, code in cases:
        e = refused(d.solve, move)
        assert (e.details.get("field"), e.code) == (field, code), (move, e)
    bad = bore_spec()
    bad["radius"][0]["selection"] = "nothing"
    assert refused(precompute, plate, bad).details["field"] == "SPEC.radius[0]"
    bad = bore_spec(handles={"h": "hole1"})
    e = refused(precompute, plate, bad)
    assert e.code == "overlapping_constraints" and "SPEC.radius[0] ('bore')" in e.message
    twice = bore_spec()
    twice["radius"] = twice["radius"] * 2
    assert refused(precompute, plate, twice).details["field"] == "radius"


# ------------------------------------------------------------------------------------------------- twist
@pytest.fixture(scope="module")
def rod():
    return shaft()


def twist_spec(**extra) -> dict:
    return {"selections": {"skin": {"box": {"min": [-6, -6, -1], "max": [6, 6, 41]}, "boundary_only": True}},
            "twist": [{"name": "shaft", "selection": "skin", "axis": {"point": [0, 0, 0], "direction": [0, 0, 1]}}],
            **extra}


def test_a_linear_twist_of_a_shaft_is_exact_on_every_handle_node(rod):
    d = precompute(rod, twist_spec(precision="exact"))
    ids = d.data.constraints.sel_ids["skin"]
    ends = ids[(rod.V[ids, 2] < 1e-9) | (rod.V[ids, 2] > 40 - 1e-9)]
    assert ends.size > 20 and ids.size > ends.size + 100  # both end faces and the lateral surface
    s0, r0, a0 = about(rod.V[ids], np.zeros(3), Z)
    rate = 1.5  # degrees per unit length: 60 degrees over the shaft
    r = d.solve({"twist": {"shaft": {"angle_deg_per_length": rate}}})
    s, rad, ang = about(r.V[ids], np.zeros(3), Z)
    off = r0 > 1e-9  # a node on the axis has no angle
    assert np.abs(turn(a0, ang)[off] - np.radians(rate * s0[off])).max() <= 1e-12
    assert np.abs(rad - r0).max() <= 1e-12 * 5 and np.abs(s - s0).max() <= 1e-12 * 40
    assert r.report["constraint_residual_max"] <= 1e-12 * diagonal(rod)
    assert r.report["inverted_elements"] == 0
    inner = np.flatnonzero(rod.interior)
    assert np.abs(r.V[inner] - rod.V[inner]).max() > 0.1  # the interior follows


def test_a_twist_table_is_interpolated_linearly_and_held_beyond_its_ends(rod):
    d = precompute(rod, twist_spec())
    ids = d.data.constraints.sel_ids["skin"]
    table = [{"at": 10.0, "angle_deg": 0.0}, {"at": 25.0, "angle_deg": 30.0}, {"at": 30.0, "angle_deg": 20.0}]
    r = d.solve({"twist": {"shaft": {"table": table}}})
    s0, r0, a0 = about(rod.V[ids], np.zeros(3), Z)
    want = np.interp(s0, [10, 25, 30], [0, 30, 20])
    off = r0 > 1e-9
    assert np.abs(turn(a0, about(r.V[ids], np.zeros(3), Z)[2])[off] - np.radians(want[off])).max() <= 1e-12
    e = refused(d.solve, {"twist": {"shaft": {"table": table[::-1]}}})
    assert e.details["field"] == "MOVE.twist.shaft"
    e = refused(d.solve, {"twist": {"shaft": {"angle_deg_per_length": 100.0}}})  # 4000 degrees at the far end
    assert e.details["field"] == "MOVE.twist.shaft.angle_deg_per_length" and e.code == "invalid_spec"
    e = refused(d.solve, {"twist": {"shaft": {"table": [{"at": 0.0, "angle_deg": 4000.0}]}}})
    assert e.details["field"] == "MOVE.twist.shaft.table[0].angle_deg" and e.code == "invalid_spec"



def test_a_linear_bend_lays_the_shaft_on_a_circular_arc_with_rigid_cross_sections(rod):
    d = precompute(rod, twist_spec(twist=[{"name": "shaft", "selection": "skin", "mode": "bend", "toward": [1, 0, 0.3],
                                           "axis": {"point": [0, 0, 0], "direction": [0, 0, 1]}}]))
    ids = d.data.constraints.sel_ids["skin"]
    rate = 1.5  # 60 degrees over the shaft: its axis a circular arc of radius 1 / kappa about the bend axis
    kappa = math.radians(rate)
    r = d.solve({"twist": {"shaft": {"angle_deg_per_length": rate}}})
    x, y, s = rod.V[ids].T
    X = r.V[ids] - [1 / kappa, 0, 0]  # from the centre of curvature, on the bend axis (along y)
    R0 = 1 / kappa - x  # each fibre's radius: shorter toward the centre
    want = np.c_[-R0 * np.cos(kappa * s), y, R0 * np.sin(kappa * s)]
    assert np.abs(X - want).max() <= 1e-12 * (1 / kappa)
    assert r.report["constraint_residual_max"] <= 1e-12 * diagonal(rod) and r.report["inverted_elements"] == 0
    table = [{"at": 10.0, "angle_deg": 0.0}, {"at": 30.0, "angle_deg": 20.0}]
    t = d.solve({"twist": {"shaft": {"table": table}}})
    straight = ids[s <= 10.0]  # no turn before 10: unmoved
    assert np.abs(t.V[straight] - rod.V[straight]).max() <= 1e-12 * diagonal(rod)
    past = ids[s >= 30.0]  # past 30 the axis runs straight again, turned by 20 degrees: rigidly
    P, P0 = t.V[past], rod.V[past]
    a = math.radians(20.0)
    turned = np.c_[P0[:, 0] * math.cos(a) + P0[:, 2] * math.sin(a), P0[:, 1],
                   -P0[:, 0] * math.sin(a) + P0[:, 2] * math.cos(a)]  # z turned toward x about y, and moved
    assert np.ptp(P - turned, axis=0).max() <= 1e-12 * diagonal(rod)
    e = refused(precompute, rod, twist_spec(twist=[{"name": "shaft", "selection": "skin", "mode": "bend",
                                                     "toward": [0, 0, 2], "axis": {"point": [0, 0, 0],
                                                                                    "direction": [0, 0, 1]}}]))
    assert e.details["field"] == "SPEC.twist" and "along the axis" in e.message

# --------------------------------------------------------------------------------------------------- map
def distance_to(geometry: dict, P: np.ndarray) -> np.ndarray:
    """Distance of each point to a line, circle, plane, cylinder or sphere, measured here."""
    (kind, g), = geometry.items()
    if kind == "sphere":
        return np.abs(np.linalg.norm(P - g["center"], axis=1) - g["radius"])
    if kind == "plane":
        n = np.asarray(g["normal"], float) / np.linalg.norm(g["normal"])
        return np.abs((P - g["point"]) @ n)
    axis = np.asarray(g.get("direction") or g.get("axis") or g.get("normal"), float)
    axis /= np.linalg.norm(axis)
    s, r, _ = about(P, np.asarray(g.get("point") or g.get("center"), float), axis)
    if kind == "line":
        return r
    if kind == "cylinder":
        return np.abs(r - g["radius"])
    return np.hypot(s, r - g["radius"])  # circle


#: (selection, geometry, projection) on the plate: its bore, its top face, a rim of the bore.
MAPS = [
    ("hole1", {"cylinder": {"point": BORE.tolist(), "axis": [0, 0, 1], "radius": 6.5}}, {}),
    ("hole1", {"cylinder": {"point": (BORE + [0.3, -0.2, 0]).tolist(), "axis": [0.05, 0, 1], "radius": 6.5}},
     {"projection": "along", "direction": [1, 0.2, 0]}),
    ("top", {"plane": {"point": [0, 0, 4.5], "normal": [0.02, -0.01, 1]}}, {}),
    ("top", {"plane": {"point": [0, 0, 4.5], "normal": [0, 0.03, 1]}}, {"projection": "along", "direction": [0, 0, 1]}),
    ("top", {"sphere": {"center": [80, 40, -400], "radius": 404.5}}, {}),
    ("top", {"sphere": {"center": [80, 40, -400], "radius": 404.5}}, {"projection": "along", "direction": [0, 0, 1]}),
    ("rim", {"circle": {"center": (BORE + [0, 0, 4]).tolist(), "normal": [0, 0, 1], "radius": 6.4}}, {}),
    ("rim", {"line": {"point": (BORE + [0, 0, 4]).tolist(), "direction": [1, 0.5, 0]}}, {}),
]


@pytest.mark.parametrize("selection, geometry, projection", MAPS,
                         ids=[f"{g and next(iter(g))}-{p.get('projection', 'nearest')}" for _, g, p in MAPS])
def test_mapped_nodes_lie_on_the_geometry(plate, selection, geometry, projection):
    rim = np.intersect1d(plate.sets["HOLE1"], plate.sets["TOP"])
    top = np.setdiff1d(plate.sets["TOP"], plate.sets["FIXED"])  # a node both fixed and mapped is refused
    spec = {"selections": {"clamp": {"set": "FIXED"}, "hole1": {"set": "HOLE1"}, "top": {"ids": top.tolist()},
                           "rim": {"ids": rim.tolist()}}, "fixed": ["clamp"],
            "map": [{"name": "m", "selection": selection, "geometry": geometry, **projection}]}
    d = precompute(plate, spec)
    ids = d.data.constraints.sel_ids[selection]
    diag = diagonal(plate)
    r = d.solve({"map": {"m": {"amount": 1.0}}})
    assert distance_to(geometry, r.V[ids]).max() <= 1e-12 * diag
    assert r.report["constraint_residual_max"] <= 1e-12 * diag
    if projection.get("projection") == "along":  # moved along the direction only
        u = np.asarray(projection["direction"], float) / np.linalg.norm(projection["direction"])
        dx = r.V[ids] - plate.V[ids]
        assert np.abs(dx - np.outer(dx @ u, u)).max() <= 1e-12 * diag
    half = d.solve({"map": {"m": {"amount": 0.5}}}).V[ids]
    assert np.abs(half - 0.5 * (plate.V[ids] + r.V[ids])).max() <= 1e-12 * diag
    np.testing.assert_array_equal(d.solve({}).V, plate.V)


def test_maps_that_have_no_point_are_refused(plate):
    base = {"selections": {"clamp": {"set": "FIXED"}, "top": {"set": "TOP"}}, "fixed": ["clamp"]}
    e = refused(precompute, plate, {**base, "map": [{"name": "m", "selection": "top", "geometry": {
        "plane": {"point": [0, 0, 5], "normal": [0, 0, 1]}}}]})
    assert e.code == "overlapping_constraints" and "SPEC.map[0] ('m')" in e.message
    base["fixed"] = []
    along_circle = {"name": "m", "selection": "top", "projection": "along", "direction": [0, 0, 1],
                    "geometry": {"circle": {"center": [0, 0, 0], "normal": [0, 0, 1], "radius": 1.0}}}
    e = refused(precompute, plate, {**base, "map": [along_circle]})
    assert e.details["field"] == "SPEC.map" and "SPEC.map[0]" in e.message and "surface" in e.message
    miss = {"name": "m", "selection": "top", "projection": "along", "direction": [1, 0, 0],
            "geometry": {"sphere": {"center": [80, 40, 100], "radius": 5.0}}}
    e = refused(precompute, plate, {**base, "map": [miss]})
    assert e.code == "no_intersection" and e.details["field"] == "map[0]" and len(e.details["ids"]) > 0
    centre = plate.sets["TOP"][0]
    at_centre = {"name": "m", "selection": "top", "geometry": {"sphere": {"center": plate.V[centre].tolist(),
                                                                          "radius": 5.0}}}
    e = refused(precompute, plate, {**base, "map": [at_centre]})
    assert e.code == "node_on_axis" and e.details["ids"] == [int(centre)]
    two = {"name": "m", "selection": "top", "geometry": {"plane": {"point": [0, 0, 0], "normal": [0, 0, 1]},
                                                          "sphere": {"center": [0, 0, 0], "radius": 1.0}}}
    assert refused(precompute, plate, {**base, "map": [two]}).details["field"] == "SPEC.map[0].geometry"


# ------------------------------------------------------------------------------------------------ offset
def face_normals(mesh, ids: np.ndarray) -> np.ndarray:
    """Unit area-weighted outward normals of nodes ``ids`` from the boundary faces whose corners are all in ``ids``."""
    inside = np.zeros(mesh.n, bool)
    inside[ids] = True
    F = mesh.F[inside[mesh.F].all(axis=1)]
    fn = np.cross(mesh.V[F[:, 1]] - mesh.V[F[:, 0]], mesh.V[F[:, 2]] - mesh.V[F[:, 0]])
    N = np.zeros((mesh.n, 3))
    for j in range(3):
        np.add.at(N, F[:, j], fn)
    return N[ids] / np.linalg.norm(N[ids], axis=1)[:, None]


def wall_spec(spec: dict | None = None, **offset) -> dict:
    return {"selections": {"top": {"set": "TOP"}, "bottom": {"set": "BOTTOM"}},
            "offset": [{"name": "wall", "selection": "top", "opposite": "bottom", **offset}], **(spec or {})}


def test_a_planar_face_moves_by_exactly_the_distance_and_its_opposite_stays(plate):
    d = precompute(plate, wall_spec())
    top, bottom = plate.sets["TOP"], plate.sets["BOTTOM"]
    assert d.data.constraints.edits[0].planar
    r = d.solve({"offset": {"wall": {"distance": 0.5}}})
    diag = diagonal(plate)
    assert np.abs(r.V[top] - plate.V[top] - [0, 0, 0.5]).max() <= 1e-12 * diag
    np.testing.assert_array_equal(r.V[bottom], plate.V[bottom])
    assert r.report["constraint_residual_max"] <= 1e-12 * diag and r.report["inverted_elements"] == 0
    s = precompute(plate, wall_spec(symmetric=True)).solve({"offset": {"wall": {"distance": 0.5}}})
    assert np.abs(s.V[top] - plate.V[top] - [0, 0, 0.25]).max() <= 1e-12 * diag
    assert np.abs(s.V[bottom] - plate.V[bottom] + [0, 0, 0.25]).max() <= 1e-12 * diag  # -d/2 along the top's normal


def test_a_curved_face_moves_along_each_nodes_area_weighted_normal(plate):
    d = precompute(plate, {"selections": {"clamp": {"set": "FIXED"}, "hole1": {"set": "HOLE1"}}, "fixed": ["clamp"],
                           "offset": [{"name": "wall", "selection": "hole1"}]})
    assert not d.data.constraints.edits[0].planar
    ids = plate.sets["HOLE1"]
    r = d.solve({"offset": {"wall": {"distance": 0.4}}})
    assert np.abs(r.V[ids] - plate.V[ids] - 0.4 * face_normals(plate, ids)).max() <= 1e-12 * diagonal(plate)
    _, rad, _ = about(r.V[ids], BORE, Z)
    assert rad.max() < 6.0 - 0.35  # the normals point into the bore, out of the solid: the bore narrows
    assert r.report["inverted_elements"] == 0


def test_an_inverting_edit_is_reported_and_clamped_to_its_safe_fraction(plate):
    d = precompute(plate, wall_spec({"inversion": "clamp"}))
    move = {"offset": {"wall": {"distance": -5.0}}}  # through the 4 mm plate
    warn = d.solve(move, inversion="warn")
    assert warn.report["inverted_elements"] > 0 and 0.5 < warn.report["safe_fraction"] < 0.8
    r = d.solve(move)
    f = r.report["applied_fraction"]
    assert r.report["clamped"] and f == r.report["safe_fraction"] == warn.report["safe_fraction"]
    assert r.report["inverted_elements"] == 0 and r.report["inverted_elements_unclamped"] > 0
    top = plate.sets["TOP"]
    assert np.abs(r.V[top] - plate.V[top] - [0, 0, -5.0 * f]).max() <= 1e-12 * diagonal(plate)
    assert r.move.to_dict()["offset"] == {"wall": {"distance": -5.0 * f}}
    np.testing.assert_array_equal(d.solve(r.move.to_dict()).V, r.V)


# ----------------------------------------------------------------------------------------------- lattice
def bernstein_sum(P: np.ndarray, lo, hi, counts, displacements: dict) -> np.ndarray:
    """``sum B_i(u) B_j(v) B_k(w) d_ijk`` at points ``P``, written out here."""
    u = (P - np.asarray(lo, float)) / (np.asarray(hi, float) - lo)
    out = np.zeros_like(P)
    for key, dv in displacements.items():
        idx = [int(c) for c in key.split(",")]
        w = np.ones(len(P))
        for axis, (i, n) in enumerate(zip(idx, counts, strict=True)):
            w *= math.comb(n - 1, i) * u[:, axis] ** i * (1 - u[:, axis]) ** (n - 1 - i)
        out += np.outer(w, dv)
    return out


def test_a_morph_volume_moves_the_boundary_nodes_inside_its_box(plate):
    lo, hi, counts = [100.0, -1.0, -1.0], [161.0, 81.0, 5.0], [3, 2, 2]
    d = precompute(plate, {"selections": {"clamp": {"set": "FIXED"}}, "fixed": ["clamp"],
                           "lattice": [{"name": "tip", "box": {"min": lo, "max": hi}, "counts": counts}]})
    inside = np.all((plate.V >= lo) & (plate.V <= hi), axis=1)
    ids = np.flatnonzero(inside & plate.boundary)
    np.testing.assert_array_equal(d.data.constraints.edits[0].nodes, ids)
    disp = {"2,0,1": [0.0, 0.0, 6.0], "2,1,1": [0.0, 0.0, 6.0], "1,1,0": [2.0, 1.0, 0.0]}
    r = d.solve({"lattice": {"tip": {"displacements": disp}}})
    diag = diagonal(plate)
    assert np.abs(r.V[ids] - plate.V[ids] - bernstein_sum(plate.V[ids], lo, hi, counts, disp)).max() <= 1e-12 * diag
    assert r.report["constraint_residual_max"] <= 1e-12 * diag and r.report["inverted_elements"] == 0
    inner = np.flatnonzero(inside & ~plate.boundary & plate.referenced)
    assert inner.size and np.abs(r.V[inner] - plate.V[inner]).max() > 0.5  # the interior follows
    np.testing.assert_array_equal(d.solve({"lattice": {"tip": {"displacements": {}}}}).V, plate.V)
    e = refused(d.solve, {"lattice": {"tip": {"displacements": {"3,0,0": [0, 0, 1]}}}})
    assert e.details["field"] == "MOVE.lattice.tip.displacements" and "'3,0,0'" in e.message
    e = refused(d.solve, {"lattice": {"tip": {"displacements": {"a,0,0": [0, 0, 1]}}}})
    assert e.details["field"].startswith("MOVE.lattice.tip.displacements")
    e = refused(d.solve, {"lattice": {"tip": {"displacements": {"0,0,0": [0, 0, 1e6]}}}})
    assert e.code == "out_of_range" and e.details["field"] == "MOVE.lattice.tip.displacements.0,0,0"


def test_a_morph_volume_takes_a_selection_inside_its_box(plate):
    spec = {"selections": {"clamp": {"set": "FIXED"}, "top": {"set": "TOP"}}, "fixed": ["clamp"],
            "lattice": [{"name": "tip", "box": {"min": [-1, -1, -1], "max": [161, 81, 5]}, "counts": [2, 2, 1],
                         "selection": "top"}]}
    e = refused(precompute, load("plate.inp"), spec)  # TOP shares the clamp's edge
    assert e.code == "overlapping_constraints"
    top = np.setdiff1d(plate.sets["TOP"], plate.sets["FIXED"])
    spec["selections"]["top"] = {"ids": top.tolist()}
    d = precompute(plate, spec)
    r = d.solve({"lattice": {"tip": {"displacements": {"1,1,0": [0, 0, 2.0]}}}})
    want = 2.0 * (plate.V[top, 0] + 1) / 162 * (plate.V[top, 1] + 1) / 82  # degree 0 along z: no z dependence
    assert np.abs(r.V[top, 2] - plate.V[top, 2] - want).max() <= 1e-12 * diagonal(plate)
    spec["lattice"][0]["box"] = {"min": [-1, -1, -1], "max": [80, 81, 5]}
    e = refused(precompute, plate, spec)
    assert e.code == "bad_selection" and e.details["field"] == "lattice[0]"
    spec["lattice"][0]["box"] = {"min": [0, 0, 0], "max": [80, 81, 0]}
    assert "positive extent" in refused(precompute, plate, spec).message


def test_specs_and_moves_with_edits_read_back_as_written(plate):
    from solver import parse_move, parse_spec

    spec = parse_spec({
        "selections": {"clamp": {"set": "FIXED"}, "hole1": {"set": "HOLE1"}, "top": {"set": "TOP"},
                       "bottom": {"set": "BOTTOM"}, "end": {"set": "LOAD"}},
        "fixed": ["clamp"],
        "radius": [{"name": "bore", "selection": "hole1"}],
        "twist": [{"name": "tip", "selection": "end", "mode": "bend", "toward": [0, 0, 1],
                   "axis": {"point": [0, 40, 2], "direction": [1, 0, 0]}}],
        "map": [{"name": "dome", "selection": "top", "geometry": {"sphere": {"center": [80, 40, -400], "radius": 404}},
                 "projection": "along", "direction": [0, 0, 1]}],
        "offset": [{"name": "wall", "selection": "top", "opposite": "bottom", "symmetric": True}],
        "lattice": [{"name": "box", "box": {"min": [0, 0, 0], "max": [1, 1, 1]}, "counts": [2, 3, 4]}]})
    again = parse_spec(spec.to_dict())
    assert again.edits == spec.edits and [e.kind for e in spec.edits] == ["radius", "twist", "map", "offset", "lattice"]
    doc = {"radius": {"bore": {"delta": 0.5}}, "twist": {"tip": {"table": [{"at": 0.0, "angle_deg": 1.0}]}},
           "map": {"dome": {"amount": 0.5}}, "offset": {"wall": {"distance": -1.0}},
           "lattice": {"box": {"displacements": {"1,2,3": [0.0, 0.0, 1.0]}}}}
    mv = parse_move(doc, [], spec.names)
    assert mv.to_dict() == {"handles": {}, **doc}


def test_a_radius_that_would_swallow_a_held_neighbouring_bore_is_clamped_short_of_it(plate):
    free = precompute(plate, bore_spec()).solve({"radius": {"bore": {"radius": 30.0}}}, inversion="warn")
    held = plate.sets["HOLE3"]  # nothing holds it here: it is pushed aside, and so is the long edge at y = 0
    assert free.report["inverted_elements"] == 0
    assert np.linalg.norm(free.V[held] - plate.V[held], axis=1).min() > 1.0 and free.V[:, 1].min() < -1.0
    spec = bore_spec(inversion="clamp")
    spec["selections"]["neighbour"] = {"set": "HOLE3"}  # 26.67 mm from HOLE1's axis, radius 6
    spec["fixed"] = ["clamp", "neighbour"]
    d = precompute(plate, spec)
    move = {"radius": {"bore": {"radius": 30.0}}}  # would reach across the neighbour
    warn = d.solve(move, inversion="warn")
    assert warn.report["inverted_elements"] > 0 and 0 < warn.report["safe_fraction"] < 1
    r = d.solve(move)
    f = r.report["applied_fraction"]
    assert r.report["clamped"] and f == warn.report["safe_fraction"] and r.report["inverted_elements"] == 0
    ids, held = plate.sets["HOLE1"], plate.sets["HOLE3"]
    _, rad, _ = about(r.V[ids], BORE, Z)
    assert np.abs(rad - (6.0 + f * (30.0 - 6.0))).max() <= 1e-12 * 30.0  # the stated fraction of the change
    np.testing.assert_array_equal(r.V[held], plate.V[held])
    gap = np.linalg.norm(r.V[ids][:, None, :2] - r.V[held][None, :, :2], axis=2).min()
    assert gap > 0  # the bore stops short of its held neighbour
