"""Mean value coordinates of interior vertices with respect to their local volumes.

The row pass is a compiled kernel in src/core/geometry.cpp.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import tetmorph_core

from .elements import LINEAR_TYPES, element_blocks, element_tables
from .mean_value_coordinates import MVC_EPS

__all__ = ["mvc_matrix", "vertex_tets"]


def mvc_matrix(V: np.ndarray, T: np.ndarray, interior: np.ndarray,
               cells: dict[str, np.ndarray] | None = None) -> tuple[sp.csr_matrix, np.ndarray]:
    """Mean value coordinates ``W`` and local-volume areas ``S`` of interior vertices.

    The local volume of interior vertex ``i`` is the union of its incident
    elements; its closed boundary is made of their faces that do not contain
    ``i`` (for a tet, the face opposite ``i``; quads split into two triangles).
    Row ``i`` of ``W`` holds the 3D mean value coordinates of ``p_i`` with
    respect to that boundary, so that ``p_i = sum_j W_ij p_j`` (eq. 2.4).

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array
        Positively oriented tetrahedra.
    interior : (n,) bool array
        Which vertices get a row.
    cells : dict, optional
        Other linear volume elements by type (``"hexahedron"``, ``"wedge"``,
        ``"pyramid"``; :mod:`solver.ops.elements`).

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
    come from :func:`solver.ops.mean_value_coordinates.mvc_pair`. One compiled pass,
    parallel over the interior vertices, builds each row from the vertex's
    incident elements. A vertex on one of its faces (within ``MVC_EPS``) takes
    that face's barycentric weights alone, the first such face in element order
    (the near-face case of Ju et al.).

    Examples
    --------
    The one interior vertex of a 2x2x2 cube grid is reproduced by its weights:

    >>> from solver.testing import cube_mesh
    >>> V, T = cube_mesh(2)
    >>> from solver.ops.boundary_facets import boundary_facets
    >>> F, _ = boundary_facets(T)
    >>> interior = np.ones(len(V), bool); interior[F.ravel()] = False
    >>> W, S = mvc_matrix(V, T, interior)
    >>> bool(np.allclose(W @ V, V * interior[:, None]))
    True
    """
    n = len(V)
    V = np.ascontiguousarray(V, dtype=np.float64)
    E, kind = _padded_elements(T, cells or {})
    ptr, inc = vertex_tets(E, n)
    rows = np.flatnonzero(interior).astype(np.int64)
    opp = _OPPOSITE
    # one pass: each row's neighbours and weights into a slot of 3 entries per opposite face (an upper
    # bound on its distinct neighbours), then compacted
    faces = (opp[:, :, :, 0] >= 0).sum(axis=2)  # (types, corners): opposite triangles of each corner
    per = np.zeros(len(inc), np.int64)
    if len(inc):
        w = E.shape[1]
        per = 3 * faces[kind[inc // w], inc % w]
    cum = np.zeros(len(inc) + 1, np.int64)
    np.cumsum(per, out=cum[1:])
    slot = np.zeros(rows.size + 1, np.int64)
    slot[1:] = cum[ptr[rows + 1]] - cum[ptr[rows]]
    np.cumsum(slot, out=slot)
    cols = np.empty(slot[-1], np.int64)
    vals = np.empty(slot[-1])
    count = np.zeros(rows.size, np.int64)
    S = np.zeros(n)
    tetmorph_core.geometry_fill_rows(V, E, kind, opp, ptr, inc, rows, slot, cols, vals, count, S, MVC_EPS)
    indptr = np.zeros(n + 1, np.int64)
    indptr[rows + 1] = count
    indptr = np.cumsum(indptr)
    indices = np.empty(indptr[-1], np.int64)
    data = np.empty(indptr[-1])
    tetmorph_core.geometry_compact(rows, slot, cols, vals, count, indptr, indices, data)
    W = sp.csr_matrix((data, indices, indptr), shape=(n, n))
    W.eliminate_zeros()
    return W, S


_OPPOSITE, _ = element_tables()


def _padded_elements(T: np.ndarray, cells: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """All elements in one (M, w) array padded with -1, and their type codes (LINEAR_TYPES)."""
    blocks = [(k, np.asarray(b, np.int64)) for k, b in element_blocks(np.asarray(T).reshape(-1, 4), cells)]
    if not blocks:
        return np.zeros((0, 4), np.int64), np.zeros(0, np.int64)
    w = max(b.shape[1] for _, b in blocks)
    E = np.full((sum(len(b) for _, b in blocks), w), -1, np.int64)
    kind = np.empty(len(E), np.int64)
    at = 0
    for k, b in blocks:
        E[at:at + len(b), :b.shape[1]] = b
        kind[at:at + len(b)] = LINEAR_TYPES.index(k)
        at += len(b)
    return E, kind


def vertex_tets(E: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Incident (element, corner) pairs of every vertex, in element order.

    Parameters
    ----------
    E : (m, w) int array
        Elements; -1 entries (padding) are skipped.
    n : int
        Number of vertices.

    Returns
    -------
    ptr : (n + 1,) int array
    inc : (k,) int array
        ``inc[ptr[v]:ptr[v + 1]]`` are the flat indices ``w e + c`` with ``E[e, c] == v``.

    Examples
    --------
    >>> ptr, inc = vertex_tets(np.array([[0, 1, 2, 3], [1, 2, 3, 4]]), 5)
    >>> inc[ptr[1]:ptr[2]].tolist()
    [1, 4]
    """
    flat = np.ascontiguousarray(E, dtype=np.int64).ravel()
    ptr = np.zeros(n + 1, np.int64)
    ptr[1:] = np.cumsum(np.bincount(flat[flat >= 0], minlength=n))
    inc = np.empty(ptr[-1], np.int64)
    tetmorph_core.geometry_counting_sort(flat, ptr, inc)
    return ptr, inc
