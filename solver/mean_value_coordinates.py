"""3D mean value coordinates for closed triangle meshes (Ju, Schaefer & Warren 2005)."""

from __future__ import annotations

import numpy as np

__all__ = ["MVC_EPS", "mvc_triangle_weights"]

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
    D = Q - x[:, None, :]
    d = np.linalg.norm(D, axis=2)  # (N, 3)
    N = len(x)
    w = np.zeros((N, 3))
    on_face = np.zeros(N, dtype=bool)
    at_vertex = d < MVC_EPS * np.maximum(d.max(axis=1, keepdims=True), 1e-300)
    safe_d = np.where(at_vertex, 1.0, d)
    U = D / safe_d[:, :, None]
    # l_i = |u_{i+1} - u_{i-1}|, theta_i = 2 asin(l_i / 2)
    idx1 = [1, 2, 0]
    idx2 = [2, 0, 1]
    ell = np.linalg.norm(U[:, idx1] - U[:, idx2], axis=2)
    theta = 2.0 * np.arcsin(np.clip(ell / 2.0, 0.0, 1.0))
    h = theta.sum(axis=1) / 2.0
    planar_inside = (np.pi - h) < MVC_EPS
    sin_t = np.sin(theta)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = 2.0 * np.sin(h)[:, None] * np.sin(h[:, None] - theta) / (sin_t[:, idx1] * sin_t[:, idx2]) - 1.0
        c = np.clip(np.nan_to_num(c, nan=1.0, posinf=1.0, neginf=-1.0), -1.0, 1.0)
        det = np.einsum("ij,ij->i", U[:, 0], np.cross(U[:, 1], U[:, 2]))
        s = np.sign(det)[:, None] * np.sqrt(1.0 - c * c)
        coplanar = np.any(np.abs(s) <= MVC_EPS, axis=1)
        num = theta - c[:, idx1] * theta[:, idx2] - c[:, idx2] * theta[:, idx1]
        general = num / (safe_d * sin_t[:, idx1] * s[:, idx2])
    ok = ~(planar_inside | coplanar)
    w[ok] = general[ok]
    # near-face case: 2D barycentric weights sin(theta_i) d_{i-1} d_{i+1}
    bary = sin_t * d[:, idx2] * d[:, idx1]
    w[planar_inside] = bary[planar_inside]
    on_face |= planar_inside
    # a point at a corner: that corner alone
    hit = at_vertex.any(axis=1)
    if hit.any():
        w[hit] = at_vertex[hit].astype(float)
        on_face |= hit
    w = np.nan_to_num(w, nan=0.0, posinf=0.0, neginf=0.0)
    return w, on_face
