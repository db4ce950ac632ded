"""Mesh validity: safe fraction of an inverting MOVE and the ``clamp`` policy."""
from __future__ import annotations

import json

import numpy as np
import pytest

from solver import precompute
from tests.conftest import bend_move, bend_spec, load


@pytest.fixture(scope="module")
def armadillo():
    """The paper's method unchanged (no thin-wall rows), so that these moves invert elements."""
    m = load("Armadillo13K.msh")
    return m, precompute(m, bend_spec(m, thin_walls=False))


_move = bend_move


def test_quality_metrics_of_the_regular_tet_and_a_sliver():
    from solver.validity.quality import aspect_ratios, dihedral_angles, element_quality

    reg = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    T = np.array([[0, 2, 1, 3]])
    np.testing.assert_allclose(dihedral_angles(reg, T), np.degrees(np.arccos(1 / 3)), atol=1e-12)
    np.testing.assert_allclose(aspect_ratios(reg, T), 1.0, atol=1e-12)
    # right-angle corner tet: dihedral angles 90 (x3) and arccos(1/sqrt(3)) (x3)
    corner = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    d = np.sort(dihedral_angles(corner, np.array([[0, 1, 2, 3]]))[0])
    np.testing.assert_allclose(d, [np.degrees(np.arccos(1 / np.sqrt(3)))] * 3 + [90.0] * 3, atol=1e-10)
    # a flat sliver: dihedral angles at 0 and 180, aspect ratio capped, all finite
    flat = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    q = element_quality(flat, np.array([[0, 1, 2, 3]]))
    assert all(np.isfinite(v).all() for v in q.values())
    assert q["min_dihedral_deg"][0] < 1e-6 and q["max_dihedral_deg"][0] > 180 - 1e-6
    assert q["aspect_ratio"][0] == 1e12


def test_full_quality_report_and_cell_data(armadillo, tmp_path):
    import meshio

    from solver import write_mesh
    from solver.validity.quality import METRICS

    m, d = armadillo
    r = d.solve(_move(m, 45, 0.1), quality="full")
    q = r.report["quality"]
    assert set(q["before"]) == set(q["after"]) == set(METRICS)
    assert q["after"]["volume"]["min"] < 0 < q["before"]["volume"]["min"]  # this move inverts
    h = q["after"]["scaled_jacobian"]["histogram"]
    assert sum(h["counts"]) == m.T.shape[0] and len(h["edges"]) == len(h["counts"]) + 1
    assert int((r.cell_quality["volume"] <= 0).sum()) <= r.report["inverted_elements"]
    json.dumps(r.report, allow_nan=False)  # the REPORT stays strict JSON
    out = tmp_path / "q.vtu"
    write_mesh(m, r.V, out, quality=True)
    back = meshio.read(out)
    sj = np.concatenate([np.asarray(a) for a, c in zip(back.cell_data["quality:scaled_jacobian"], back.cells,
                                                          strict=True)
                         if c.type == "tetra"])
    np.testing.assert_allclose(sj, r.cell_quality["scaled_jacobian"])
    with pytest.raises(Exception, match="quality"):
        d.solve(_move(m, 10, 0.01), quality="all")
