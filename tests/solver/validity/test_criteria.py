"""The quality check's measures against a few lines of numpy, its thresholds, presets and deck ids."""

from __future__ import annotations

import numpy as np
import pytest

from solver.errors import SpecError
from solver.io import read_mesh
from solver.io.element_sets import deck_element_ids
from solver.validity.criteria import (
    CRITERIA,
    PRESETS,
    Criteria,
    criteria_values,
    gauss_scaled_jacobians,
    preset,
    quality_check,
)
from tests.conftest import DATA

REGULAR = np.array([[1.0, 1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, 1]])  # positively oriented
EDGES10 = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))


def sj_numpy(P):
    """Verdict's tet scaled Jacobian of the (4, 3) corners ``P``."""
    det = np.linalg.det(np.stack([P[1] - P[0], P[2] - P[0], P[3] - P[0]], axis=1))
    prods = [np.prod([np.linalg.norm(P[j] - P[k]) for j in range(4) if j != k]) for k in range(4)]
    return np.sqrt(2.0) * det / max(prods)


def aspect_numpy(P):
    """``h_max / (2 sqrt(6) r_in)`` with ``r_in = 3 |vol| / area``."""
    vol = abs(np.linalg.det(np.stack([P[1] - P[0], P[2] - P[0], P[3] - P[0]]))) / 6
    area = sum(np.linalg.norm(np.cross(P[b] - P[a], P[c] - P[a])) / 2
               for a, b, c in ((1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)))
    hmax = max(np.linalg.norm(P[i] - P[j]) for i, j in EDGES10)
    return hmax / (2 * np.sqrt(6) * 3 * vol / area)


def dihedrals_numpy(P):
    """The six dihedral angles, degrees: the angle between the two other corners seen across the edge."""
    out = []
    for i, j in EDGES10:
        k, q = (x for x in range(4) if x not in (i, j))
        e = (P[j] - P[i]) / np.linalg.norm(P[j] - P[i])
        a = (P[k] - P[i]) - np.dot(P[k] - P[i], e) * e
        b = (P[q] - P[i]) - np.dot(P[q] - P[i], e) * e
        out.append(np.degrees(np.arccos(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b))))
    return np.array(out)


def test_the_regular_tet_scores_one_and_70_53_degrees():
    q = criteria_values(REGULAR, np.array([[0, 1, 2, 3]]))
    np.testing.assert_allclose([q["scaled_jacobian"][0], q["aspect_ratio"][0]], [1.0, 1.0], atol=1e-12)
    np.testing.assert_allclose([q["min_dihedral"][0], q["max_dihedral"][0]],
                               [np.degrees(np.arccos(1 / 3))] * 2, atol=1e-9)
    assert round(float(q["min_dihedral"][0]), 2) == 70.53
    assert np.isnan(q["scaled_jacobian_ip"][0]) and np.isnan(q["volume_ratio"][0])  # linear, no rest given


