"""3D mean value coordinates for closed triangle meshes (Ju, Schaefer & Warren 2005)."""

from __future__ import annotations

import numba
import numpy as np

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
        _mvc_kernel(x, Q, MVC_EPS, w, on_face)
    return w, on_face


@numba.njit(parallel=True, cache=True, error_model="numpy")
def _mvc_kernel(x, Q, eps, w, on_face):  # pragma: no cover - compiled
    for k in numba.prange(x.shape[0]):
        on_face[k] = mvc_pair(x[k], Q[k, 0], Q[k, 1], Q[k, 2], eps, w[k], np.empty((8, 3)))


@numba.njit(cache=True, error_model="numpy")
def mvc_pair(x, q0, q1, q2, eps, w, wk):  # pragma: no cover - compiled
    """Weights ``w`` (3,) that triangle ``(q0, q1, q2)`` gives its corners for point ``x``.

    Ju et al., Fig. 4, with the corner, near-face and coplanar cases; non-finite
    weights become 0. Returns whether ``x`` lies on the triangle. ``wk`` is (8, 3)
    scratch. Compiled; callable from other numba kernels.
    """
    U = wk[0:3]  # corner directions, unit after the corner test
    d, theta, sin_t, cc, ss = wk[3], wk[4], wk[5], wk[6], wk[7]
    for j in range(3):
        U[0, j] = q0[j] - x[j]
        U[1, j] = q1[j] - x[j]
        U[2, j] = q2[j] - x[j]
    for c in range(3):
        d[c] = np.sqrt(U[c, 0] ** 2 + U[c, 1] ** 2 + U[c, 2] ** 2)
    tol = eps * max(max(d[0], d[1]), max(d[2], 1e-300))
    if d[0] < tol or d[1] < tol or d[2] < tol:  # at a corner: that corner alone
        for c in range(3):
            w[c] = 1.0 if d[c] < tol else 0.0
        return True
    for c in range(3):
        for j in range(3):
            U[c, j] /= d[c]
    for i in range(3):  # l_i = |u_{i+1} - u_{i-1}|, theta_i = 2 asin(l_i / 2)
        a, b = (i + 1) % 3, (i + 2) % 3
        ell = np.sqrt((U[a, 0] - U[b, 0]) ** 2 + (U[a, 1] - U[b, 1]) ** 2 + (U[a, 2] - U[b, 2]) ** 2)
        theta[i] = 2.0 * np.arcsin(min(max(ell / 2.0, 0.0), 1.0))
        sin_t[i] = np.sin(theta[i])
    h = 0.5 * (theta[0] + theta[1] + theta[2])
    if np.pi - h < eps:  # on the triangle: 2D barycentric weights sin(theta_i) d_{i-1} d_{i+1}
        for i in range(3):
            w[i] = sin_t[i] * d[(i + 1) % 3] * d[(i + 2) % 3]
        return True
    det = (U[0, 0] * (U[1, 1] * U[2, 2] - U[1, 2] * U[2, 1])
           + U[0, 1] * (U[1, 2] * U[2, 0] - U[1, 0] * U[2, 2])
           + U[0, 2] * (U[1, 0] * U[2, 1] - U[1, 1] * U[2, 0]))
    sgn = 1.0 if det > 0 else (-1.0 if det < 0 else 0.0)
    coplanar = False
    for i in range(3):
        ci = 2.0 * np.sin(h) * np.sin(h - theta[i]) / (sin_t[(i + 1) % 3] * sin_t[(i + 2) % 3]) - 1.0
        if np.isnan(ci) or ci > 1.0:
            ci = 1.0
        elif ci < -1.0:
            ci = -1.0
        cc[i] = ci
        ss[i] = sgn * np.sqrt(1.0 - ci * ci)
        if abs(ss[i]) <= eps:
            coplanar = True
    for i in range(3):  # x in the triangle's plane, outside it: no contribution
        a, b = (i + 1) % 3, (i + 2) % 3
        wi = 0.0
        if not coplanar:
            wi = (theta[i] - cc[a] * theta[b] - cc[b] * theta[a]) / (d[i] * sin_t[a] * ss[b])
            if not np.isfinite(wi):
                wi = 0.0
        w[i] = wi
    return False
