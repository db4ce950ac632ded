"""Mirror and cyclic symmetry, non-matching ties, target surfaces and point-to-point relative constraints.

Every check is recomputed here from the output positions: mirrored and
rotated node pairs found by coordinates, and distances to triangles by a
brute-force projection written in this file.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from solver import ConstraintError, mesh_from_arrays, precompute, read_mesh
from tests.conftest import DATA, distance_to_triangles, shared_file
from tests.gmsh_parts import periodic_sector, symmetric_bar, two_blocks


# ------------------------------------------------------------------ mirror symmetry
@pytest.fixture(scope="module")
def bar():
    return mesh_from_arrays(*symmetric_bar(4.0))


def _bar_spec(**extra):
    return {"selections": {"fix": {"box": {"min": [-1, -1, -1], "max": [3, 21, 11]}},
                           "hole": {"sphere": {"center": [30, 10, 5], "radius": 8}, "boundary_only": True}},
            "fixed": ["fix"], "handles": {"h": "hole"},
            "symmetry": [{"name": "mid", "plane": {"point": [50, 0, 0], "normal": [1, 0, 0]}}], **extra}


def _mirror_pairs(m):
    mir = m.V * [-1, 1, 1] + [100, 0, 0]
    d, j = cKDTree(m.V).query(mir)
    ok = d < 1e-9
    return np.flatnonzero(ok), j[ok]


@pytest.mark.parametrize("method", ["null_space", "kkt"])
def test_a_handle_on_one_side_drives_its_mirror_image_exactly(bar, method):
    d = precompute(bar, _bar_spec(constraints={"method": method}))
    r = d.solve({"handles": {"h": {"translation": [0, 0, 3], "rotation": {"axis": [1, 0, 0], "angle_deg": 10}}}})
    diag = float(np.linalg.norm(bar.V.max(0) - bar.V.min(0)))
    i, j = _mirror_pairs(bar)
    assert i.size == bar.n  # every node has its mirror image in this mesh
    P = r.V
    err = np.linalg.norm(P[j] - (P[i] * [-1, 1, 1] + [100, 0, 0]), axis=1)
    on_boundary = bar.boundary[i]
    assert err[on_boundary].max() <= 1e-9 * diag
    assert err.max() <= 1e-6 * diag  # interior nodes follow (this mesh is exactly symmetric)
    moved = np.linalg.norm(P - bar.V, axis=1)
    assert moved[bar.V[:, 0] > 60].max() > 1.0  # the mirror side moved with the handle
    assert r.report["conflicting_constraints"] == [] and r.report["inverted_elements"] == 0


@pytest.fixture(scope="module")
def fine_bar():
    return mesh_from_arrays(*symmetric_bar(2.5))


def _all_pairs_error(m, P):
    """Largest |p_j - M p_i| over every node and its mirror image (found here by coordinates), per diagonal."""
    i, j = _mirror_pairs(m)
    assert i.size == m.n
    diag = float(np.linalg.norm(m.V.max(0) - m.V.min(0)))
    err = np.linalg.norm(P[j] - (P[i] * [-1, 1, 1] + [100, 0, 0]), axis=1) / diag
    return float(err[m.boundary[i]].max()), float(err[~m.boundary[i]].max())


@pytest.mark.parametrize("method", ["null_space", "kkt", "penalty"])
@pytest.mark.parametrize("precision", ["exact", "mixed"])
def test_every_node_inside_the_part_is_mirrored_too(fine_bar, method, precision):
    # fixed at one end only, through the thickness (interior nodes held), a handle box on one side only
    m = fine_bar
    spec = {"selections": {"end": {"box": {"min": [-1, -1, -1], "max": [3, 21, 11]}},
                           "block": {"box": {"min": [25, -1, -1], "max": [35, 21, 11]}}},
            "fixed": ["end"], "handles": {"h": "block"}, "precision": precision,
            "symmetry": [{"name": "mid", "plane": {"point": [50, 0, 0], "normal": [1, 0, 0]}}],
            "constraints": {"method": method}}
    assert (~m.boundary & (m.V[:, 0] < 3)).any()  # the fixed end holds interior nodes
    d = precompute(m, spec)
    r = d.solve({"handles": {"h": {"translation": [0, 0, 3], "rotation": {"axis": [1, 0, 0], "angle_deg": 10}}}})
    on_boundary, inside = _all_pairs_error(m, r.V)
    assert on_boundary <= 1e-9 and inside <= 1e-9
    far = m.V[:, 0] > 97
    assert np.abs(r.V[far] - m.V[far]).max() <= 1e-9 * 100  # the mirror image of the fixed end stays fixed
    assert r.report["inverted_elements"] == 0


def test_the_single_precision_interior_is_mirrored_exactly():
    m = mesh_from_arrays(*symmetric_bar(1.15))
    assert (~m.boundary).sum() > 5_000  # above LU_SMALL: the interior factor is single precision
    spec = {"selections": {"end": {"box": {"min": [-1, -1, -1], "max": [3, 21, 11]}},
                           "hole": {"sphere": {"center": [30, 10, 5], "radius": 8}, "boundary_only": True}},
            "fixed": ["end"], "handles": {"h": "hole"}, "precision": "mixed",
            "symmetry": [{"name": "mid", "plane": {"point": [50, 0, 0], "normal": [1, 0, 0]}}]}
    r = precompute(m, spec).solve({"handles": {"h": {"translation": [0, 0, 2]}}})
    assert r.report["interior_precision"] == "single"
    on_boundary, inside = _all_pairs_error(m, r.V)
    assert on_boundary <= 1e-9 and inside <= 1e-9


def test_a_move_that_breaks_the_symmetry_is_a_conflict(bar):
    spec = _bar_spec()
    spec["selections"]["hole2"] = {"sphere": {"center": [70, 10, 5], "radius": 8}, "boundary_only": True}
    spec["handles"]["g"] = "hole2"
    d = precompute(bar, spec)
    ok = d.solve({"handles": {"h": {"translation": [0, 0, 2]}, "g": {"translation": [0, 0, 2]}}})  # symmetric
    assert ok.report["conflicting_constraints"] == []
    bad = d.solve({"handles": {"h": {"translation": [2, 0, 0]}, "g": {"translation": [2, 0, 0]}}})  # not
    assert any(c["kind"] == "symmetry" for c in bad.report["conflicting_constraints"])
    rej = precompute(bar, {**spec, "conflicts": "reject"})
    with pytest.raises(ConstraintError) as e:
        rej.solve({"handles": {"h": {"translation": [2, 0, 0]}, "g": {"translation": [2, 0, 0]}}})
    assert e.value.code == "conflicting_constraints"


def test_a_wrong_plane_names_the_nodes_without_a_partner(bar):
    spec = _bar_spec()
    spec["symmetry"] = [{"name": "off", "plane": {"point": [48, 0, 0], "normal": [1, 0, 0]}}]
    with pytest.raises(ConstraintError, match=r"nodes find no partner") as e:
        precompute(bar, spec)
    assert e.value.code == "unmatched_nodes" and e.value.details["unmatched"] > 0


# ------------------------------------------------------------------ cyclic symmetry
def test_a_periodic_sector_keeps_its_cut_faces_matched():
    m = mesh_from_arrays(*periodic_sector(2.0, 30.0))
    a = math.radians(30.0)
    nb = [-math.sin(a), math.cos(a), 0.0]
    ang = np.degrees(np.arctan2(m.V[:, 1], m.V[:, 0]))
    top = np.flatnonzero((m.V[:, 2] > 7.99) & (ang > 3) & (ang < 27))  # off both cut faces
    spec = {"selections": {"A": {"plane": {"point": [0, 0, 0], "normal": [0, 1, 0], "tolerance": 1e-6}},
                           "B": {"plane": {"point": [0, 0, 0], "normal": nb, "tolerance": 1e-6}},
                           "inner": {"sphere": {"center": [0, 0, 4], "radius": 8.5}, "boundary_only": True},
                           "top": {"ids": top.tolist()}},
            "fixed": ["inner"], "handles": {"h": "top"},
            "cyclic": [{"name": "c", "axis": {"point": [0, 0, 0], "direction": [0, 0, 1]}, "angle_deg": 30.0,
                        "faces": ["A", "B"]}]}
    d = precompute(m, spec)
    R = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    A = np.flatnonzero(np.abs(m.V[:, 1]) < 1e-6)
    B = np.flatnonzero(np.abs(m.V @ np.array(nb)) < 1e-6)
    dist, j = cKDTree(m.V[B]).query(m.V[A] @ R.T)
    assert (dist < 1e-6).all() and len(A) == len(B)  # matching faces
    diag = float(np.linalg.norm(m.V.max(0) - m.V.min(0)))
    for mv in ({"handles": {"h": {"translation": [0, 0, 2]}}},  # axisymmetric push
               {"handles": {"h": {"rotation": {"axis": [1, 0, 0], "angle_deg": 8}}}}):  # tilt
        r = d.solve(mv)
        gap = np.linalg.norm(r.V[B[j]] - r.V[A] @ R.T, axis=1).max()
        assert gap <= 1e-9 * diag
        assert r.report["conflicting_constraints"] == [] and r.report["inverted_elements"] == 0


_TURN = math.radians(30.0)
_R30 = np.array([[math.cos(_TURN), -math.sin(_TURN), 0], [math.sin(_TURN), math.cos(_TURN), 0], [0, 0, 1]])


def _sector_spec(V, turn, method, precision):
    """Inner wall fixed, the top face off both cut faces a handle; the sector turned by ``turn`` (3, 3)."""
    na = turn @ np.array([0.0, 1.0, 0.0])
    nb = turn @ np.array([-math.sin(_TURN), math.cos(_TURN), 0.0])
    local = V @ turn  # the sector's own frame
    ang = np.degrees(np.arctan2(local[:, 1], local[:, 0]))
    top = np.flatnonzero((V[:, 2] > 7.99) & (ang > 3) & (ang < 27))
    return {"selections": {"A": {"plane": {"point": [0, 0, 0], "normal": na.tolist(), "tolerance": 1e-6}},
                           "B": {"plane": {"point": [0, 0, 0], "normal": nb.tolist(), "tolerance": 1e-6}},
                           "inner": {"sphere": {"center": [0, 0, 4], "radius": 8.5}, "boundary_only": True},
                           "top": {"ids": top.tolist()}},
            "fixed": ["inner"], "handles": {"h": "top"}, "precision": precision,
            "constraints": {"method": method},
            "cyclic": [{"name": "c", "axis": {"point": [0, 0, 0], "direction": [0, 0, 1]}, "angle_deg": 30.0,
                        "faces": ["A", "B"]}]}


def _cut_face_pairs(V):
    """Every node of face A and its partner on face B (found here by coordinates)."""
    A = np.flatnonzero(np.abs(V[:, 1]) < 1e-6)
    B = np.flatnonzero(np.abs(V @ np.array([-math.sin(_TURN), math.cos(_TURN), 0.0])) < 1e-6)
    dist, j = cKDTree(V[B]).query(V[A] @ _R30.T)
    assert len(A) == len(B) and dist.max() < 1e-9
    return A, B[j]


#: Axisymmetric moves of the top face: a push along the axis and a turn about it.
_AXISYMMETRIC = ({"handles": {"h": {"translation": [0, 0, 2]}}},
                 {"handles": {"h": {"rotation": {"axis": [0, 0, 1], "angle_deg": 4}}}})


@pytest.fixture(scope="module")
def fine_sector():
    return periodic_sector(0.55, 30.0)


@pytest.mark.parametrize("method", ["null_space", "kkt", "penalty"])
@pytest.mark.parametrize("precision", ["exact", "mixed"])
def test_every_cut_face_pair_and_the_interior_of_a_sector_are_periodic(fine_sector, method, precision):
    """All pairs ``p_b = R p_a``; and the neighbour sector (the mesh turned by R) under the same
    axisymmetric move is this sector's result turned by R at every node, interior included, so
    that the sectors expand into one continuous ring."""
    V, T = fine_sector
    m, turned = mesh_from_arrays(V, T), mesh_from_arrays(V @ _R30.T, T)
    a, b = _cut_face_pairs(V)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    d = precompute(m, _sector_spec(V, np.eye(3), method, precision))
    d2 = precompute(turned, _sector_spec(V @ _R30.T, _R30, method, precision))
    for mv in _AXISYMMETRIC:
        r, r2 = d.solve(mv), d2.solve(mv)
        assert np.linalg.norm(r.V[b] - r.V[a] @ _R30.T, axis=1).max() <= 1e-9 * diag
        turned_back = np.linalg.norm(r2.V - r.V @ _R30.T, axis=1)
        assert turned_back[~m.boundary].max() <= 1e-9 * diag and turned_back.max() <= 1e-9 * diag
        assert np.abs(r.V - m.V).max() > 0.1  # it did move
        assert r.report["inverted_elements"] == 0


def test_a_sector_with_a_single_precision_interior_keeps_every_pair():
    V, T = periodic_sector(0.4, 30.0)
    m = mesh_from_arrays(V, T)
    assert (~m.boundary).sum() > 5_000  # above LU_SMALL: the interior factor is single precision
    a, b = _cut_face_pairs(V)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    d = precompute(m, _sector_spec(V, np.eye(3), "null_space", "mixed"))
    for mv in _AXISYMMETRIC:
        r = d.solve(mv)
        assert r.report["interior_precision"] == "single"
        assert np.linalg.norm(r.V[b] - r.V[a] @ _R30.T, axis=1).max() <= 1e-9 * diag


def _segment():
    mesh = read_mesh(shared_file("tet/segmenttet.inp"))
    left, right = mesh.sets["Nleft"], mesh.sets["Nright"]
    # the model's own *CYCLIC SYMMETRY MODEL line: 12 sectors about the x axis
    best = None
    for sign in (1, -1):  # which way turns the right face onto the left one
        a = math.radians(sign * 30.0)
        R = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
        img = mesh.V[right] @ R.T
        d = cKDTree(mesh.V[left]).query(img)[0].max()
        if best is None or d < best[0]:
            best = (d, sign * 30.0, R)
    return mesh, left, right, best[1], best[2]


def test_segmenttet_cut_faces_stay_cyclic_with_incompatible_meshes():
    mesh, left, right, angle, R = _segment()
    diag = float(np.linalg.norm(mesh.V.max(0) - mesh.V.min(0)))
    radius = np.linalg.norm(mesh.V[:, 1:], axis=1)
    on_b = np.zeros(mesh.n, bool)
    on_b[left] = True  # face B follows face A: no fixed or handle node of its own
    spec = {"selections": {"A": {"set": "Nright"}, "B": {"set": "Nleft"},
                           "hub": {"ids": np.flatnonzero((radius <= radius.min() + 0.02 * diag) & ~on_b).tolist()},
                           "rim": {"ids": np.flatnonzero((radius >= radius.max() - 0.02 * diag) & ~on_b).tolist()}},
            "fixed": ["hub"], "handles": {"h": "rim"},
            "cyclic": [{"name": "sector", "axis": {"point": [0, 0, 0], "direction": [1, 0, 0]}, "angle_deg": angle,
                        "faces": ["A", "B"], "tolerance": 1e-3}]}
    d = precompute(mesh, spec)
    # independent: each node of the left face is the turned image of a node of the right face (a matched
    # pair within the tie's tolerance: corner nodes pair with corner nodes, mid-side nodes with any) or of
    # a point of the right face's boundary triangles (found here at rest by projection on their plane)
    nodes_a = np.zeros(mesh.n, bool)
    nodes_a[right] = True
    Fa = mesh.F[nodes_a[mesh.F].all(axis=1)]
    pre = mesh.V[left] @ R  # R^T p
    corner_r = right[mesh.referenced[right]]
    near_c, which_c = cKDTree(mesh.V[corner_r]).query(pre)
    near_a, which_a = cKDTree(mesh.V[right]).query(pre)
    ref = []
    for k, p in enumerate(pre):
        corner = mesh.referenced[left[k]]
        near, node = (near_c[k], corner_r[which_c[k]]) if corner else (near_a[k], right[which_a[k]])
        if near <= 1e-3:
            ref.append((k, np.array([node] * 3), np.array([1.0, 0.0, 0.0])))
            continue
        for f in Fa:
            a, b, c = mesh.V[f]
            n = np.cross(b - a, c - a)
            q = p - ((p - a) @ n) / (n @ n) * n
            w = np.array([np.cross(c - b, q - b) @ n, np.cross(a - c, q - c) @ n, 0.0]) / (n @ n)
            w[2] = 1 - w[0] - w[1]
            if (w >= -1e-9).all():
                ref.append((k, f, w))
                break
    assert len(ref) == len(left)
    for mv in ({"handles": {"h": {"translation": [0.02 * diag, 0, 0]}}},
               {"handles": {"h": {"rotation": {"axis": [0, 1, 0], "angle_deg": 3}}}}):
        P = d.solve(mv).V
        gap = max(np.linalg.norm(P[left[k]] - R @ (w @ P[f])) for k, f, w in ref)
        assert gap <= 1e-9 * diag
    spec["cyclic"][0]["angle_deg"] = angle * 2 / 3
    with pytest.raises(ConstraintError) as e:
        precompute(mesh, spec)
    assert e.value.code == "unmatched_nodes"


# ------------------------------------------------------------------ non-matching ties
def test_an_independently_meshed_interface_stays_closed_after_a_bend():
    V, T, body = two_blocks()
    m = mesh_from_arrays(V, T)
    iface = np.abs(V[:, 2] - 10.0) < 1e-9
    low = np.flatnonzero(iface & (body == 0))
    high = np.flatnonzero(iface & (body == 1))
    assert cKDTree(V[low]).query(V[high])[0].max() > 0.1  # the two sides do not match
    base = {"selections": {"low": {"ids": low.tolist()}, "high": {"ids": high.tolist()},
                           "floor": {"box": {"min": [-1, -1, -1], "max": [41, 21, 0.01]}},
                           "roof": {"box": {"min": [-1, -1, 19.99], "max": [41, 21, 21]}}},
            "fixed": ["floor"], "handles": {"h": "roof"}}
    mv = {"handles": {"h": {"translation": [4, 0, 0], "rotation": {"axis": [0, 1, 0], "angle_deg": 15}}}}
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    in_low = np.zeros(len(V), bool)
    in_low[low] = True

    def gap(P):
        F = m.F[in_low[m.F].all(axis=1)]
        return max(distance_to_triangles(P[i], P[F[:, 0]], P[F[:, 1]], P[F[:, 2]]) for i in high)

    tied = precompute(m, {**base, "ties": {"surface": [["high", "low"]]}}).solve(mv)
    assert gap(tied.V) <= 1e-9 * diag
    assert tied.report["inverted_elements"] == 0
    loose = precompute(m, {**base, "ties": False}).solve(mv)
    assert gap(loose.V) > 1e-3 * diag  # without the tie the interface opens
    for method in ("null_space", "kkt", "penalty"):  # every method, both precisions: every tied node
        for precision in ("exact", "mixed"):
            spec = {**base, "ties": {"surface": [["high", "low"]]}, "precision": precision,
                    "constraints": {"method": method}}
            r = precompute(m, spec).solve(mv)
            assert gap(r.V) <= 1e-9 * diag, (method, precision)


# ------------------------------------------------------------------ target surfaces
@pytest.fixture(scope="module")
def plate():
    return read_mesh(DATA / "plate.inp")


def _top_surface(m):
    on = np.zeros(m.n, bool)
    on[m.sets["TOP"]] = True
    F = m.F[on[m.F].all(axis=1)]
    used = np.unique(F)
    remap = np.full(m.n, -1)
    remap[used] = np.arange(used.size)
    return m.V[used].copy(), remap[F]


@pytest.mark.parametrize("kind", ["bump", "twist", "scan"])
def test_the_selection_lands_on_its_target_surface(plate, kind, rng):
    TV, TF = _top_surface(plate)
    x, y = TV[:, 0], TV[:, 1]
    if kind == "bump":
        TV[:, 2] += 3.0 * np.exp(-((x - 80) ** 2 + (y - 40) ** 2) / 30.0**2)
    elif kind == "twist":
        TV[:, 2] += (y - 40) * np.tan(np.radians(4.0)) * (x / 160.0)
    else:  # a scan-like copy: the surface with noise, finer than the mesh
        TV[:, 2] += 0.5 + rng.normal(0.0, 0.05, len(TV))
    nodes = np.setdiff1d(plate.sets["TOP"], plate.sets["FIXED"])  # the clamped edge stays clamped
    spec = {"selections": {"top": {"ids": nodes.tolist()}, "fix": {"set": "FIXED"}},
            "fixed": ["fix"], "handles": {},
            "targets": [{"name": "skin", "selection": "top", "surface": {"vertices": TV.tolist(),
                                                                        "triangles": TF.tolist()}}]}
    d = precompute(plate, spec)
    diag = float(np.linalg.norm(plate.V.max(0) - plate.V.min(0)))
    r = d.solve({"targets": {"skin": {"amount": 1.0}}})
    assert r.report["conflicting_constraints"] == []
    far = max(distance_to_triangles(r.V[i], TV[TF[:, 0]], TV[TF[:, 1]], TV[TF[:, 2]]) for i in nodes[::7])
    assert far <= 1e-6 * diag
    rep = r.report["targets"]["skin"]
    assert rep["max_distance"] <= 1e-6 * diag and rep["iterations"] >= 1 and rep["nodes"] == nodes.size
    assert r.report["inverted_elements"] == 0
    half = d.solve({"targets": {"skin": {"amount": 0.5}}})
    np.testing.assert_allclose(half.V[nodes], 0.5 * (plate.V[nodes] + r.V[nodes]), atol=1e-9 * diag)


# ------------------------------------------------------------------ relative points
def test_one_hole_centre_keeps_its_offset_to_another(plate):
    spec = {"selections": {"fix": {"set": "FIXED"}, "load": {"set": "LOAD"}, "h1": {"set": "HOLE1"},
                           "h2": {"set": "HOLE2"}},
            "fixed": ["fix"], "handles": {"tip": "load"},
            "relative": [{"name": "pitch", "points": [{"selection": "h2"}, {"selection": "h1"}],
                          "mode": "translate"}]}
    d = precompute(plate, spec)
    off = [60.0, 3.0, 0.0]
    r = d.solve({"handles": {"tip": {"translation": [0, 0, 5]}}, "relative": {"pitch": {"offset": off}}})
    c1, c2 = r.V[plate.sets["HOLE1"]].mean(0), r.V[plate.sets["HOLE2"]].mean(0)
    np.testing.assert_allclose(c2 - c1, off, atol=1e-9 * 160)
