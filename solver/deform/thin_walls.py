"""Rows that tie the two faces of walls one element thick (``SPEC.thin_walls``).

An element whose nodes are all on the boundary gets no mean-value row:
nothing in the paper's system holds the wall's thickness, and such walls
invert first (measured on kiefer_fea_bracket.vtu). For every edge of such an
element that is not an edge of the boundary surface (it crosses the wall), a
soft row ``w_ij (p_i - p_j) = w_ij s R_ij (p0_i - p0_j)`` keeps the edge's rest
vector, turned and scaled by the rotation field averaged over its two ends.
``w_ij = thin_walls * sqrt(|L_ii| |L_jj|)`` matches the boundary rows'
magnitude. Meshes without all-boundary elements are unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..mesh import Mesh
from ..ops.boundary_facets import simplex_edges
from ..ops.elements import element_edges
from ..ops.rotation import rotate_by_log
from ..ops.unique import unique_rows

__all__ = ["WallRows", "wall_rows"]


@dataclass(frozen=True, eq=False)
class WallRows:
    """The thin-wall rows of one mesh.

    Attributes
    ----------
    E : (k, 2) int array
        Edges crossing walls one element thick.
    w : (k,) float array
        Row weights.
    D0 : (k, 3) float array
        Rest edge vectors ``p0_i - p0_j``.
    """

    E: np.ndarray
    w: np.ndarray
    D0: np.ndarray

    def matrix(self, unknowns: np.ndarray, n: int) -> sp.csr_matrix:
        """(k, u) rows over the unknowns ``unknowns``."""
        umap = np.full(n, -1, np.int64)
        umap[unknowns] = np.arange(unknowns.size)
        k = np.arange(self.E.shape[0])
        return sp.csr_matrix((np.r_[self.w, -self.w], (np.r_[k, k], np.r_[umap[self.E[:, 0]], umap[self.E[:, 1]]])),
                             shape=(self.E.shape[0], unknowns.size))

    def rhs(self, r: np.ndarray, sigma: np.ndarray, bpos: np.ndarray) -> np.ndarray:
        """(k, 3) right-hand side for boundary rotation logarithms ``r`` and log-scales ``sigma``."""
        a, b = bpos[self.E[:, 0]], bpos[self.E[:, 1]]
        rr = 0.5 * (r[a] + r[b])
        return rotate_by_log(self.D0, rr, self.w * np.exp(0.5 * (sigma[a] + sigma[b])))


def wall_rows(mesh: Mesh, weight: float, Lb: sp.csr_matrix) -> WallRows | None:
    """Thin-wall rows of ``mesh`` with weight ``weight`` (None when there are none or weight is 0).

    Parameters
    ----------
    mesh : Mesh
    weight : float
        ``SPEC.thin_walls``.
    Lb : (n, n) sparse matrix
        Boundary rows (their diagonals scale the weights).

    Returns
    -------
    WallRows or None
    """
    if weight <= 0 or mesh.is_surface:
        return None
    parts = []
    for kind, B in mesh.blocks:  # elements with every node on the boundary
        B = B[mesh.boundary[B].all(axis=1)]
        if len(B):
            parts.append(simplex_edges(B) if kind == "tetra" else element_edges(B, kind))
    if not parts:
        return None
    E = unique_rows(np.sort(np.concatenate(parts), axis=1))
    FE = simplex_edges(mesh.F)
    n = mesh.n
    key = E[:, 0] * n + E[:, 1]
    E = E[~np.isin(key, FE[:, 0] * n + FE[:, 1])]
    if not E.size:
        return None
    d = np.abs(Lb.diagonal())
    w = weight * np.sqrt(d[E[:, 0]] * d[E[:, 1]])
    return WallRows(E, w, mesh.V[E[:, 0]] - mesh.V[E[:, 1]])
