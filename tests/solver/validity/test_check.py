"""The per-update check: the fused tet pass against plain numpy, and flipped triangles of surfaces."""

from __future__ import annotations

import numpy as np
import pytest

from solver import mesh_from_arrays, precompute, read_mesh
from solver.testing import cube_mesh, sphere_surface
from solver.validity.check import ElementCheck, _select, tet_check
from tests.conftest import DATA, bend_spec, longest_axis


def _numpy_check(V, T):
    P = V[T]
    det = np.einsum("ij,ij->i", P[:, 1] - P[:, 0], np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]))
    return det


def test_fused_check_counts_like_numpy(rng):
    V, T = cube_mesh(12)
    V = V + rng.normal(0.0, 0.05, V.shape)  # enough jitter to invert some tets
    det = _numpy_check(V, T)
    bad = np.flatnonzero(det <= 0)
    r = tet_check(V, T.astype(np.int32))
    assert bad.size > 0 and r.count == bad.size and np.array_equal(r.ids, bad[:100])
    sj = r.sj
    assert float(np.sort(sj)[sj.size // 100]) == r.p01_sj and float(sj.min()) == r.min_sj


@pytest.mark.parametrize("jitter", [0.0, 0.01, 0.03])
def test_the_sampled_percentile_is_the_exact_order_statistic_on_a_large_mesh(rng, jitter):
    V, T = cube_mesh(24)  # 82,944 tets: above the size where the 1st percentile is bracketed from a sample
    V = V + rng.normal(0.0, jitter, V.shape)
    ec = ElementCheck(cube_mesh(24)[0], T, {})
    r = ec.check(V)
    det = _numpy_check(V, T)
    sj = r.sj
    assert float(np.sort(sj)[sj.size // 100]) == r.p01_sj and float(sj.min()) == r.min_sj
    assert r.count == int((det <= 0).sum() + ((det > 0) & (np.abs(sj) <= 1e-12)).sum())
    assert np.array_equal(r.ids, np.flatnonzero(sj <= 1e-12)[:100])
    assert np.array_equal(sj > 0, det > 0)


def test_a_bracket_that_misses_still_selects_exactly(rng):
    sj = rng.uniform(-1, 1, 100_000)
    k = sj.size // 100
    nch = 8
    for lo, hi in ((0.5, 0.9), (-1.0, -0.999), (np.inf, -np.inf)):  # above, below, empty
        counts = np.zeros((nch, 4), np.int64)
        for c in range(nch):
            part = sj[c * sj.size // nch:(c + 1) * sj.size // nch]
            counts[c, 2], counts[c, 3] = (part < lo).sum(), ((part >= lo) & (part <= hi)).sum()
        assert _select(sj, k, lo, hi, counts) == float(np.sort(sj)[k])


def _normals(V, F):
    return np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])


def test_a_sphere_pushed_through_itself_reports_its_flipped_triangles():
    V, F = sphere_surface(3)
    s = mesh_from_arrays(V, surface=F)
    d = precompute(s, {"selections": {"n": {"box": {"min": [-1, -1, 0.7], "max": [1, 1, 1]}},
                                      "s": {"box": {"min": [-1, -1, -1], "max": [1, 1, -0.7]}}},
                       "fixed": ["s"], "handles": {"n": "n"}})
    for push in (1.2, 1.9):
        r = d.solve({"handles": {"n": {"translation": [0, 0, -push]}}})
        flipped = np.einsum("ij,ij->i", _normals(V, F), _normals(r.V, F)) <= 0  # independent
        vol = np.einsum("ij,ij->i", r.V[F[:, 0]], np.cross(r.V[F[:, 1]], r.V[F[:, 2]])).sum() / 6
        expected = np.arange(len(F)) if vol <= 0 else np.flatnonzero(flipped)  # inside out: every triangle
        assert flipped.any()
        assert r.report["inverted_elements"] == expected.size
        assert r.report["inverted_ids"] == expected[:100].tolist()
        vol0 = np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6
        assert r.report["enclosed_volume_ratio"] == pytest.approx(vol / vol0, rel=1e-9)
    assert d.solve({"handles": {"n": {"translation": [0, 0, -0.05]}}}).report["inverted_elements"] == 0


def test_a_closed_surface_turned_inside_out_counts_every_triangle():
    m = read_mesh(DATA / "42400-IDGH.stl")
    ax, diag = longest_axis(m)
    d = precompute(m, bend_spec(m))
    r = d.solve({"handles": {"h": {"scale": 1.0}}})
    assert r.report["inverted_elements"] == 0  # zero-area triangles of the file are reported apart
    q0 = np.linalg.norm(_normals(m.V, m.surface), axis=1)
    assert r.report["degenerate_at_rest"]["count"] == int((q0 <= 1e-12 * q0.max()).sum()) > 0
    # mirror the part through its centre: every normal reverses (enclosed volume changes sign)
    c = 0.5 * (m.V.max(0) + m.V.min(0))
    P = 2 * c - m.V
    res = d.data.check.check(P)
    assert res.count == len(m.surface)
