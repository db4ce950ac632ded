"""Quadratic tetrahedra (tetra10 / C3D10): mid-side nodes and the ten-node Jacobian.

The method deforms the corner nodes. A mid-side node ``m`` of edge ``(a, b)``
keeps its offset from the chord, carried by the local deformation:
``m' = (a' + b') / 2 + G (m0 - (a0 + b0) / 2)``, where ``G`` is the deformation
gradient averaged over the tets that share the edge (``F_t = D_t D0_t^-1`` from
each tet's corners). A curved edge stays curved as it was, turned, stretched
and sheared with its neighbourhood; a straight edge stays straight; any affine
motion (rigid ones included) moves the quadratic elements exactly.

Carrying the offset with only the rotation and the edge's stretch (``s R`` from
the polar decomposition of ``G``) folds more elements. Measured on
kiefer_fea_bracket.vtu with the tests' bend (10°/15°/20°): 1/4/18 elements with
a non-positive node Jacobian, against 0/0/2 with ``G``
(benchmarks/measure_choices.py --only midside).

Validity of a quadratic tet is checked with the Jacobian of its quadratic map
``x(xi) = sum_i x_i N_i(xi)`` at its ten nodes (a curved edge can fold an element
whose corner tet is fine). Node order is VTK/meshio and Abaqus C3D10: corners 0..3,
then edges 01, 12, 02, 03, 13, 23.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..ops.elements import TET10_EDGES as EDGES
from ..ops.elements import midside_edges
from ..ops.unique import unique
from .quality import tet_quality

__all__ = ["EDGES", "MidsideNodes", "Placement", "node_jacobians"]


def _reference_nodes() -> np.ndarray:
    """Barycentric coordinates (10, 4) of the ten nodes."""
    L = np.zeros((10, 4))
    L[np.arange(4), np.arange(4)] = 1.0
    for k, (i, j) in enumerate(EDGES):
        L[4 + k, [i, j]] = 0.5
    return L


def _shape_gradients() -> np.ndarray:
    """Derivatives d N_i / d xi_k at each node: (10 nodes, 10 shape functions, 3).

    xi = (L1, L2, L3), L0 = 1 - L1 - L2 - L3; N_i = L_i (2 L_i - 1) at corners,
    4 L_i L_j at the mid-side node of edge (i, j).
    """
    Ln = _reference_nodes()
    dL = np.array([[-1.0, -1, -1], [1, 0, 0], [0, 1, 0], [0, 0, 1]])  # dL_c / dxi
    G = np.zeros((10, 10, 3))
    for n in range(10):
        L = Ln[n]
        for c in range(4):
            G[n, c] = (4 * L[c] - 1) * dL[c]
        for k, (i, j) in enumerate(EDGES):
            G[n, 4 + k] = 4 * (L[j] * dL[i] + L[i] * dL[j])
    return G


_DN = _shape_gradients()


def node_jacobians(V: np.ndarray, T10: np.ndarray) -> np.ndarray:
    """Determinant of the quadratic map's Jacobian at the ten nodes of each element.

    Parameters
    ----------
    V : (n, 3) float array
    T10 : (m, 10) int array

    Returns
    -------
    (m, 10) float array
        Positive for a valid, positively oriented element; for a straight-sided
        element every entry is ``6 * volume``.

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> T10 = np.array([[0, 1, 2, 3, 4, 5, 6, 7, 8, 9]])
    >>> mids = np.array([(V[i] + V[j]) / 2 for i, j in EDGES])
    >>> np.round(node_jacobians(np.vstack([V, mids]), T10), 12).tolist()[0][:3]
    [1.0, 1.0, 1.0]
    """
    X = V[T10]  # (m, 10, 3)
    J = np.tensordot(X, _DN, axes=([1], [1]))  # (m, 3, 10 nodes, 3): J[m, a, n, b]
    a, b, c = J[:, 0], J[:, 1], J[:, 2]  # rows of J at every node, (m, 10, 3) each
    return (a[..., 0] * (b[..., 1] * c[..., 2] - b[..., 2] * c[..., 1])
            - a[..., 1] * (b[..., 0] * c[..., 2] - b[..., 2] * c[..., 0])
            + a[..., 2] * (b[..., 0] * c[..., 1] - b[..., 1] * c[..., 0]))


@dataclass(frozen=True, eq=False)
class Placement:
    """Positions with the mid-side nodes placed, and what the placement did.

    Attributes
    ----------
    P : (n, 3) float array
        Every node's position.
    jacobians : (m, 10) float array or None
        Node Jacobians of every element at ``P`` (when validity was checked).
    relaxed : dict or None
        ``{"midside_nodes", "elements", "min_factor"}`` when curved edges were
        flattened to keep elements valid, else None.
    """

    P: np.ndarray
    jacobians: np.ndarray | None = None
    relaxed: dict[str, Any] | None = None


class MidsideNodes:
    """Placement of the mid-side nodes of a tetra10 mesh: set up once, immutable, applied per solve.

    Parameters
    ----------
    V0 : (n, 3) array
        Rest positions.
    T10 : (m, 10) int array
    """

    def __init__(self, V0: np.ndarray, T10: np.ndarray) -> None:
        m = T10.shape[0]
        ids = T10[:, 4:].ravel()
        self.ids, self.a, self.b = midside_edges(T10)
        # tets sharing each mid-side node: average their deformation gradients
        rows = np.searchsorted(self.ids, ids)
        tets = np.repeat(np.arange(m), 6)
        A = sp.csr_matrix((np.ones(ids.size), (rows, tets)), shape=(self.ids.size, m))
        self._avg = sp.diags(1.0 / np.asarray(A.sum(axis=1)).ravel()) @ A
        self._node_tets = A.tocsr()
        self._slot = np.searchsorted(self.ids, T10[:, 4:])  # (m, 6) mid-side node of each slot
        self.T10 = T10
        self.T = np.ascontiguousarray(T10[:, :4])
        P = V0[self.T]
        D0 = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]], axis=2)  # columns
        self._D0inv = np.linalg.inv(D0)
        self._off0 = V0[self.ids] - 0.5 * (V0[self.a] + V0[self.b])
        self._V0 = V0
        self._rest_mid = V0[self.ids]

    @property
    def rest_offsets(self) -> np.ndarray:
        """(k, 3) offsets of the mid-side nodes from their chords' midpoints, at rest."""
        return self._off0

    def gradients(self, P: np.ndarray) -> np.ndarray:
        """(k, 3, 3) deformation gradient around each mid-side node: the mean of its tets' ``F_t``.

        Linear in ``P``: of displacements ``P - V0`` it is ``F - I``.
        """
        Q = P[self.T]
        D = np.stack([Q[:, 1] - Q[:, 0], Q[:, 2] - Q[:, 0], Q[:, 3] - Q[:, 0]], axis=2)
        F = D @ self._D0inv  # (m, 3, 3) deformation gradients
        return (self._avg @ F.reshape(-1, 9)).reshape(-1, 3, 3)

    def rotations(self, P: np.ndarray) -> np.ndarray:
        """(k, 3, 3) rotation of each mid-side node's neighbourhood at positions ``P`` (polar part)."""
        U, _, Vt = np.linalg.svd(self.gradients(P))
        d = np.sign(np.linalg.det(U @ Vt))  # a proper rotation even where the average reflects
        U[:, :, 2] *= d[:, None]
        return U @ Vt

    def place(self, P: np.ndarray, valid: np.ndarray | None = None, pinned: np.ndarray | None = None,
              pinned_at: np.ndarray | None = None) -> Placement:
        """Positions with every mid-side node placed from its corners (a new array).

        Parameters
        ----------
        P : (n, 3) array
            Positions whose corner nodes are final.
        valid : (m,) bool array, optional
            Elements valid at rest. When given, an element of them that the
            placement folds (a node Jacobian <= 0) while its corner tet is
            still positive gets its mid-side nodes' curvature offsets halved,
            up to five times and then removed, until no such element is left:
            a curved edge is flattened only as far as needed to keep its
            elements valid. Pinned nodes are never relaxed.
        pinned : (p,) int array, optional
            Mid-side nodes held by hard constraints (fixed or handle selections).
        pinned_at : (p, 3) array, optional
            Their exact positions.

        Returns
        -------
        Placement
        """
        out = P.copy()
        # summed as changes from rest (F - I from the displacements): corners at rest leave every
        # mid-side node at rest bit for bit
        U = P - self._V0
        bend = np.einsum("kab,kb->ka", self.gradients(U), self._off0)
        out[self.ids] = self._rest_mid + (0.5 * (U[self.a] + U[self.b]) + bend)
        free = np.ones(self.ids.size, bool)
        if pinned is not None and pinned.size:
            out[pinned] = pinned_at
            free[np.searchsorted(self.ids, pinned)] = False
        if valid is None:
            return Placement(out)
        dj = node_jacobians(out, self.T10)
        corner_ok = tet_quality(out, self.T)[0] > 0  # the straight-sided element
        bad = (dj.min(axis=1) <= 0) & valid & corner_ok
        relaxed = None
        if bad.any():
            mid = 0.5 * (P[self.a] + P[self.b])
            curv = self._off0 + bend
            alpha = np.ones(self.ids.size)
            touched = np.zeros(len(dj), bool)
            for step in range(6):
                nodes = unique(self._slot[bad])
                nodes = nodes[free[nodes]]
                if not nodes.size:
                    break
                alpha[nodes] = 0.0 if step == 5 else alpha[nodes] / 2
                out[self.ids[nodes]] = mid[nodes] + alpha[nodes, None] * curv[nodes]
                elems = unique(self._node_tets[nodes].indices)
                touched[elems] = True
                dj[elems] = node_jacobians(out, self.T10[elems])
                bad = np.zeros(len(dj), bool)
                bad[elems] = (dj[elems].min(axis=1) <= 0) & valid[elems] & corner_ok[elems]
                if not bad.any():
                    break
            changed = alpha < 1
            if changed.any():
                relaxed = {"midside_nodes": int(changed.sum()), "elements": int(touched.sum()),
                           "min_factor": float(alpha[changed].min())}
        return Placement(out, dj, relaxed)
