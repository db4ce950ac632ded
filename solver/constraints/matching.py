"""Node correspondences for symmetry, cyclic symmetry and non-matching ties.

A *slave* node ``s`` is matched to the *master* side through a rigid map
``p_s = A p + t`` (``A`` orthogonal: a reflection for mirror symmetry, a
rotation for cyclic sectors, the identity for ties): its preimage
``A^T (p_s - t)`` is looked up among the master nodes (an exact pair when one
lies within the tolerance) and otherwise projected on the master boundary
faces (a barycentric point). The rows built from a :class:`Matching` hold
``p_s = A sum_k w_k p_{m_k} + t`` exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import MAX_IDS, ConstraintError, format_ids
from ..ops.closest_point import TriangleSurface

__all__ = ["Matching", "match", "reflection", "rotation"]


@dataclass(frozen=True, eq=False)
class Matching:
    """Slave nodes and the master points they map to.

    Attributes
    ----------
    slaves : (s,) int array
    masters : (s, 3) int array
        Master nodes of each slave's point (a repeated node for an exact pair).
    weights : (s, 3) float array
        Barycentric weights (``[1, 0, 0]`` for an exact pair).
    A : (3, 3) float array
    t : (3,) float array
    gap : (s,) float array
        Rest distance between each slave and the image of its master point.
    """

    slaves: np.ndarray
    masters: np.ndarray
    weights: np.ndarray
    A: np.ndarray
    t: np.ndarray
    gap: np.ndarray

    @property
    def exact_pairs(self) -> int:
        """Slaves matched to a single master node."""
        return int((self.weights[:, 0] == 1.0).sum())


def reflection(point: np.ndarray, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(M, t)`` with ``M p + t`` the mirror image of ``p`` across the plane (unit ``normal``)."""
    n = np.asarray(normal, float)
    M = np.eye(3) - 2.0 * np.outer(n, n)
    return M, 2.0 * n * float(n @ np.asarray(point, float))


def rotation(point: np.ndarray, direction: np.ndarray, angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """``(R, t)`` with ``R p + t`` the turn of ``p`` by ``angle_deg`` about the axis (unit ``direction``)."""
    from .move import axis_angle_matrix

    R = axis_angle_matrix(np.asarray(direction, float), math.radians(angle_deg))
    o = np.asarray(point, float)
    return R, o - R @ o


def match(V: np.ndarray, slaves: np.ndarray, master_nodes: np.ndarray, master_faces: np.ndarray,
          A: np.ndarray, t: np.ndarray, tol: float, what: str, require_all: bool = True) -> Matching:
    """Match ``slaves`` to the master side under ``p_s = A p + t``.

    Parameters
    ----------
    V : (n, 3) float array
        Rest positions.
    slaves : (s,) int array
    master_nodes : (m,) int array
        Nodes a slave may pair with exactly.
    master_faces : (f, 3) int array
        Master boundary triangles, for slaves with no master node within ``tol``.
    A, t : (3, 3) and (3,) float arrays
    tol : float
        Largest distance of a slave's preimage from the master side.
    what : str
        Name for error messages.
    require_all : bool
        Refuse when some slave finds no partner (else those are left out).

    Returns
    -------
    Matching

    Raises
    ------
    ConstraintError
        ``unmatched_nodes``: slaves with no master point within ``tol`` (their count and first ids).
    """
    slaves = np.asarray(slaves, np.int64)
    pre = (V[slaves] - t) @ A  # A^T (p - t), row-wise
    s = slaves.size
    masters = np.zeros((s, 3), np.int64)
    weights = np.zeros((s, 3))
    gap = np.full(s, np.inf)
    done = np.zeros(s, bool)
    if s and master_nodes.size:
        from scipy.spatial import cKDTree  # scipy.spatial loads on first use

        d, k = cKDTree(V[master_nodes]).query(pre)
        hit = d <= tol
        masters[hit] = master_nodes[k[hit], None]
        weights[hit, 0] = 1.0
        gap[hit] = d[hit]
        done = hit
    rest = np.flatnonzero(~done)
    if rest.size and len(master_faces):
        cp = TriangleSurface(V, master_faces).closest(pre[rest])
        ok = cp.dist <= tol
        r = rest[ok]
        masters[r] = master_faces[cp.tri[ok]]
        weights[r] = cp.bary[ok]
        gap[r] = cp.dist[ok]
        done[r] = True
    if require_all and not done.all():
        bad = slaves[~done]
        raise ConstraintError(
            f"{what}: {bad.size} of {s} nodes find no partner within {tol:.3g} (first nodes {format_ids(bad)}); "
            "the two sides do not match under the given plane or axis: check it, or raise the tolerance",
            code="unmatched_nodes", unmatched=int(bad.size), nodes=bad[:MAX_IDS].tolist(), tolerance=tol)
    return Matching(slaves[done], masters[done], weights[done], A, t, gap[done])
