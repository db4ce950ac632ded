"""Per-element quality of tetrahedra: signed volume and scaled Jacobian."""

from __future__ import annotations

import numpy as np
import tetmorph_core

from ..ops.elements import corner_jacobians, element_blocks, element_volumes

__all__ = ["DEGENERATE_TOL", "signed_volumes", "scaled_jacobians", "degenerate_mask", "first_percentile",
           "dihedral_angles", "aspect_ratios", "element_quality", "summarize_quality", "METRICS",
           "tet_quality", "element_jacobians"]

#: A tet is degenerate when ``6 |vol| <= DEGENERATE_TOL * l_max**3`` (scale-free).
DEGENERATE_TOL = 1.0e-12


def signed_volumes(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Signed volume of each tetrahedron (positive for the meshio/VTK node order).

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array

    Returns
    -------
    vol : (m,) float array

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> signed_volumes(V, np.array([[0, 1, 2, 3]])).round(12).tolist()
    [0.166666666667]
    """
    p0 = V[T[:, 0]]
    a = V[T[:, 1]] - p0
    b = V[T[:, 2]] - p0
    c = V[T[:, 3]] - p0
    return np.einsum("ij,ij->i", np.cross(a, b), c) / 6.0


def _edges2(V: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    P = V[T]
    L0 = P[:, 1] - P[:, 0]
    L2 = P[:, 0] - P[:, 2]
    L3 = P[:, 3] - P[:, 0]
    jac = np.einsum("ij,ij->i", np.cross(L2, L0), L3)
    e2 = np.stack([
        np.einsum("ij,ij->i", L0, L0),
        np.einsum("ij,ij->i", d := P[:, 2] - P[:, 1], d),
        np.einsum("ij,ij->i", L2, L2),
        np.einsum("ij,ij->i", L3, L3),
        np.einsum("ij,ij->i", d := P[:, 3] - P[:, 1], d),
        np.einsum("ij,ij->i", d := P[:, 3] - P[:, 2], d),
    ], axis=1)
    return jac, e2


def tet_quality(V: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Six times the signed volume and the scaled Jacobian of every tet, fused.

    The per-update check: one compiled, multi-threaded pass over the tets
    (``validity_tet_quality`` in src/core/validity.cpp), where the same formulas
    as numpy array expressions make a temporary array per operation (``python
    benchmarks/measure_choices.py --only kernels`` compares them). The scaled
    Jacobian is ``sqrt(2) det / sqrt(max over corners of the product of its three
    squared edge lengths)``, clipped to [-1, 1], 0 for a flat tet; it rounds as the
    element check's (:func:`solver.validity.check.tet_check`), bit for bit.

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array

    Returns
    -------
    vol6 : (m,) float array
        ``6 * signed volume``.
    sj : (m,) float array
        Scaled Jacobian as :func:`scaled_jacobians`.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> vol6, sj = tet_quality(V, np.array([[0, 1, 2, 3]]))
    >>> float(vol6[0]), round(float(sj[0]), 6)
    (1.0, 0.707107)
    """
    V = np.ascontiguousarray(V, dtype=np.float64)
    T = np.ascontiguousarray(T)
    if T.dtype not in (np.int32, np.int64):
        T = T.astype(np.int64)
    vol6 = np.empty(T.shape[0])
    sj = np.empty(T.shape[0])
    if T.shape[0]:
        tetmorph_core.validity_tet_quality(V, T, vol6, sj)
    return vol6, sj


def scaled_jacobians(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Scaled Jacobian of each tetrahedron: 1 for the regular tet, <= 0 when inverted.

    ``sqrt(2) * det(J) / max_corner(|e_a| |e_b| |e_c|)`` with the three edges
    that meet at each corner, as in the Verdict library (Stimpson et al.,
    "The Verdict geometric quality library", SAND2007-1751, tet scaled Jacobian).

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array

    Returns
    -------
    sj : (m,) float array in [-1, 1]

    Examples
    --------
    >>> V = np.array([[1., 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    >>> scaled_jacobians(V, np.array([[0, 2, 1, 3]])).round(12).tolist()
    [1.0]
    """
    return tet_quality(V, np.asarray(T))[1]


def degenerate_mask(V: np.ndarray, T: np.ndarray, vol: np.ndarray | None = None) -> np.ndarray:
    """Tets whose volume is zero relative to their size (``DEGENERATE_TOL``).

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array
    vol : (m,) float array, optional
        Precomputed signed volumes.

    Returns
    -------
    (m,) bool array
    """
    vol = signed_volumes(V, T) if vol is None else vol
    _, e2 = _edges2(V, T)
    lmax3 = e2.max(axis=1) ** 1.5
    return 6.0 * np.abs(vol) <= DEGENERATE_TOL * lmax3


def first_percentile(v: np.ndarray) -> float:
    """The 1st-percentile value (the order statistic ``m // 100``), as every REPORT and summary gives it.

    Examples
    --------
    >>> first_percentile(np.arange(200.0))
    2.0
    """
    k = v.size // 100
    return float(np.partition(v, k)[k])


METRICS = ("volume", "scaled_jacobian", "min_dihedral_deg", "max_dihedral_deg", "aspect_ratio")
#: Cap of the aspect ratio of flat or inverted-flat tets (keeps reports finite).
ASPECT_CAP = 1.0e12
#: Tet faces (opposite vertex k) and the two faces that meet at each edge (i, j).
_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
_EDGES = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]


def _face_normals(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Area-weighted outward normals (m, 4, 3) of the faces opposite each vertex (for positive tets)."""
    P = V[T]  # (m, 4, 3)
    a, b, c = P[:, _FACES[:, 0]], P[:, _FACES[:, 1]], P[:, _FACES[:, 2]]
    return 0.5 * np.cross(b - a, c - a)


def dihedral_angles(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    """The six interior dihedral angles of each tet, in degrees.

    At edge (i, j) the two faces are those opposite the other two vertices
    k, l; the angle is ``pi - angle(n_k, n_l)`` for outward normals (Verdict,
    "minimum/maximum dihedral angle").

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array

    Returns
    -------
    (m, 6) float array
        Edges in the order (0,1), (0,2), (0,3), (1,2), (1,3), (2,3).

    Examples
    --------
    >>> V = np.array([[1., 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    >>> np.round(dihedral_angles(V, np.array([[0, 2, 1, 3]])), 4).tolist()[0][:2]
    [70.5288, 70.5288]
    """
    N = _face_normals(V, T)
    Nn = N / np.maximum(np.linalg.norm(N, axis=2, keepdims=True), 1e-300)
    out = np.empty((T.shape[0], 6))
    for e, (i, j) in enumerate(_EDGES):
        k, q = (x for x in range(4) if x not in (i, j))
        cosang = np.clip(-np.einsum("ij,ij->i", Nn[:, k], Nn[:, q]), -1.0, 1.0)
        out[:, e] = np.degrees(np.arccos(cosang))
    return out


def aspect_ratios(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Aspect ratio ``h_max / (2 sqrt(6) r_in)`` of each tet: 1 for the regular tet.

    The Verdict/VTK tet aspect ratio (Stimpson et al., SAND2007-1751; VTK
    ``vtkMeshQuality`` TetAspectRatio), with the inradius ``r_in = 3 |vol| /
    (sum of face areas)``. Flat tets are capped at ``ASPECT_CAP``.

    Examples
    --------
    >>> V = np.array([[1., 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    >>> np.round(aspect_ratios(V, np.array([[0, 2, 1, 3]])), 12).tolist()
    [1.0]
    """
    vol = np.abs(signed_volumes(V, T))
    area = np.linalg.norm(_face_normals(V, T), axis=2).sum(axis=1)
    _, e2 = _edges2(V, T)
    hmax = np.sqrt(e2.max(axis=1))
    r_in = 3.0 * vol / np.maximum(area, 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        ar = hmax / (2.0 * np.sqrt(6.0) * r_in)
    return np.where(np.isfinite(ar), np.minimum(ar, ASPECT_CAP), ASPECT_CAP)


def element_quality(V: np.ndarray, T: np.ndarray,
                    cells: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Every per-element metric of :data:`METRICS`.

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array
    cells : dict, optional
        Hexahedra, wedges and pyramids (:attr:`solver.mesh.Mesh.cells`). Their
        volume comes from their faces and their scaled Jacobian from their
        corners (:func:`solver.ops.elements.corner_jacobians`); the dihedral
        angles and aspect ratio are tetrahedron metrics and are NaN there.

    Returns
    -------
    dict of str to (M,) float array
        ``volume`` (signed), ``scaled_jacobian``, ``min_dihedral_deg``,
        ``max_dihedral_deg``, ``aspect_ratio``; tets first, then the other
        types in :data:`solver.ops.elements.LINEAR_TYPES` order.
    """
    m = len(T)
    det, sj = element_jacobians(V, T, cells)
    dih = dihedral_angles(V, T) if m else np.zeros((0, 6))
    others = [(k, E) for k, E in element_blocks(np.asarray(T), cells or {}) if k != "tetra"]
    nan = np.full(len(sj) - m, np.nan)  # tet-only metrics on the other elements
    return {"volume": np.concatenate([det[:m] / 6.0, *[element_volumes(V, E, k) for k, E in others]]),
            "scaled_jacobian": sj,
            "min_dihedral_deg": np.concatenate([dih.min(axis=1, initial=np.inf), nan]),
            "max_dihedral_deg": np.concatenate([dih.max(axis=1, initial=-np.inf), nan]),
            "aspect_ratio": np.concatenate([aspect_ratios(V, T) if m else np.zeros(0), nan])}


def element_jacobians(V: np.ndarray, T: np.ndarray,
                      cells: dict[str, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Jacobian and scaled Jacobian of every element, in element-numbering order.

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array
    cells : dict, optional
        Hexahedra, wedges and pyramids (:attr:`solver.mesh.Mesh.cells`).

    Returns
    -------
    det : (M,) float array
        Tets: six times the signed volume (:func:`tet_quality`); other elements:
        the smallest corner Jacobian (:func:`solver.ops.elements.corner_jacobians`).
        Positive for a valid element.
    sj : (M,) float array in [-1, 1]
        The matching scaled Jacobians.
    """
    det, sj = tet_quality(V, np.asarray(T))
    others = [corner_jacobians(V, E, k) for k, E in element_blocks(np.asarray(T), cells or {}) if k != "tetra"]
    if not others:
        return det, sj
    return np.concatenate([det, *[o[0] for o in others]]), np.concatenate([sj, *[o[1] for o in others]])


#: Histogram bin edges per metric in :func:`summarize_quality`.
HISTOGRAM_EDGES = {
    "scaled_jacobian": np.linspace(-1.0, 1.0, 21),
    "min_dihedral_deg": np.linspace(0.0, 90.0, 19),
    "max_dihedral_deg": np.linspace(90.0, 180.0, 19),
}


def summarize_quality(q: dict[str, np.ndarray]) -> dict[str, dict]:
    """Min, percentiles, max (and histograms) of each metric, JSON-ready.

    Parameters
    ----------
    q : dict
        Output of :func:`element_quality`.

    Returns
    -------
    dict
        ``{metric: {"min", "p01", "p05", "median", "p95", "p99", "max"[, "histogram":
        {"edges", "counts"}]}}``.
    """
    out: dict[str, dict] = {}
    for k, v in q.items():
        v = v[~np.isnan(v)]  # tet-only metrics are NaN on other elements
        if not v.size:
            continue
        p = np.percentile(v, [0, 1, 5, 50, 95, 99, 100])
        ent: dict = dict(zip(("min", "p01", "p05", "median", "p95", "p99", "max"), map(float, p), strict=True))
        ent["p01"] = first_percentile(v)  # the REPORT's definition
        if k in HISTOGRAM_EDGES:
            edges = HISTOGRAM_EDGES[k]
            counts, _ = np.histogram(np.clip(v, edges[0], edges[-1]), bins=edges)
            ent["histogram"] = {"edges": edges.tolist(), "counts": counts.tolist()}
        out[k] = ent
    return out
