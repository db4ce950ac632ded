"""Mean value coordinates of interior vertices with respect to their local volumes."""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp

from .boundary_facets import TET_FACES
from .mean_value_coordinates import MVC_EPS, mvc_pair

__all__ = ["mvc_matrix", "vertex_tets"]


def mvc_matrix(V: np.ndarray, T: np.ndarray, interior: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
    """Mean value coordinates ``W`` and local-volume areas ``S`` of interior vertices.

    The local volume of interior vertex ``i`` is the union of its incident
    tetrahedra; its closed boundary is made of the faces opposite ``i``. Row
    ``i`` of ``W`` holds the 3D mean value coordinates of ``p_i`` with respect
    to that boundary, so that ``p_i = sum_j W_ij p_j`` (eq. 2.4).

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array
        Positively oriented tetrahedra.
    interior : (n,) bool array
        Which vertices get a row.

    Returns
    -------
    W : (n, n) scipy.sparse.csr_matrix
        Rows of interior vertices sum to one; other rows are empty.
    S : (n,) float array
        Area of the boundary of each interior vertex's local volume (the
        ``S_i`` of eq. 2.5); zero elsewhere.

    Notes
    -----
    Interactive deformation of 3D mesh models, eq. (2.4)-(2.5); the weights
    come from :func:`solver.mean_value_coordinates.mvc_triangle_weights`.

    Examples
    --------
    The one interior vertex of a 2x2x2 cube grid is reproduced by its weights:

    >>> from solver.testing import cube_mesh
    >>> V, T = cube_mesh(2)
    >>> from solver.boundary_facets import boundary_facets
    >>> F, _ = boundary_facets(T)
    >>> interior = np.ones(len(V), bool); interior[F.ravel()] = False
    >>> W, S = mvc_matrix(V, T, interior)
    >>> bool(np.allclose(W @ V, V * interior[:, None]))
    True
    """
    n = len(V)
    V = np.ascontiguousarray(V, dtype=np.float64)
    T = np.ascontiguousarray(T, dtype=np.int64)
    ptr, inc = vertex_tets(T, n)
    rows = np.flatnonzero(interior).astype(np.int64)
    counts = _row_sizes(T, ptr, inc, rows)
    indptr = np.zeros(n + 1, np.int64)
    np.add.at(indptr, rows + 1, counts)  # rows are unique: one add per row
    indptr = np.cumsum(indptr)
    indices = np.empty(indptr[-1], np.int64)
    data = np.empty(indptr[-1])
    S = np.zeros(n)
    _fill_rows(V, T, ptr, inc, rows, indptr, indices, data, S, TET_FACES, MVC_EPS)
    W = sp.csr_matrix((data, indices, indptr), shape=(n, n))
    W.eliminate_zeros()
    return W, S


def vertex_tets(T: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Incident (tet, corner) pairs of every vertex, in tet order.

    Parameters
    ----------
    T : (m, 4) int array
    n : int
        Number of vertices.

    Returns
    -------
    ptr : (n + 1,) int array
    inc : (4 m,) int array
        ``inc[ptr[v]:ptr[v + 1]]`` are the flat indices ``4 t + k`` with ``T[t, k] == v``.

    Examples
    --------
    >>> ptr, inc = vertex_tets(np.array([[0, 1, 2, 3], [1, 2, 3, 4]]), 5)
    >>> inc[ptr[1]:ptr[2]].tolist()
    [1, 4]
    """
    flat = np.ascontiguousarray(T, dtype=np.int64).ravel()
    ptr = np.zeros(n + 1, np.int64)
    ptr[1:] = np.cumsum(np.bincount(flat, minlength=n))
    return ptr, _counting_sort(flat, ptr)


@numba.njit(cache=True)
def _counting_sort(flat, ptr):  # pragma: no cover - compiled
    nxt = ptr[:-1].copy()
    out = np.empty(flat.size, np.int64)
    for p in range(flat.size):
        v = flat[p]
        out[nxt[v]] = p
        nxt[v] += 1
    return out


@numba.njit(cache=True)
def _neighbours(T, ptr, inc, i):  # pragma: no cover - compiled
    """Sorted distinct vertices of the faces opposite ``i`` (its one ring)."""
    deg = ptr[i + 1] - ptr[i]
    nb = np.empty(3 * deg, np.int64)
    for a in range(deg):
        p = inc[ptr[i] + a]
        t, k = p // 4, p % 4
        c = 0
        for j in range(4):
            if j != k:
                nb[3 * a + c] = T[t, j]
                c += 1
    return np.unique(nb)


@numba.njit(parallel=True, cache=True)
def _row_sizes(T, ptr, inc, rows):  # pragma: no cover - compiled
    out = np.empty(rows.size, np.int64)
    for r in numba.prange(rows.size):
        out[r] = _neighbours(T, ptr, inc, rows[r]).size
    return out


@numba.njit(parallel=True, cache=True, error_model="numpy")
def _fill_rows(V, T, ptr, inc, rows, indptr, indices, data, S, faces, eps):  # pragma: no cover
    for r in numba.prange(rows.size):
        i = rows[r]
        cols = _neighbours(T, ptr, inc, i)
        lo = indptr[i]
        acc = np.zeros(cols.size)
        w = np.empty(3)
        wk = np.empty((8, 3))
        area = 0.0
        special = False
        for a in range(ptr[i + 1] - ptr[i]):
            p = inc[ptr[i] + a]
            t, k = p // 4, p % 4
            f0, f1, f2 = T[t, faces[k, 0]], T[t, faces[k, 1]], T[t, faces[k, 2]]
            ux, uy, uz = V[f1, 0] - V[f0, 0], V[f1, 1] - V[f0, 1], V[f1, 2] - V[f0, 2]
            vx, vy, vz = V[f2, 0] - V[f0, 0], V[f2, 1] - V[f0, 1], V[f2, 2] - V[f0, 2]
            area += 0.5 * np.sqrt((uy * vz - uz * vy) ** 2 + (uz * vx - ux * vz) ** 2
                                  + (ux * vy - uy * vx) ** 2)
            if special:
                continue
            on = mvc_pair(V[i], V[f0], V[f1], V[f2], eps, w, wk)
            if on:  # near-face case: this face's weights alone
                acc[:] = 0.0
                special = True
            for c, f in enumerate((f0, f1, f2)):
                acc[np.searchsorted(cols, f)] += w[c]
        tot = acc.sum()
        for c in range(cols.size):
            indices[lo + c] = cols[c]
            data[lo + c] = acc[c] / tot if tot != 0.0 else 0.0
        S[i] = area
