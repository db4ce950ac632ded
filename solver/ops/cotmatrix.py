"""Cotangent stiffness matrix and mixed Voronoi areas of a triangle surface."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .boundary_facets import simplex_edges

__all__ = ["COT_MAX", "AREA_FLOOR", "cotangents", "cotmatrix", "voronoi_areas", "uniform_matrix"]

#: Cotangents are bounded by ``COT_MAX`` in magnitude. All three cotangents of a
#: triangle share one denominator, twice its area (``cot_k = d_k / 2A`` with
#: ``d_k`` the dot product of the two edges at corner ``k``); that denominator is
#: floored at ``l_max**2 / COT_MAX`` (``l_max`` the longest edge). Slivers,
#: needles and zero-area triangles then get finite weights, and -- unlike
#: clamping each cotangent on its own -- every triangle's stiffness stays a
#: scaled Gram matrix, so ``K`` stays positive semi-definite. Triangles with all
#: angles above about 0.06 deg are not affected.
COT_MAX = 1.0e3

#: Mixed Voronoi areas are floored at ``AREA_FLOOR`` times the mean area, so a
#: vertex that touches only zero-area triangles keeps a finite row weight.
AREA_FLOOR = 1.0e-4


def cotangents(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Cotangent of each corner angle of each triangle, bounded as ``COT_MAX`` says.

    Parameters
    ----------
    V : (n, 3) float array
    F : (k, 3) int array

    Returns
    -------
    C : (k, 3) float array
        ``C[f, c]`` is the cotangent of the angle at corner ``c`` of face ``f``.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> np.round(cotangents(V, np.array([[0, 1, 2]])), 12).tolist()
    [[0.0, 1.0, 1.0]]
    """
    P = V[F]  # (k, 3 corners, 3)
    e1 = P[:, 1] - P[:, 0]
    e2 = P[:, 2] - P[:, 0]
    twice_area = np.linalg.norm(np.cross(e1, e2), axis=1)
    l2max = np.max([np.einsum("ij,ij->i", d, d) for d in (e1, e2, P[:, 2] - P[:, 1])], axis=0)
    denom = np.maximum(twice_area, l2max / COT_MAX)
    C = np.empty(F.shape, dtype=np.float64)
    for c in range(3):
        a = P[:, (c + 1) % 3] - P[:, c]
        b = P[:, (c + 2) % 3] - P[:, c]
        dot = np.einsum("ij,ij->i", a, b)
        C[:, c] = np.divide(dot, denom, out=np.zeros_like(dot), where=denom > 0)
    return C


def cotmatrix(V: np.ndarray, F: np.ndarray, n: int | None = None) -> sp.csr_matrix:
    """Cotangent stiffness matrix ``K`` (positive semi-definite).

    ``(K p)_i = 1/2 * sum_j (cot a_ij + cot b_ij) (p_i - p_j)``, so that the
    mean curvature normal of eq. (3.1) is ``L(p_i) = (K p)_i / (2 A_i)`` with the
    mixed Voronoi area ``A_i`` of :func:`voronoi_areas`.

    Parameters
    ----------
    V : (n, 3) float array
    F : (k, 3) int array
    n : int, optional
        Matrix size; defaults to ``len(V)``.

    Returns
    -------
    K : (n, n) scipy.sparse.csr_matrix
        Symmetric, rows summing to zero.

    Notes
    -----
    Interactive deformation of 3D mesh models, eq. (3.1); Meyer et al. 2003.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> K = cotmatrix(V, np.array([[0, 1, 2]]))
    >>> bool(np.abs(K.sum(axis=1)).max() < 1e-15)
    True
    """
    n = len(V) if n is None else n
    C = cotangents(V, F)
    rows, cols, vals = [], [], []
    for c in range(3):
        i, j = F[:, (c + 1) % 3], F[:, (c + 2) % 3]
        w = 0.5 * C[:, c]
        rows += [i, j]
        cols += [j, i]
        vals += [-w, -w]
    r = np.concatenate(rows)
    cidx = np.concatenate(cols)
    v = np.concatenate(vals)
    K = sp.csr_matrix((v, (r, cidx)), shape=(n, n))
    diag = -np.asarray(K.sum(axis=1)).ravel()
    return (K + sp.diags(diag)).tocsr()


def uniform_matrix(F: np.ndarray, n: int) -> sp.csr_matrix:
    """Graph Laplacian of the surface edges with unit weights (the "uniform" option).

    Parameters
    ----------
    F : (k, 3) int array
        Triangles; tetrahedra (k, 4) give the graph Laplacian of the tet edges.
    n : int

    Returns
    -------
    K : (n, n) scipy.sparse.csr_matrix
        ``K_ij = -1`` for each edge, ``K_ii`` the valence.

    Notes
    -----
    Equality-constrained least squares deformation, eq. (9) (up to the row
    scaling ``1/n_i``, which the caller applies as the row weight).
    """
    E = simplex_edges(F)
    A = sp.csr_matrix((np.ones(2 * len(E)), (np.r_[E[:, 0], E[:, 1]], np.r_[E[:, 1], E[:, 0]])),
                      shape=(n, n))
    A.data[:] = 1.0
    return (sp.diags(np.asarray(A.sum(axis=1)).ravel()) - A).tocsr()


def voronoi_areas(V: np.ndarray, F: np.ndarray, n: int | None = None) -> np.ndarray:
    """Mixed Voronoi area of every vertex (Meyer et al. 2003, Fig. 4).

    Non-obtuse triangles give each corner its Voronoi region; an obtuse
    triangle gives half its area to the obtuse corner and a quarter to each
    other corner. Areas are floored at ``AREA_FLOOR * mean`` (see module notes).

    Parameters
    ----------
    V : (n, 3) float array
    F : (k, 3) int array
    n : int, optional

    Returns
    -------
    A : (n,) float array
        Zero for vertices in no triangle.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> float(voronoi_areas(V, np.array([[0, 1, 2]])).sum())
    0.5
    """
    n = len(V) if n is None else n
    P = V[F]
    C = cotangents(V, F)
    area = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    # squared length of the edge opposite each corner
    l2 = np.stack([np.sum((P[:, (c + 2) % 3] - P[:, (c + 1) % 3]) ** 2, axis=1) for c in range(3)],
                  axis=1)
    obtuse = C < 0  # cot < 0  <=>  angle > 90 deg
    any_obtuse = obtuse.any(axis=1)
    contrib = np.empty_like(C)
    for c in range(3):
        # Voronoi part of corner c: edges (c, c+1) and (c, c+2) with opposite corners c+2, c+1
        vor = (l2[:, (c + 2) % 3] * C[:, (c + 2) % 3] + l2[:, (c + 1) % 3] * C[:, (c + 1) % 3]) / 8
        contrib[:, c] = np.where(any_obtuse, np.where(obtuse[:, c], area / 2, area / 4), vor)
    A = np.bincount(F.ravel(), weights=contrib.ravel(), minlength=n)
    used = np.bincount(F.ravel(), minlength=n) > 0
    if used.any():
        floor = AREA_FLOOR * A[used].mean()
        A[used] = np.maximum(A[used], floor)
    return A
