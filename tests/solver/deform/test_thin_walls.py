"""Mesh validity: safe fraction of an inverting MOVE and the ``clamp`` policy."""
from __future__ import annotations

import numpy as np

from solver import precompute
from tests.conftest import bend_spec, longest_axis


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
