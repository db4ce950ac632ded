"""Mean value coordinates of interior vertices with respect to their local volumes."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .boundary_facets import TET_FACES
from .mean_value_coordinates import mvc_triangle_weights

__all__ = ["mvc_matrix"]

#: (point, triangle) pairs evaluated per vectorised chunk; bounds peak memory.
CHUNK_PAIRS = 400_000


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
    T = np.asarray(T, dtype=np.int64)
    rows_l, cols_l, vals_l, onf_l, pair_l = [], [], [], [], []
    S = np.zeros(n)
    pair_base = 0
    for k in range(4):
        sel = np.flatnonzero(interior[T[:, k]])
        for start in range(0, sel.size, CHUNK_PAIRS):
            tets = sel[start:start + CHUNK_PAIRS]
            i = T[tets, k]
            face = T[tets][:, TET_FACES[k]]
            Q = V[face]
            w, on = mvc_triangle_weights(V[i], Q)
            area = 0.5 * np.linalg.norm(np.cross(Q[:, 1] - Q[:, 0], Q[:, 2] - Q[:, 0]), axis=1)
            S += np.bincount(i, weights=area, minlength=n)
            rows_l.append(np.repeat(i, 3))
            cols_l.append(face.ravel())
            vals_l.append(w.ravel())
            onf_l.append(on)
            pair_l.append(i)
            pair_base += len(i)
    if not rows_l:
        return sp.csr_matrix((n, n)), S
    rows = np.concatenate(rows_l)
    cols = np.concatenate(cols_l)
    vals = np.concatenate(vals_l)
    on_face = np.concatenate(onf_l)
    owner = np.concatenate(pair_l)
    if on_face.any():
        # near-face case: a point on one of its faces takes that face's weights alone
        first = {}
        for p in np.flatnonzero(on_face):
            first.setdefault(int(owner[p]), p)
        special = np.zeros(n, bool)
        special[list(first)] = True
        keep = np.ones(len(owner), bool)
        keep[special[owner]] = False
        keep[list(first.values())] = True
        vals = (vals.reshape(-1, 3) * keep[:, None]).ravel()
    W = sp.csr_matrix((vals, (rows, cols)), shape=(n, n))
    W.sum_duplicates()
    tot = np.asarray(W.sum(axis=1)).ravel()
    scale = np.zeros(n)
    np.divide(1.0, tot, out=scale, where=tot != 0)
    W = sp.diags(scale) @ W
    W.eliminate_zeros()
    return W.tocsr(), S
