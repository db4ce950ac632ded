"""Validation: flat tets at rest are recorded, vertex manifoldness is checked, open surfaces pass."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from solver import mesh_from_arrays, read_mesh
from solver.errors import InvalidMeshError, TopologyError
from solver.testing import cube_mesh
from solver.validity.quality import signed_volumes
from tests.conftest import DATA, shared_file
from tests.gmsh_parts import sheet_panel


def _oriented(V, T):
    T = np.array(T, dtype=np.int64)
    neg = signed_volumes(V, T) < 0
    T[neg] = T[neg][:, [0, 2, 1, 3]]
    return T


def _flat_on_face(mesh, lift: float = 0.0):
    """The plate with one more tet on two coplanar boundary triangles of its z = 0 face (a flat
    tet at rest, as mesh generators leave on planar faces); ``lift`` raises its fourth node."""
    F, V = mesh.F, mesh.V
    onz = F[np.all(np.abs(V[F][:, :, 2]) < 1e-12, axis=1)]
    for i, f in enumerate(onz):
        for g in onz[i + 1:]:
            shared = np.intersect1d(f, g)
            if shared.size == 2:
                d = int(np.setdiff1d(g, f)[0])
                V2 = V.copy()
                V2[d, 2] += lift
                T = np.vstack([mesh.T, _oriented(V2, [[*f, d]])])
                return V2, T
    raise AssertionError("no two coplanar triangles")


def test_flat_tet_at_rest_loads_and_is_listed(tmp_path):
    plate = read_mesh(DATA / "plate.inp")
    V, T = _flat_on_face(plate)
    vol = signed_volumes(V, T)
    assert vol[-1] == 0 and np.median(vol[:-1]) > 1  # one flat tet among tets of volume ~8
    m = mesh_from_arrays(V, T, sets=plate.sets)
    assert m.degenerate_at_rest.tolist() == [len(T) - 1]
    info = m.info()
    assert info["degenerate_at_rest"] == {"count": 1, "ids": [len(T) - 1]}
    # from a file, as an upload: the same
    p = tmp_path / "plate_flat.inp"
    meshio.write(p, meshio.Mesh(V, [("tetra", T)]))
    assert read_mesh(p).info()["degenerate_at_rest"]["ids"] == [len(T) - 1]


def test_nearly_flat_tet_of_the_issue_loads():
    """Volume 4.5e-13 next to tets of volume ~2: flat to working precision, not inverted."""
    plate = read_mesh(DATA / "plate.inp")
    base = _flat_on_face(plate)[1][-1]
    h = -1.0  # down, out of the plate: the flat tet stays outside it
    for _ in range(60):  # the lift that gives a volume near 4.5e-13
        V, T = _flat_on_face(plate, lift=h)
        if abs(signed_volumes(V, T)[-1]) <= 4.5e-13:
            break
        h /= 2
    vol = signed_volumes(V, T)
    assert 0 < abs(vol[-1]) <= 4.5e-13 and set(T[-1]) == set(base)
    m = mesh_from_arrays(V, T)
    assert m.degenerate_at_rest.tolist() == [len(T) - 1]


def test_negative_volume_at_rest_is_still_refused():
    V, T = cube_mesh(2)
    T = T.copy()
    T[3] = T[3][[0, 2, 1, 3]]
    with pytest.raises(InvalidMeshError) as e:
        mesh_from_arrays(V, T)
    assert e.value.code == "inverted_input" and e.value.details["tets"] == [3]


def test_bow_tie_is_a_non_manifold_vertex():
    """The bracket with a tet touching it at one boundary corner only."""
    m = read_mesh(DATA / "bracket.inp")
    corner = int(np.argmin(np.linalg.norm(m.V - m.V.min(0), axis=1)))
    p = m.V[corner]
    V = np.vstack([m.V, p + [[-1, 0, 0], [0, -1, 0], [0, 0, -1]]])
    T = np.vstack([m.T, _oriented(V, [[corner, m.n, m.n + 1, m.n + 2]])])
    with pytest.raises(TopologyError) as e:
        mesh_from_arrays(V, T)
    assert e.value.code == "non_manifold_vertex" and e.value.details["vertices"] == [corner]
    assert f"[{corner}]" in e.value.message and "fans" in e.value.message


def test_tet_glued_along_an_interior_edge():
    """A tet on the cube's body diagonal, an edge through the interior between two boundary corners:
    every edge is in two boundary faces, but the corners' boundary fans are two."""
    V, T = cube_mesh(1)
    a, b = 0, 7  # (0, 0, 0) and (1, 1, 1): the diagonal all six Kuhn tets share
    assert ((T == a).any(1) & (T == b).any(1)).all()
    V2 = np.vstack([V, [[2.0, -1, 0], [2.0, 0, -1]]])
    T2 = np.vstack([T, _oriented(V2, [[a, b, 8, 9]])])
    with pytest.raises(TopologyError) as e:
        mesh_from_arrays(V2, T2)
    assert e.value.code == "non_manifold_vertex" and e.value.details["vertices"] == [a, b]


