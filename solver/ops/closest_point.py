"""Closest points on triangle meshes: exact point-triangle projection on KD-tree candidates.

For each query point the candidate triangles are those incident to its
``k`` nearest surface vertices (:class:`scipy.spatial.cKDTree`); each
candidate is projected exactly (the Voronoi-region walk of Ericson,
*Real-Time Collision Detection*, §5.1.5) and the nearest projection wins.
Rays (for projection along a normal) are intersected with candidate
triangles the same way (Möller–Trumbore). Both loops are compiled kernels
in src/core/geometry.cpp.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import tetmorph_core

from .unique import unique

__all__ = ["TriangleSurface", "ClosestPoints", "closest_points"]


@dataclass(frozen=True, eq=False)
class ClosestPoints:
    """Projections of query points on a triangle surface.

    Attributes
    ----------
    tri : (q,) int array
        Triangle of each projection (-1 where a ray hit nothing).
    bary : (q, 3) float array
        Barycentric coordinates in that triangle.
    points : (q, 3) float array
    dist : (q,) float array
        Distance from the query point.
    """

    tri: np.ndarray
    bary: np.ndarray
    points: np.ndarray
    dist: np.ndarray


class TriangleSurface:
    """A triangle surface prepared for closest-point and ray queries (immutable).

    Parameters
    ----------
    V : (n, 3) float array
    F : (k, 3) int array
    """

    def __init__(self, V: np.ndarray, F: np.ndarray) -> None:
        self.V = np.ascontiguousarray(V, dtype=np.float64)
        self.F = np.ascontiguousarray(F, dtype=np.int64)
        used = unique(self.F)
        self._used = used
        from scipy.spatial import cKDTree  # scipy.spatial loads on first use

        self._tree = cKDTree(self.V[used])
        k = self.F.shape[0]
        self._vt = sp.csr_matrix((np.ones(3 * k), (self.F.ravel(), np.repeat(np.arange(k), 3))),
                                 shape=(len(self.V), k))
        ext = self.V[used].max(0) - self.V[used].min(0) if used.size else np.zeros(3)
        self.diagonal = float(np.linalg.norm(ext))

    def _candidates(self, Q: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        k = min(k, self._used.size)
        _, nn = self._tree.query(Q, k=k)
        nn = self._used[np.asarray(nn).reshape(len(Q), -1)]
        rows = np.repeat(np.arange(len(Q)), nn.shape[1])
        S = sp.csr_matrix((np.ones(rows.size), (rows, nn.ravel())), shape=(len(Q), len(self.V))) @ self._vt
        S = sp.csr_matrix(S)
        S.sort_indices()
        return S.indptr.astype(np.int64), S.indices.astype(np.int64)

    def closest(self, Q: np.ndarray, k: int = 12) -> ClosestPoints:
        """Closest points of ``Q`` (q, 3) on the surface."""
        Q = np.ascontiguousarray(Q, dtype=np.float64)
        q = len(Q)
        tri = np.full(q, -1, np.int64)
        bary = np.zeros((q, 3))
        dist = np.full(q, np.inf)
        if q and len(self.F):
            ptr, cand = self._candidates(Q, k)
            tetmorph_core.geometry_closest_best(Q, self.V, self.F, ptr, cand, tri, bary, dist)
        pts = np.einsum("qi,qij->qj", bary, self.V[self.F[np.maximum(tri, 0)]])
        return ClosestPoints(tri, bary, pts, dist)

    def along(self, X0: np.ndarray, D: np.ndarray, k: int = 24) -> ClosestPoints:
        """Intersections of the lines ``X0 + s D`` with the surface, nearest ``|s|`` (tri -1: none found)."""
        X0 = np.ascontiguousarray(X0, dtype=np.float64)
        D = np.ascontiguousarray(D, dtype=np.float64)
        q = len(X0)
        tri = np.full(q, -1, np.int64)
        bary = np.zeros((q, 3))
        s = np.zeros(q)
        if q and len(self.F):
            guess = self.closest(X0).points  # candidates around the closest point
            ptr, cand = self._candidates(guess, k)
            tetmorph_core.geometry_rays(X0, D, self.V, self.F, ptr, cand, tri, bary, s)
        pts = np.where((tri >= 0)[:, None], np.einsum("qi,qij->qj", bary, self.V[self.F[np.maximum(tri, 0)]]), X0)
        return ClosestPoints(tri, bary, pts, np.where(tri >= 0, np.abs(s) * np.linalg.norm(D, axis=1), np.inf))


def closest_points(V: np.ndarray, F: np.ndarray, Q: np.ndarray) -> ClosestPoints:
    """Closest points of ``Q`` (q, 3) on the triangle mesh ``(V, F)``.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> r = closest_points(V, np.array([[0, 1, 2]]), np.array([[0.2, 0.2, 1.0], [2.0, 0.0, 0.0]]))
    >>> r.points.round(12).tolist(), r.dist.round(12).tolist()
    ([[0.2, 0.2, 0.0], [1.0, 0.0, 0.0]], [1.0, 1.0])
    """
    return TriangleSurface(V, F).closest(Q)