@pytest.mark.parametrize("name", ["bracket.inp", "screw.msh"])
def test_measures_agree_with_numpy_on_a_real_mesh(name):
    mesh = read_mesh(DATA / name)
    q = criteria_values(mesh.V, mesh.T)
    worst = int(np.argmin(q["min_dihedral"]))  # screw.msh: a sliver of 0.013 degrees
    for e in [0, 17, len(mesh.T) // 2, len(mesh.T) - 1, worst]:
        P = mesh.V[mesh.T[e]]
        d = dihedrals_numpy(P)
        np.testing.assert_allclose(q["scaled_jacobian"][e], sj_numpy(P), rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(q["aspect_ratio"][e], aspect_numpy(P), rtol=1e-6)
        np.testing.assert_allclose([q["min_dihedral"][e], q["max_dihedral"][e]], [d.min(), d.max()], atol=1e-6)
    if name == "screw.msh":
        assert q["min_dihedral"][worst] < 0.05 and q["aspect_ratio"][worst] > 100


def test_gauss_point_values_agree_with_finite_differences_of_the_quadratic_map():
    """At each Gauss point, J from central differences of x(xi); the edge tangents of corner k are t_0j - t_0k."""
    mesh = read_mesh(DATA / "ccx_bracket.inp")
    V, T10 = mesh.V, mesh.T10
    got = gauss_scaled_jacobians(V, T10)
    a, b = (5 + 3 * np.sqrt(5)) / 20, (5 - np.sqrt(5)) / 20

    def x(X, xi):
        L = np.array([1 - xi.sum(), *xi])
        N = [L[c] * (2 * L[c] - 1) for c in range(4)] + [4 * L[i] * L[j] for i, j in EDGES10]
        return np.asarray(N) @ X

    ip = gauss_scaled_jacobians(V, T10).min(axis=1)
    corner = criteria_values(V, mesh.T)["scaled_jacobian"]
    curved = int(np.argmax(np.abs(ip - corner)))
    assert abs(ip[curved] - corner[curved]) > 1e-3  # a curved element: the points see what the corners do not
    for e in [0, 400, curved]:
        X = V[T10[e]]
        for p in range(4):
            L = np.full(4, b)
            L[p] = a
            h = 1e-6
            J = np.stack([(x(X, L[1:] + h * np.eye(3)[k]) - x(X, L[1:] - h * np.eye(3)[k])) / (2 * h)
                          for k in range(3)], axis=1)  # columns t_01, t_02, t_03
            t0 = [np.zeros(3), J[:, 0], J[:, 1], J[:, 2]]
            prods = [np.prod([np.linalg.norm(t0[j] - t0[k]) for j in range(4) if j != k]) for k in range(4)]
            np.testing.assert_allclose(got[e, p], np.sqrt(2) * np.linalg.det(J) / max(prods), atol=1e-7)


def test_a_straight_sided_quadratic_tet_has_its_corner_value_at_every_point():
    mesh = read_mesh(DATA / "ccx_bracket.inp")
    V = mesh.V.copy()
    for k, (i, j) in enumerate(EDGES10):  # straighten every edge
        V[mesh.T10[:, 4 + k]] = (V[mesh.T10[:, i]] + V[mesh.T10[:, j]]) / 2
    corner = criteria_values(V, mesh.T)["scaled_jacobian"]
    np.testing.assert_allclose(gauss_scaled_jacobians(V, mesh.T10), np.repeat(corner[:, None], 4, 1), atol=1e-12)


def test_thresholds_decide_who_fails_and_the_worst_is_the_extreme():
    mesh = read_mesh(DATA / "screw.msh")
    q = criteria_values(mesh.V, mesh.T)
    c = quality_check(mesh.V, mesh.T, Criteria(min_scaled_jacobian=0.1, max_aspect_ratio=20.0, min_dihedral=2.0))
    by = {r.name: r for r in c.results}
    np.testing.assert_array_equal(by["min_scaled_jacobian"].failing, np.flatnonzero(q["scaled_jacobian"] < 0.1))
    np.testing.assert_array_equal(by["max_aspect_ratio"].failing, np.flatnonzero(q["aspect_ratio"] > 20.0))
    np.testing.assert_array_equal(by["min_dihedral"].failing, np.flatnonzero(q["min_dihedral"] < 2.0))
    assert by["max_dihedral"].threshold is None and by["max_dihedral"].passed  # not checked: nothing fails
    assert by["max_dihedral"].worst == q["max_dihedral"].max()  # but measured
    assert by["min_scaled_jacobian"].worst_element == int(np.argmin(q["scaled_jacobian"]))
    np.testing.assert_array_equal(c.failing, np.flatnonzero((q["scaled_jacobian"] < 0.1)
                                                            | (q["aspect_ratio"] > 20.0) | (q["min_dihedral"] < 2.0)))
    assert not c.passed and quality_check(mesh.V, mesh.T, Criteria()).passed


def test_volume_ratio_against_rest():
    mesh = read_mesh(DATA / "bracket.inp")
    P = mesh.V * np.array([2.0, 1.0, 1.0])  # every volume doubles
    P[mesh.T[5]] = mesh.V[mesh.T[5]]  # ... but element 5's own corners are back at rest
    q = criteria_values(P, mesh.T, V0=mesh.V)
    vol = lambda X, t: np.linalg.det(np.stack([X[t[1]] - X[t[0]], X[t[2]] - X[t[0]], X[t[3]] - X[t[0]]]))  # noqa: E731
    for e in [0, 5, 100]:
        np.testing.assert_allclose(q["volume_ratio"][e], vol(P, mesh.T[e]) / vol(mesh.V, mesh.T[e]), rtol=1e-9)
    assert abs(q["volume_ratio"][5] - 1.0) < 1e-12
    c = quality_check(P, mesh.T, Criteria(max_volume_ratio=1.5), V0=mesh.V)
    assert c.results[-1].failing.size == np.sum(q["volume_ratio"] > 1.5) > 0
    assert quality_check(P, mesh.T, Criteria(max_volume_ratio=1.5)).passed  # no rest: not measured


def test_presets_and_an_unknown_one():
    assert set(PRESETS) == {"tetmorph", "abaqus", "calculix", "nastran"}
    assert all(set(p.thresholds()) == set(CRITERIA) for p in PRESETS.values())
    assert preset("calculix").max_aspect_ratio is None
    with pytest.raises(SpecError) as e:
        preset("ansa")
    assert e.value.code == "unknown_preset" and e.value.details["field"] == "preset"
    assert Criteria(min_dihedral=-1e12).min_dihedral == -1e12  # at the bound: accepted
    for bad in (float("nan"), float("inf"), np.nextafter(1e12, 2e12), "5"):
        with pytest.raises(SpecError) as e:
            PRESETS["tetmorph"].replace(max_aspect_ratio=bad)
        assert e.value.code == "invalid_threshold" and e.value.details["field"] == "max_aspect_ratio"


def test_the_deck_ids_are_the_files_own():
    mesh = read_mesh(DATA / "bracket.inp")  # 136 triangles are numbered before the tets
    ids = deck_element_ids(mesh)
    lines = (DATA / "bracket.inp").read_text().splitlines()
    start = next(k for k, ln in enumerate(lines) if ln.upper().startswith("*ELEMENT") and "C3D4" in ln.upper())
    first = [int(ln.split(",")[0]) for ln in lines[start + 1:start + 4]]
    assert ids[:3].tolist() == first and ids[0] == 137 and ids.size == len(mesh.T)
    c = quality_check(mesh.V, mesh.T, Criteria(max_aspect_ratio=3.0), ids=ids)
    doc = c.to_dict()
    assert doc["criteria"][2]["ids"] == ids[c.results[2].failing].tolist()
    assert deck_element_ids(read_mesh(DATA / "screw.msh"))[:3].tolist() == [1, 2, 3]  # no numbers kept: positions
