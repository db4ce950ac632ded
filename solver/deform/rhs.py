"""Right-hand sides of one MOVE: fixed and handle targets, rotated normals, wall rows, hard-row targets."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constraints.assembly import block_targets
from ..constraints.move import ResolvedMove
from ..mesh import Mesh
from ..ops.rotation import rotate_by_log
from .constraint_set import ConstraintSet, edit_owner
from .rotation_field import RotationField
from .thin_walls import WallRows

__all__ = ["RightHandSides", "right_hand_sides", "handle_targets"]


@dataclass(frozen=True, eq=False)
class RightHandSides:
    """What one MOVE asks of the position solve.

    Attributes
    ----------
    U : (k, 3) float array
        Targets of the fixed, handle and edit corner nodes (``ConstraintSet.constrained`` order).
    c : (l, 3) float array
        Soft rows' right-hand side: the rotated and scaled mean curvature
        normals ``s_i R_i delta_i`` of the position system's vertex rows (eq. 3.2;
        zero on interior rows), then the thin-wall rows.
    d : (m, 3) or (m, 1) float array or None
        Targets of the hard constraint rows (None without a position system).
    """

    U: np.ndarray
    c: np.ndarray
    d: np.ndarray | None


def handle_targets(mesh: Mesh, cs: ConstraintSet, move: ResolvedMove, ids: np.ndarray) -> np.ndarray:
    """Targets (k, 3) of fixed, handle and edit nodes ``ids`` (corner or mid-side) under ``move``."""
    V0 = mesh.V
    U = V0[ids].copy()
    own = cs.owner[ids]
    for h, name in enumerate(cs.handle_names):
        hm = move.handles.get(name)
        if hm is None:
            continue
        rows = np.flatnonzero(own == h)
        U[rows] = hm.apply(V0[ids[rows]], cs.handle_pivots[name])
    for j, e in enumerate(cs.edits):
        value = move.edit(e.kind, e.name)
        if value is None:
            continue
        rows = np.flatnonzero(own == edit_owner(j))
        if rows.size:
            U[rows] = e.positions(value)[np.searchsorted(e.nodes, ids[rows])]
    return U


def right_hand_sides(mesh: Mesh, cs: ConstraintSet, rotation: RotationField, delta: np.ndarray,
                     walls: WallRows | None, rows: np.ndarray, with_targets: bool,
                     move: ResolvedMove) -> RightHandSides:
    """Right-hand sides of ``move`` for a position system whose vertex rows are ``rows``.

    Parameters
    ----------
    mesh : Mesh
    cs : ConstraintSet
    rotation : RotationField
    delta : (n, 3) float array
        Rest mean curvature normals.
    walls : WallRows or None
    rows : (l,) int array
        Vertices of the position system's soft rows.
    with_targets : bool
        Whether a position system exists (else ``d`` is None).
    move : ResolvedMove

    Returns
    -------
    RightHandSides
    """
    U = handle_targets(mesh, cs, move, cs.constrained)
    for mi in cs.mirrors:  # split solve: free interior partners of held nodes are held at their images
        dst = mi.dst[mi.derived]
        if dst.size and cs.mode == "split":
            src = np.searchsorted(cs.constrained, mi.src[mi.derived])
            U[np.searchsorted(cs.constrained, dst)] = U[src] @ mi.A.T + mi.t
    r, sigma = rotation.solve(move)
    bpos = np.full(mesh.n, -1, np.int64)
    bpos[cs.bidx] = np.arange(cs.bidx.size)
    nb = rotate_by_log(delta[cs.bidx], r, np.exp(sigma)) if cs.bidx.size else np.zeros((0, 3))
    if rows is cs.bidx or np.array_equal(rows, cs.bidx):  # the split solve's rows: the boundary itself
        c = nb
    else:  # joint: zero on interior rows
        b = np.zeros((mesh.n, 3))
        b[cs.bidx] = nb
        c = b[rows]
    if walls is not None:
        c = np.vstack([c, walls.rhs(r, sigma, bpos)])
    d = None
    if with_targets and cs.pasm is not None:
        d = block_targets(cs.blocks, cs.pasm, move, lambda ids: r[bpos[ids]])
    return RightHandSides(U, c, d)
