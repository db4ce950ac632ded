"""``GET /v1/meshes/{id}/symmetry``: the mirror planes and the deck's cyclic definitions ``tetmorph info`` lists.

Every check reads the mesh file again with meshio and works out the property with numpy and a
KD-tree: boundary nodes as the nodes of the faces one tetrahedron has, mirror images by the
reflection formula, the sector by turning face A about the deck's axis.
"""

from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np
from scipy.spatial import cKDTree

from tests.conftest import DATA, shared_file

from ..conftest import BEAM_SPEC, BRACKET, err

BEAM = DATA / "beam.node"  # TetGen; its .ele goes with it


def _boundary_ids(path: Path) -> np.ndarray:
    """The nodes of the faces that belong to one tetrahedron only."""
    m = meshio.read(path)
    T = np.concatenate([c.data[:, :4] for c in m.cells if c.type in ("tetra", "tetra10")])
    faces = np.sort(np.concatenate([T[:, [0, 1, 2]], T[:, [0, 1, 3]], T[:, [0, 2, 3]], T[:, [1, 2, 3]]]), axis=1)
    uniq, count = np.unique(faces, axis=0, return_counts=True)
    return np.unique(uniq[count == 1])


def _boundary_points(path: Path) -> np.ndarray:
    return np.asarray(meshio.read(path).points, float)[_boundary_ids(path)]


def _mirrored(P: np.ndarray, point, normal) -> np.ndarray:
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    return P - 2.0 * np.outer((P - np.asarray(point, float)) @ n, n)


def _turned(P: np.ndarray, point, direction, deg: float) -> np.ndarray:
    """``P`` turned by ``deg`` about the axis (Rodrigues)."""
    k = np.asarray(direction, float) / np.linalg.norm(direction)
    a = np.radians(deg)
    Q = P - np.asarray(point, float)
    Q = Q * np.cos(a) + np.cross(k, Q) * np.sin(a) + np.outer(Q @ k, k) * (1 - np.cos(a))
    return Q + np.asarray(point, float)


def test_a_mirrored_mesh_is_offered_the_planes_that_map_its_boundary_onto_itself(client, tc):
    mesh = client.upload_mesh(BEAM)  # a box meshed symmetrically: every boundary node has its mirror node
    r = tc.get(f"/v1/meshes/{mesh['id']}/symmetry")
    assert r.status_code == 200, r.text
    body = r.json()
    assert set(body) == {"planes", "cyclic"} and body["cyclic"] == []  # a TetGen mesh defines no sector
    assert client.symmetry(mesh["id"]) == body  # the Python client's call is the same route
    P = _boundary_points(BEAM)
    diag = float(np.linalg.norm(P.max(0) - P.min(0)))
    tree = cKDTree(P)
    normals = set()
    for c in body["planes"]:
        gap, _ = tree.query(_mirrored(P, c["plane"]["point"], c["plane"]["normal"]))
        assert gap.max() <= 1e-9 * diag, c  # each boundary node's image is a boundary node
        normals.add(tuple(np.round(np.abs(c["plane"]["normal"]), 12)))
    assert normals == {(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)}
    # and a plane that is not offered does not: turned 30 degrees about z through the same point
    c = body["planes"][0]["plane"]["point"]
    gap, _ = tree.query(_mirrored(P, c, [np.cos(np.radians(30)), np.sin(np.radians(30)), 0]))
    assert gap.max() > 0.01 * diag
    # the plane x = 0, as offered, keeps a morph of the beam symmetric
    x0 = next(c for c in body["planes"] if abs(c["plane"]["normal"][0]) == 1.0)
    entry = {k: x0[k] for k in ("name", "plane", "tolerance")}  # the SPEC.symmetry entry
    s = client.create_session(mesh["id"], {**BEAM_SPEC, "symmetry": [entry]})
    assert tc.get(f"/v1/sessions/{s['id']}").json()["spec"]["symmetry"] == [entry]
    V, rep = client.deform(s["id"], {"handles": {"tip": {"translation": [0.0, 0.0, 0.2]}}})
    assert rep["inverted_elements"] == 0
    B = np.asarray(V)[_boundary_ids(BEAM)]
    assert np.abs(B - _boundary_points(BEAM)).max() > 0.1  # it moved
    assert cKDTree(B).query(_mirrored(B, x0["plane"]["point"], x0["plane"]["normal"]))[0].max() < 1e-6


