"""Local repair of inverted tetrahedra by moving free interior vertices.

After the linear solve, the tets around the inverted ones are untangled by
minimising, over the positions of the *free interior* vertices of a patch
(vertices in no hard constraint, not on the boundary), ::

    E(x) = sum_t  1 / h(v_t)  +  alpha (v_t - 1)^2,      v_t = vol_t(x) / vol_t(rest)

with ``h(v) = (v + sqrt(v^2 + 4 delta^2)) / 2`` the regularised positive part
used by Escobar et al. ("Simultaneous untangling and smoothing of
tetrahedral meshes", CMAME 2003) so that the energy stays finite, and very
large, for inverted tets. The first term pushes every normalised volume up
and away from zero; the second keeps volumes near their rest values.
Boundary and constrained vertices do not move, so the surface and every hard
constraint are exactly as the solve left them. The patch grows by one ring
of tets when a pass leaves tets inverted; the result is accepted only if it
has fewer inverted tets and is otherwise no worse.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..errors import MAX_IDS
from .quality import DEGENERATE_TOL, signed_volumes, tet_quality

__all__ = ["RepairResult", "repair_inverted"]

#: Regularisation of h(v), in units of the rest volume.
DELTA = 1e-3
#: Weight of the volume-preservation term.
ALPHA = 0.1


@dataclass
class RepairResult:
    """Outcome of :func:`repair_inverted`.

    Attributes
    ----------
    V : (n, 3) array
        Repaired positions (the input when ``success`` is False).
    success : bool
        Every tet valid afterwards.
    report : dict
        ``attempted``, ``success``, ``accepted`` (whether ``V`` differs from the input),
        ``inverted_before``, ``inverted_after``, ``repaired_elements`` (first 100 ids),
        ``moved_vertices``, ``min_scaled_jacobian_before``, ``min_scaled_jacobian_after``,
        ``passes``, ``ms``, and ``reason`` when it failed.
    """

    V: np.ndarray
    success: bool
    report: dict = field(default_factory=dict)


def _bad(P: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    vol6, sj = tet_quality(P, T)
    return (vol6 <= 0) | (np.abs(sj) <= DEGENERATE_TOL), sj


def _energy(x: np.ndarray, P: np.ndarray, Tp: np.ndarray, idx: np.ndarray, vol0: np.ndarray
            ) -> tuple[float, np.ndarray]:
    Q = P.copy()
    Q[idx] = x.reshape(-1, 3)
    a, b, c, d = (Q[Tp[:, k]] for k in range(4))
    ab, ac, ad = b - a, c - a, d - a
    gb = np.cross(ac, ad) / 6.0
    gc = np.cross(ad, ab) / 6.0
    gd = np.cross(ab, ac) / 6.0
    v = np.einsum("ij,ij->i", ab, gb) / vol0
    s = np.sqrt(v * v + 4 * DELTA * DELTA)
    h = 0.5 * (v + s)
    E = float(np.sum(1.0 / h + ALPHA * (v - 1.0) ** 2))
    dh = 0.5 * (1.0 + v / s)
    dEdv = (-dh / (h * h) + 2 * ALPHA * (v - 1.0)) / vol0
    n = Q.shape[0]
    rows = Tp[:, [1, 2, 3, 0]].T.ravel()
    W = np.concatenate([gb, gc, gd, -(gb + gc + gd)]) * np.tile(dEdv, 4)[:, None]
    G = np.stack([np.bincount(rows, W[:, c], minlength=n) for c in range(3)], axis=1)
    return E, G[idx].ravel()


def repair_inverted(V0: np.ndarray, P: np.ndarray, T: np.ndarray, movable: np.ndarray,
                    rings: int = 2, max_passes: int = 3, max_iter: int = 200) -> RepairResult:
    """Untangle the inverted tets of ``P`` by moving ``movable`` vertices near them.

    Parameters
    ----------
    V0 : (n, 3) array
        Rest positions (rest volumes normalise the energy).
    P : (n, 3) array
        Deformed positions from the linear solve.
    T : (m, 4) int array
    movable : (n,) bool array
        Vertices that may move (free interior vertices).
    rings : int
        Tet rings around the inverted tets in the first patch; each further
        pass adds one.
    max_passes, max_iter : int
        Patch enlargements, and L-BFGS iterations per pass.

    Returns
    -------
    RepairResult
    """
    t0 = time.perf_counter()
    bad0, sj0 = _bad(P, T)
    rep: dict[str, Any] = {"attempted": True, "inverted_before": int(bad0.sum()),
           "min_scaled_jacobian_before": float(sj0.min())}
    if not bad0.any():
        rep.update(success=True, accepted=False, inverted_after=0, repaired_elements=[], moved_vertices=0,
                   min_scaled_jacobian_after=float(sj0.min()), passes=0, ms=0.0)
        return RepairResult(P, True, rep)
    n = V0.shape[0]
    vol_rest = np.abs(signed_volumes(V0, T))
    # vertex-tet incidence, to grow the patch ring by ring
    m = T.shape[0]
    inc = sp.csr_matrix((np.ones(4 * m), (T.ravel(), np.repeat(np.arange(m), 4))), shape=(n, m))
    cur = P.copy()
    tets = bad0.copy()
    for _ in range(rings):
        tets = (inc.T @ (inc @ tets) > 0)
    passes = 0
    moved = np.zeros(n, bool)
    bad = bad0
    for passes in range(1, max_passes + 1):  # noqa: B007 - the count is reported after the loop
        verts = np.zeros(n, bool)
        verts[T[tets].ravel()] = True
        idx = np.flatnonzero(verts & movable)
        if idx.size:
            ring = (inc[idx].sum(axis=0).A1 > 0)  # every tet that a moving vertex touches
            Tp = T[ring]
            from scipy.optimize import minimize  # loaded only when a repair runs (about 0.1 s)

            res = minimize(_energy, cur[idx].ravel(), args=(cur, Tp, idx, vol_rest[ring]), jac=True,
                           method="L-BFGS-B", options={"maxiter": max_iter})
            trial = cur.copy()
            trial[idx] = res.x.reshape(-1, 3)
            if np.isfinite(trial).all():
                tbad, _ = _bad(trial, T)
                if tbad.sum() < bad.sum():
                    cur, bad = trial, tbad
                    moved[idx] = True
        if not bad.any():
            break
        tets = (inc.T @ (inc @ (tets | bad)) > 0)
    _, sj = _bad(cur, T)
    success = not bad.any()
    accepted = bool(bad.sum() < bad0.sum())
    out = cur if accepted else P
    fixed_ids = np.flatnonzero(bad0 & ~bad) if accepted else np.zeros(0, np.int64)
    rep.update(success=success, accepted=accepted, inverted_after=int(bad.sum()) if accepted else int(bad0.sum()),
               repaired_elements=fixed_ids[:MAX_IDS].tolist(),
               moved_vertices=int(moved.sum()) if accepted else 0,
               min_scaled_jacobian_after=float(sj.min()) if accepted else float(sj0.min()),
               passes=passes, ms=1e3 * (time.perf_counter() - t0))
    if not success:
        left = bad if accepted else bad0
        stuck = np.flatnonzero(left)
        no_free = [int(t) for t in stuck[:MAX_IDS] if not movable[T[t]].any()]
        rep["reason"] = (f"{int(left.sum())} tets stay inverted"
                         + (f"; {len(no_free)} of them have no free interior vertex (thin walls: all four "
                            "vertices on the boundary or constrained)" if no_free else ""))
        rep["unrepaired_ids"] = stuck[:MAX_IDS].tolist()
    return RepairResult(out, success, rep)
