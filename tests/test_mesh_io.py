"""Reading, validation errors and coordinate-only round trips."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from solver import (
    InvalidMeshError,
    UnsupportedElementError,
    mesh_from_arrays,
    read_mesh,
    write_mesh,
)
from solver.testing import cube_mesh

from .conftest import load


def _tet():
    return np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]), np.array([[0, 1, 2, 3]])


@pytest.mark.parametrize("name,fmt", [("screw.msh", None), ("wheelset.vtk", None),
                                      ("cones_with_cavities.inp", None), ("Armadillo13K.msh", "vtu")])
def test_round_trip_changes_only_coordinates(tmp_path, name, fmt):
    m = load(name)
    V = m.V + 0.25
    ext = fmt or name.rsplit(".", 1)[1]
    out = tmp_path / f"out.{ext}"
    write_mesh(m, V, out)
    back = meshio.read(out)
    src = m.source
    np.testing.assert_allclose(back.points, V.astype(src.points.dtype), rtol=1e-6, atol=1e-6)
    assert [c.type for c in back.cells] == [c.type for c in src.cells]
    for a, b in zip(back.cells, src.cells, strict=True):
        np.testing.assert_array_equal(a.data, b.data)
    if fmt is None:
        if ext not in ("msh", "inp"):
            # compare with meshio's own round trip of the untouched mesh (.msh and .inp are
            # written by patching the original file, so they keep everything it had, e.g.
            # Gmsh node entity tags that meshio's writer drops)
            ref_path = tmp_path / f"ref.{ext}"
            meshio.write(ref_path, src)
            src = meshio.read(ref_path)
        assert set(back.point_data) == set(src.point_data)
        for k in src.point_data:
            np.testing.assert_array_equal(back.point_data[k], src.point_data[k])
        assert set(back.cell_data) == set(src.cell_data)
        assert set(back.point_sets) == set(src.point_sets)
        for k in src.point_sets:
            np.testing.assert_array_equal(back.point_sets[k], src.point_sets[k])
        assert set(back.cell_sets) == set(src.cell_sets)


def test_inp_sets_are_selections():
    m = load("cones_with_cavities.inp")
    src = m.source
    assert set(src.point_sets) | set(src.cell_sets) <= set(m.sets)
    assert all(len(v) > 0 for v in m.sets.values())


def test_tetgen_and_vtk_data_are_read():
    b = load("beam.node")
    assert (b.n, len(b.T)) == (208, 450)
    w = load("wheelset.vtk")
    assert w.info()["bodies"] >= 1 and len(w.T) == 21934


def test_quadratic_and_mixed_elements_are_refused(tmp_path):
    V, T = cube_mesh(1)
    from solver.io import mesh_from_meshio

    # tetra10 is read (tests/test_quadratic.py); one whose mid-side nodes are corners is refused
    m10 = meshio.Mesh(np.vstack([V, V[:2] + 5]), [("tetra10", np.c_[T, np.zeros((len(T), 6), int)][:1])])
    with pytest.raises(InvalidMeshError) as e:
        mesh_from_meshio(m10)
    assert e.value.code == "bad_connectivity"
    mixed = meshio.Mesh(V, [("tetra", T), ("tetra10", np.c_[T, T[:, :2], T[:, :2], T[:, :2]][:1])])
    with pytest.raises(UnsupportedElementError, match="tetra10"):
        mesh_from_meshio(mixed)
    # linear hexahedra are read (tests/test_mixed.py); quadratic ones are refused
    hexm = meshio.Mesh(np.vstack([V, V[:8] + 3, V[:4] + 7]), [("hexahedron20", np.arange(20)[None])])
    p = tmp_path / "hex20.vtu"
    meshio.write(p, hexm)
    with pytest.raises(UnsupportedElementError, match="hexahedron20"):
        read_mesh(p)
    with pytest.raises(UnsupportedElementError, match="hexahedron"):
        mesh_from_meshio(meshio.Mesh(np.vstack([V, V[:2] + 5]), [
            ("tetra10", np.array([[0, 1, 2, 4, 8, 9, 3, 5, 6, 7]])), ("hexahedron", np.arange(8)[None])]))


def test_unreadable_and_missing_files(tmp_path):
    with pytest.raises(InvalidMeshError, match="no such file"):
        read_mesh(tmp_path / "nope.msh")
    bad = tmp_path / "bad.msh"
    bad.write_text("garbage")
    with pytest.raises(InvalidMeshError) as e:
        read_mesh(bad)
    assert e.value.code == "wrong_format"  # not Gmsh's $MeshFormat: tests/solver/io/test_read.py


def test_each_validation_error_names_the_defect():
    V, T = _tet()
    cases = [
        (np.where(np.arange(12).reshape(4, 3) == 4, np.nan, V), T, "non_finite_coordinates", "vertices"),
        (np.where(np.arange(12).reshape(4, 3) == 4, 1e308, V), T, "coordinates_out_of_range", "beyond +-1e+15"),
        (V, np.array([[0, 1, 2, 7]]), "index_out_of_range", "outside 0..3"),
        (V, np.array([[0, 1, 1, 3]]), "repeated_index", "repeat"),
        (V, np.array([[0, 2, 1, 3]]), "inverted_input", "inverted"),
        (np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]), T, "degenerate_input", "zero volume"),
        (V, np.zeros((0, 4), int), "no_elements", "no tetrahedra"),
        (V[:, :2], T, "bad_shape", "(n, 3)"),
    ]
    for Vx, Tx, code, words in cases:
        with pytest.raises(InvalidMeshError) as e:
            mesh_from_arrays(Vx, Tx)
        assert e.value.code == code, (code, e.value.message)
        assert words in e.value.message


def test_non_manifold_volume_and_boundary():
    V, T = _tet()
    V3 = np.vstack([V, [[1, 1, 1]], [[-1, -1, -1]]])
    # three tets on face (0,1,2): non-manifold volume
    with pytest.raises(InvalidMeshError) as e:
        mesh_from_arrays(V3, np.array([[0, 1, 2, 3], [0, 2, 1, 5], [0, 1, 2, 4]]))
    assert e.value.code in ("non_manifold_volume", "inverted_input")
    # two tets sharing only an edge: boundary edge in four faces
    Vb = np.array([[0.0, 0, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]])
    Tb = np.array([[0, 1, 2, 3], [0, 1, 4, 5]])
    for t in Tb:
        P = Vb[t]
        if np.linalg.det(P[1:] - P[0]) < 0:
            t[[2, 3]] = t[[3, 2]]
    with pytest.raises(InvalidMeshError) as e:
        mesh_from_arrays(Vb, Tb)
    assert e.value.code == "non_manifold_boundary"


def test_unreferenced_vertices_are_ignored_and_reported():
    V, T = cube_mesh(2)
    V2 = np.vstack([V, [[9.0, 9, 9]], [[np.nan, 0, 0]]])
    m = mesh_from_arrays(V2, T)
    assert m.info()["unreferenced_vertices"] == 2
    from solver import precompute
    d = precompute(m, {"selections": {"a": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
                                      "b": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
                       "fixed": ["a"], "handles": {"b": "b"}})
    r = d.solve({"handles": {"b": {"translation": [0.1, 0, 0]}}})
    assert np.array_equal(r.V[-2], V2[-2]) and np.isnan(r.V[-1, 0])
    assert np.isfinite(r.V[:-1]).all()