def test_interior_vertex_whose_link_is_two_spheres():
    """Two balls of tets around one interior vertex (and nothing else shared): the boundary is two
    closed surfaces, fine, but the centre's link is two spheres."""
    V, T = cube_mesh(2)
    c = int(np.flatnonzero((V == 0.5).all(1))[0])
    ball = T[(T == c).any(1)]
    others = np.setdiff1d(np.unique(ball), [c])
    V2 = np.vstack([V, V[others] + [0, 0, 0]])
    remap = np.arange(len(V))
    remap[others] = len(V) + np.arange(others.size)
    T2 = np.vstack([ball, remap[ball]])
    with pytest.raises(TopologyError) as e:
        mesh_from_arrays(V2, T2)
    assert e.value.code in ("non_manifold_vertex", "duplicate_nodes")
    cause = e.value.details.get("cause", e.value.code)
    assert cause == "non_manifold_vertex"


def test_open_scan_is_a_surface_with_its_rim():
    """stanford-bunny.obj: the original scan, 5 holes in its base (223 boundary edges per the data README)."""
    m = read_mesh(shared_file("surface/stanford-bunny.obj"))
    assert m.is_surface and len(m.rim_edges) == 223 and int(m.rim.sum()) == 223
    info = m.info()
    assert info["open_edges"] == 223 and info["rim_vertices"] == 223


def test_sheet_panel_with_holes(tmp_path):
    """A gmsh triangle mesh of a plate face with two holes: open, accepted; its rim is the outer
    boundary and the holes (gmsh's own line elements on those curves give the count)."""
    path = tmp_path / "panel.msh"
    rim_lines = sheet_panel(path, 4.0)
    m = read_mesh(path)
    assert m.is_surface and len(m.rim_edges) == rim_lines
    assert m.shell_labels.max() == 0  # one sheet


def test_surfaces_still_refuse_edges_in_three_faces_and_bow_ties():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [-1, -1, 1], [-1, 1, 1]])
    with pytest.raises(TopologyError) as e:  # edge (0, 1) in three triangles
        mesh_from_arrays(V, surface=[[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    assert e.value.code == "non_manifold_boundary" and e.value.details["edges"] == [[0, 1]]
    with pytest.raises(TopologyError) as e:  # two triangles sharing vertex 0 only
        mesh_from_arrays(V, surface=[[0, 1, 2], [0, 5, 6]])
    assert e.value.code == "non_manifold_vertex" and e.value.details["vertices"] == [0]
    with pytest.raises(TopologyError) as e:  # two triangles using edge (0, 1) the same way
        mesh_from_arrays(V, surface=[[0, 1, 2], [0, 1, 3]])
    assert e.value.code == "inconsistent_orientation"
