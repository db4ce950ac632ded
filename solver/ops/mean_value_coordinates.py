"""3D mean value coordinates for closed triangle meshes (Ju, Schaefer & Warren 2005).

The per-triangle formula is a compiled kernel in src/core/geometry.cpp.
"""

from __future__ import annotations

import numpy as np
import tetmorph_core

__all__ = ["MVC_EPS", "mvc_pair", "mvc_triangle_weights"]

#: Tolerance of the two special cases of Ju et al.: ``pi - h < MVC_EPS`` (the
#: point lies on the triangle) and ``|s_i| <= MVC_EPS`` (the point lies in the
#: triangle's plane, outside it).
MVC_EPS = 1.0e-9


def mvc_triangle_weights(x: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unnormalised mean value weights that each triangle gives its corners.

    For a point ``x`` inside a closed triangle mesh, summing the returned
    weights of all its triangles per mesh vertex and normalising them to sum 1
    gives the mean value coordinates of ``x`` (eq. 2.1-2.3).

    Parameters
    ----------
    x : (N, 3) float array
        One query point per (point, triangle) pair.
    Q : (N, 3, 3) float array
        The triangle's corners ``Q[k, c]`` of pair ``k``.

    Returns
    -------
    w : (N, 3) float array
        Weights of the triangle's three corners, zero for triangles that are
        coplanar with ``x`` and do not contain it.
    on_face : (N,) bool array
        ``True`` where ``x`` lies on the triangle (within ``MVC_EPS``); there
        ``w`` holds the triangle's barycentric weights, and the caller must use
        them alone (the near-face case of Ju et al.).

    Notes
    -----
    Ju, Schaefer & Warren, "Mean value coordinates for closed triangular
    meshes", ACM TOG 24(3), 2005, Fig. 4 (the robust formula with
    ``theta_i = 2 arcsin(l_i / 2)``); Interactive deformation of 3D mesh models,
    eq. (2.1)-(2.3). A point at a corner gets that corner's weight only.

    Examples
    --------
    A point at the centroid of a regular tetrahedron gets equal weights:

    >>> P = np.array([[1., 1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, 1]])
    >>> faces = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
    >>> w, on = mvc_triangle_weights(np.zeros((4, 3)), P[faces])
    >>> tot = np.bincount(faces.ravel(), w.ravel())
    >>> np.allclose(tot / tot.sum(), 0.25), bool(on.any())
    (True, False)
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    Q = np.ascontiguousarray(Q, dtype=np.float64)
    w = np.empty((len(x), 3))
    on_face = np.empty(len(x), dtype=np.bool_)
    if len(x):
        tetmorph_core.geometry_mvc_weights(x, Q, MVC_EPS, w, on_face)
    return w, on_face


def mvc_pair(x: np.ndarray, q0: np.ndarray, q1: np.ndarray, q2: np.ndarray, eps: float, w: np.ndarray,
             wk: np.ndarray | None = None) -> bool:
    """Weights ``w`` (3,) that triangle ``(q0, q1, q2)`` gives its corners for point ``x``.

    Ju et al., Fig. 4, with the corner, near-face and coplanar cases;
    non-finite weights become 0. The compiled kernels (:func:`mvc_triangle_weights`,
    :func:`solver.ops.mvc_matrix.mvc_matrix`) use the same formula in
    src/core/geometry.cpp; this is the one-pair form for Python callers.

    Parameters
    ----------
    x, q0, q1, q2 : (3,) float arrays
        The point and the triangle's corners.
    eps : float
        Tolerance of the special cases (:data:`MVC_EPS`).
    w : (3,) float array
        Receives the weights.
    wk : array, optional
        Unused (scratch of an earlier version); accepted for compatibility.

    Returns
    -------
    bool
        Whether ``x`` lies on the triangle (``w`` then holds its barycentric
        weights, or the indicator of the corner ``x`` is at).

    Examples
    --------
    >>> w = np.empty(3)
    >>> mvc_pair(np.array([0.25, 0.25, 0.0]), np.zeros(3), np.array([1., 0, 0]), np.array([0., 1, 0]),
    ...          MVC_EPS, w), (w / w.sum()).round(12).tolist()
    (True, [0.5, 0.25, 0.25])
    """
    del wk
    xs = np.ascontiguousarray(x, dtype=np.float64).reshape(1, 3)
    Q = np.ascontiguousarray(np.stack([q0, q1, q2]), dtype=np.float64).reshape(1, 3, 3)
    out = np.empty((1, 3))
    on = np.empty(1, dtype=np.bool_)
    tetmorph_core.geometry_mvc_weights(xs, Q, float(eps), out, on)
    w[:3] = out[0]
    return bool(on[0])
