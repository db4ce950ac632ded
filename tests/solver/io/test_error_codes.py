"""The remaining typed codes of reading, writing and tetrahedralizing, each provoked once."""

from __future__ import annotations

import numpy as np
import pytest

from solver import InvalidMeshError, SolverError, mesh_from_arrays, precompute, read_mesh, write_mesh
from solver.cli import main
from solver.errors import UnreadableFileError
from solver.io.read import read_surface
from solver.io.tetrahedralize import tetrahedralize
from solver.testing import cube_mesh, sphere_surface
from tests.conftest import DATA


def test_tetrahedralize_refuses_bad_options_and_non_finite_surfaces():
    V, F = sphere_surface(1)
    with pytest.raises(InvalidMeshError) as e:
        tetrahedralize(V, F, epsilon=-1.0)
    assert e.value.code == "bad_option"
    W = V.copy()
    W[0, 0] = np.nan
    with pytest.raises(InvalidMeshError) as e:
        tetrahedralize(W, F)
    assert e.value.code == "non_finite"


def test_tetgen_node_numbers_defined_twice(tmp_path):
    node = (DATA / "beam.node").read_text().splitlines()
    body = [ln for ln in node if ln.strip() and not ln.lstrip().startswith("#")]
    head, first, second = body[0], body[1].split(), body[2].split()
    second[0] = first[0]  # the second node reuses the first one's number
    (tmp_path / "beam.node").write_text("\n".join([head, " ".join(first), " ".join(second), *body[3:]]) + "\n")
    (tmp_path / "beam.ele").write_text((DATA / "beam.ele").read_text())
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(tmp_path / "beam.node")
    assert e.value.code == "duplicate_node_number"


def test_read_surface_wants_triangles(tmp_path):
    with pytest.raises(UnreadableFileError) as e:
        read_surface(DATA / "plate.inp")
    assert e.value.code == "not_a_surface"
    p = tmp_path / "lines.vtk"
    import meshio

    meshio.write(p, meshio.Mesh(np.eye(3), [("line", np.array([[0, 1], [1, 2]]))]))
    with pytest.raises(UnreadableFileError) as e:
        read_surface(p)
    assert e.value.code == "no_triangles"


def test_an_unreadable_target_surface(tmp_path):
    bad = tmp_path / "target.stl"
    bad.write_bytes(b"solid x\nfacet normal 0 0 1\n garbage\n")
    m = read_mesh(DATA / "plate.inp")
    spec = {"selections": {"top": {"set": "TOP"}, "fix": {"set": "BOTTOM"}}, "fixed": ["fix"], "handles": {},
            "targets": [{"name": "t", "selection": "top", "surface": str(bad)}]}
    with pytest.raises(SolverError) as e:
        precompute(m, spec)
    assert e.value.code == "unreadable_file"


def test_a_format_meshio_cannot_write(tmp_path):
    m = mesh_from_arrays(*cube_mesh(2))
    with pytest.raises(InvalidMeshError) as e:
        write_mesh(m, m.V, tmp_path / "cube.svg", lossy=True)  # meshio's SVG writer wants planar triangles
    assert e.value.code == "unwritable_format"
    assert "cube.svg" in e.value.message and str(tmp_path) not in e.value.message


def test_cli_usage_errors(tmp_path, capsys):
    spec = tmp_path / "s.json"
    spec.write_text('{"selections": {"a": {"set": "FIXED"}}, "fixed": ["a"]}')
    assert main(["morph", str(DATA / "plate.inp"), "--spec", str(spec), "--output", str(tmp_path / "o.inp")]) == 1
    assert "[usage]" in capsys.readouterr().err
