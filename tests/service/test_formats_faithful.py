"""A download in the mesh's own format is its original file, patched in place (legacy VTK, Medit)."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from service.formats import export_mesh
from solver import read_mesh
from solver.testing import cube_mesh
from tests.conftest import DATA


@pytest.mark.parametrize(("name", "fmt"), [("wheelset.vtk", "vtk"), ("part.mesh", "medit")])
def test_the_original_format_download_is_the_patched_original(tmp_path, name, fmt):
    src = DATA / name
    if not src.exists():
        src = tmp_path / name
        V, T = cube_mesh(3, (10.0, 20.0, 30.0))
        meshio.write(src, meshio.Mesh(V, [("tetra", T)]))
    mesh = read_mesh(src)
    body, filename, _, dropped = export_mesh(mesh, mesh.V, fmt, "part")
    assert body == src.read_bytes() and dropped == [] and filename == f"part.{name.rsplit('.', 1)[1]}"
    P = mesh.V.copy()
    P[3] += [0.5, -0.25, 0.125]
    body, _, _, _ = export_mesh(mesh, P, fmt, "part")
    a, b = src.read_bytes().split(), body.split()
    assert len(a) == len(b) and sum(x != y for x, y in zip(a, b, strict=True)) == 3
    out = tmp_path / f"back.{name.rsplit('.', 1)[1]}"
    out.write_bytes(body)
    np.testing.assert_array_equal(meshio.read(out).points, P)
