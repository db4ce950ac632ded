"""Small canonical meshes for tests, doctests and benchmarks."""

from __future__ import annotations

import itertools

import numpy as np

__all__ = ["cube_mesh", "sphere_surface"]


def cube_mesh(n: int = 4, size: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """Tetrahedral grid of a box: ``n`` cells per axis, 6 tets per cell (Kuhn split).

    Parameters
    ----------
    n : int
        Cells per axis.
    size : tuple of 3 float
        Box edge lengths; the box spans ``[0, size]``.

    Returns
    -------
    V : ((n+1)**3, 3) float array
    T : (6 n**3, 4) int64 array
        Positively oriented tetrahedra.

    Examples
    --------
    >>> V, T = cube_mesh(1)
    >>> V.shape, T.shape
    ((8, 3), (6, 4))
    """
    g = np.arange(n + 1)
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    V = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1).astype(float) / n * np.asarray(size)

    def vid(i, j, k):
        return (i * (n + 1) + j) * (n + 1) + k

    base = np.stack(np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 3)
    tets = []
    for perm in itertools.permutations(range(3)):
        corners = [np.zeros(3, int)]
        for axis in perm:
            c = corners[-1].copy()
            c[axis] = 1
            corners.append(c)
        tet = np.stack([vid(*(base + c).T) for c in corners], axis=1)
        tets.append(tet)
    T = np.concatenate(tets).astype(np.int64)
    P = V[T]
    vol = np.einsum("ij,ij->i", np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), P[:, 3] - P[:, 0])
    neg = vol < 0
    T[neg] = T[neg][:, [0, 2, 1, 3]]
    return V, T


def sphere_surface(subdivisions: int = 4, radius: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Icosphere: a subdivided icosahedron projected on a sphere, outward oriented.

    Parameters
    ----------
    subdivisions : int
        Loop-style midpoint subdivisions (each multiplies the faces by 4).
    radius : float

    Returns
    -------
    V : (n, 3) float array
    F : (k, 3) int64 array

    Examples
    --------
    >>> V, F = sphere_surface(1)
    >>> V.shape, F.shape
    ((42, 3), (80, 3))
    """
    t = (1 + 5 ** 0.5) / 2
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                  [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], np.int64)
    for _ in range(subdivisions):
        E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(E, axis=0, return_inverse=True)
        mid = len(V) + inv.reshape(3, -1).T  # midpoints of edges (01, 12, 20)
        V = np.vstack([V, (V[uniq[:, 0]] + V[uniq[:, 1]]) / 2])
        a, b, c = F.T
        ab, bc, ca = mid.T
        F = np.concatenate([np.stack(x, 1) for x in
                            ([a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca])])
    V = V / np.linalg.norm(V, axis=1, keepdims=True) * radius
    return V, F