def test_a_deck_is_offered_its_mirror_planes_through_the_box_middle(client, tc):
    mesh = client.upload_mesh(BRACKET)  # a bar with a bolt hole, symmetric about y = 10 and z = 5
    planes = tc.get(f"/v1/meshes/{mesh['id']}/symmetry").json()["planes"]
    P = _boundary_points(BRACKET)
    mid, diag = (P.min(0) + P.max(0)) / 2, float(np.linalg.norm(P.max(0) - P.min(0)))
    assert sorted(tuple(np.abs(c["plane"]["normal"])) for c in planes) == [(0, 0, 1), (0, 1, 0)]
    tree = cKDTree(P)
    for c in planes:
        np.testing.assert_allclose(c["plane"]["point"], mid, atol=1e-9)
        assert 0 < c["tolerance"] < 0.01 * diag
        # gmsh did not mesh it mirrored: the images land between nodes, within an element of one
        assert tree.query(_mirrored(P, c["plane"]["point"], c["plane"]["normal"]))[0].max() < 0.05 * diag
    # along x it is not symmetric (the hole is at a third of the length): not offered
    assert tree.query(_mirrored(P, mid, [1, 0, 0]))[0].max() > 0.05 * diag


def test_a_deck_with_a_cyclic_tie_is_offered_its_sector(client, tc):
    deck = shared_file("tet/segmenttet.inp")  # *TIE, CYCLIC SYMMETRY of left, right; N=12 about x
    mesh = client.upload_mesh(deck)
    body = tc.get(f"/v1/meshes/{mesh['id']}/symmetry").json()
    (c,) = body["cyclic"]
    assert c["name"] == "T1" and c["faces"] == ["Nright", "Nleft"] and c["tolerance"] == 0.001
    assert c["axis"] == {"point": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, 0.0]}
    # the sign: face A turned by the angle lands on face B, turned the other way it does not
    m = meshio.read(deck)
    A, B = m.points[m.point_sets["Nright"]], m.points[m.point_sets["Nleft"]]
    tree = cKDTree(B)

    def gap(deg: float) -> float:
        return float(np.median(tree.query(_turned(A, c["axis"]["point"], c["axis"]["direction"], deg))[0]))

    assert abs(c["angle_deg"]) == 30.0
    assert gap(c["angle_deg"]) < 0.1 * gap(-c["angle_deg"])  # the faces do not match node for node
    # the entry goes into a session's SPEC with its faces as named sets
    spec = {"selections": {"Nright": {"set": "Nright"}, "Nleft": {"set": "Nleft"}}, "fixed": ["Nright"],
            "handles": {}, "cyclic": [c]}
    assert client.create_session(mesh["id"], spec)["id"]


def test_a_deck_without_a_tie_has_no_sector_and_surfaces_are_refused(client, tc, tmp_path):
    mesh = client.upload_mesh(DATA / "cones_with_cavities.inp")
    assert tc.get(f"/v1/meshes/{mesh['id']}/symmetry").json()["cyclic"] == []
    stl = tmp_path / "tet.stl"
    meshio.write(stl, meshio.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]),
                                  [("triangle", np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]))]),
                 binary=False)
    surf = client.upload_mesh(stl)
    r = tc.get(f"/v1/meshes/{surf['id']}/symmetry")
    assert r.status_code == 422
    e = err(r)
    assert e["code"] == "surface_not_volume" and e["details"]["field"] == "mesh_id"
    r = tc.get("/v1/meshes/m_0000000000000000/symmetry")
    assert r.status_code == 404 and err(r)["code"] == "mesh_not_found"
