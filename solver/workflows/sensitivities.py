"""Shape sensitivities: ``dX / d theta_k`` at every node, for every shape, at one variant.

The position solve is linear in its right-hand sides (eq. 4.2/4.3 by
back-substitution, in residual form): ``X = X_rest + L (b(theta) - b_rest)``
with ``b = (U, c, d)`` the targets of the fixed and handle nodes, the rotated
and scaled mean curvature normals ``c_i = exp(sigma_i) R(r_i) delta_i`` (eq.
3.1-3.2) with the thin-wall rows, and the hard-row targets ``d``. So

    dX / d theta_k = L (d b / d theta_k),

one more back-substitution per shape, stacked into one multi-column solve.
``d b / d theta_k`` is differentiated analytically, nothing by finite
differences:

* translations, offsets, point and motion targets are linear in ``theta``
  (:mod:`solver.workflows.shapes`): their derivatives are the shapes' steps;
* handle rotations enter through ``R(r)`` of the quaternion logarithms
  ``r_h = sum_k theta_k r_kh`` and, propagated, ``r = Phi C`` at the boundary
  vertices (eq. 3.5-3.9; ECLS eq. 22-27, linear in the handle logarithms
  ``C``). With ``phi = 2 r`` the rotation vector,
  ``d (R v) = (J_l(phi) d phi) x (R v)``, ``J_l`` the left Jacobian of SO(3):
  ``J_l(phi) = I + (1 - cos a) / a**2 [phi]x + (a - sin a) / a**3 [phi]x**2``,
  ``a = |phi|``;
* scales enter as ``exp`` of log-scales (handles, propagated as
  ``sigma = Phi s``; features; relative constraints): ``d exp(x) = exp(x) dx``;
* the edits' nodes: their edit's own derivative
  (:meth:`~solver.constraints.edits.Edit.derivative`), the displacement of the
  shape's value for the edits linear in it (radius changes, map amounts,
  offsets, lattices) and ``phi_k(s) d x (p - a)`` for a twist.

Hard-row kinds this module does not know are differenced centrally in the
MOVE (step :data:`TARGET_STEP`): exact for kinds linear in the MOVE, such as
target-surface amounts. Quadratic meshes: mid-side nodes follow the corner
derivative through the placement, which is linear in the corners; where the
placement relaxed curved edges at ``theta`` (REPORT ``midside_relaxed``), the
derivative is that of the unrelaxed placement. The derivative is of the raw
solve: no repair and no inversion policy.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import meshio
import numpy as np

from ..constraints.assembly import Assembly
from ..constraints.edit_entries import EDIT_KINDS
from ..constraints.edits import Edit
from ..constraints.move import ResolvedMove
from ..constraints.rows import Block, block_target
from ..deform.constraint_set import edit_owner
from ..deform.deformer import Deformer
from ..deform.rhs import RightHandSides
from ..errors import InvalidMeshError
from ..mesh import Mesh
from ..ops.rotation import rotate_by_log
from ..ops.unique import unique
from .shapes import Shapes, variant_move

__all__ = ["Sensitivities", "shape_sensitivities", "write_sensitivities", "left_jacobian", "rotation_derivative",
           "TARGET_STEP", "ANALYTIC"]

#: Central-difference step (parameter units) for hard-row kinds without an analytic derivative.
TARGET_STEP = 1e-3


@dataclass(frozen=True, eq=False)
class Sensitivities:
    """Node sensitivities of every shape at one variant.

    Attributes
    ----------
    names : tuple of str
        Shape names; ``derivatives[k]`` belongs to ``names[k]``.
    theta : (K,) float array
        The parameters they were taken at.
    positions : (n, 3) float array
        The variant's node positions ``X(theta)`` (the raw solve).
    derivatives : (K, n, 3) float array
        ``dX / d theta_k`` per node, in mesh units per unit parameter.
    method : str
        ``"analytic"``.
    """

    names: tuple[str, ...]
    theta: np.ndarray
    positions: np.ndarray
    derivatives: np.ndarray
    method: str = "analytic"

    def point_data(self) -> dict[str, np.ndarray]:
        """``{"d_<shape>": (n, 3)}`` arrays."""
        return {f"d_{n}": self.derivatives[k] for k, n in enumerate(self.names)}


def left_jacobian(phi: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """``J_l(phi) psi`` row by row: the rotation vector's increment turned into the rotation's.

    Parameters
    ----------
    phi : (k, 3) or (3,) float array
        Rotation vectors (angle times axis; twice the quaternion logarithm).
    psi : (k, 3) float array
        Increments of ``phi``.

    Returns
    -------
    (k, 3) float array
        ``omega`` with ``d R(phi) = [omega]x R(phi)``.

    Examples
    --------
    >>> left_jacobian(np.zeros(3), np.array([[1.0, 2.0, 3.0]])).tolist()
    [[1.0, 2.0, 3.0]]
    """
    phi = np.broadcast_to(np.asarray(phi, np.float64), np.shape(psi))
    a = np.sqrt((phi * phi).sum(axis=-1, keepdims=True))
    a2 = a * a
    small = a < 1e-4
    safe = np.where(small, 1.0, a)
    # (1 - cos a) / a^2 = 2 sin^2(a/2) / a^2 (no cancellation) and (a - sin a) / a^3, by series below 1e-4
    f1 = np.where(small, 0.5 - a2 / 24.0, 2.0 * np.sin(0.5 * safe) ** 2 / (safe * safe))
    f2 = np.where(small, 1.0 / 6.0 - a2 / 120.0, (safe - np.sin(safe)) / (safe * safe * safe))
    c = np.cross(phi, psi)
    return psi + f1 * c + f2 * np.cross(phi, c)


def rotation_derivative(w: np.ndarray, r: np.ndarray, dr: np.ndarray) -> np.ndarray:
    """Derivative of ``w = R(r) v`` when the quaternion logarithm ``r`` moves by ``dr``.

    Parameters
    ----------
    w : (k, 3) float array
        Rotated vectors ``R(r_i) v_i``.
    r, dr : (k, 3) or (3,) float arrays
        Quaternion logarithms ``(theta / 2) axis`` and their derivatives.

    Returns
    -------
    (k, 3) float array
        ``(J_l(2 r) 2 dr) x w``.
    """
    dr = np.broadcast_to(np.asarray(dr, np.float64), np.shape(w))
    return np.cross(left_jacobian(2.0 * np.asarray(r, np.float64), 2.0 * dr), w)


def _edit_step(shapes: Shapes, e: Edit, k: int) -> Any:
    """Shape ``k``'s value of edit ``e`` (None: the shape leaves it at rest)."""
    steps = shapes.edits.get(e.kind, {}).get(e.name)
    return None if steps is None else steps[k]


def _handle_derivative(deformer: Deformer, shapes: Shapes, mv: ResolvedMove, ids: np.ndarray, U: np.ndarray,
                       k: int) -> np.ndarray:
    """Derivative (p, 3) of the targets ``U`` of nodes ``ids`` along shape ``k``.

    Handle nodes: ``u = c + t + s R (p0 - c)``; edit nodes: as their edits place them.
    """
    cs = deformer.data.constraints
    out = np.zeros((ids.size, 3))
    own = cs.owner[ids]
    for j, e in enumerate(cs.edits):
        step = _edit_step(shapes, e, k)
        rows = np.flatnonzero(own == edit_owner(j))
        if step is not None and rows.size:
            out[rows] = e.derivative(mv.edit(e.kind, e.name), step)[np.searchsorted(e.nodes, ids[rows])]
    for h, name in enumerate(shapes.handles):
        hm = mv.handles.get(name)
        rows = np.flatnonzero(own == h)
        if hm is None or not rows.size:
            continue
        c = shapes.centroids[name] if hm.pivot is None else hm.pivot
        w = U[rows] - c - hm.translation  # s R (p0 - c)
        out[rows] = (shapes.translation[k, h] + shapes.log_scale[k, h] * w
                     + rotation_derivative(w, hm.log_rotation, shapes.log_rotation[k, h]))
    return out


def _layout(blocks: list[Block], asm: Assembly, per: dict[int, np.ndarray]) -> np.ndarray:
    """Per-block values laid in an assembly's rows, as :func:`~solver.constraints.assembly.block_targets` does."""
    if not asm.vector:
        d = np.zeros((asm.C.shape[0], 3))
        for b_i, t in per.items():
            rows = asm.block == b_i
            d[rows] = t[asm.local[rows]]
        return d
    d = np.zeros((asm.C.shape[0], 1))
    for b_i, t in per.items():
        rows = np.flatnonzero(asm.block == b_i)
        d[rows, 0] = t[asm.local[rows]] if blocks[b_i].vector else t[asm.local[rows], asm.coord[rows]]
    return d


@dataclass(frozen=True, eq=False)
class _Along:
    """What a block derivative needs: the shape ``k``, the variant, its rotation field and the field's derivative."""

    k: int
    shapes: Shapes
    move: ResolvedMove
    r: np.ndarray
    dr: np.ndarray
    bpos: np.ndarray


def _zero(b: Block, t: np.ndarray, a: _Along) -> np.ndarray:
    return np.zeros_like(t)


def _d_handle(b: Block, t: np.ndarray, a: _Along) -> np.ndarray:
    hm = a.move.handles.get(b.name)
    if hm is None:
        return np.zeros_like(t)
    h = a.shapes.handles.index(b.name)
    assert b.pivot is not None
    w = t - (b.pivot if hm.pivot is None else hm.pivot) - hm.translation
    return (a.shapes.translation[a.k, h] + a.shapes.log_scale[a.k, h] * w
            + rotation_derivative(w, hm.log_rotation, a.shapes.log_rotation[a.k, h]))


def _d_point(b: Block, t: np.ndarray, a: _Along) -> np.ndarray:
    p = a.shapes.points.get(b.name)
    return np.zeros_like(t) if p is None else p.step[a.k][None, :].copy()


def _d_motion(b: Block, t: np.ndarray, a: _Along) -> np.ndarray:
    m = a.shapes.motion.get(b.name)
    assert b.normal is not None
    return np.zeros_like(t) if m is None else b.normal @ m.step[a.k]


def _d_scaled(b: Block, t: np.ndarray, a: _Along) -> np.ndarray:
    """Relative and feature targets ``s R(r_v) v0``: log-scale and rotation at the block's rotation vertex."""
    if b.kind == "relative" and b.name in a.shapes.offsets:
        return a.shapes.offsets[b.name].step[a.k][None, :].copy()
    logs = a.shapes.relative_log_scale if b.kind == "relative" else a.shapes.feature_log_scale
    out = logs[b.name][a.k] * t if b.name in logs else np.zeros_like(t)
    if b.uses_rotation:
        v = a.bpos[b.rot_vertex]
        out = out + rotation_derivative(t, a.r[v], a.dr[v])
    return out


def _d_edit(b: Block, t: np.ndarray, a: _Along) -> np.ndarray:
    """An edit's corner targets: :meth:`Edit.derivative <solver.constraints.edits.Edit.derivative>`."""
    if b.edit is None:  # nodes sliding on a fixed plane
        return np.zeros_like(t)
    step = _edit_step(a.shapes, b.edit, a.k)
    if step is None:
        return np.zeros_like(t)
    return b.edit.derivative(a.move.edit(b.kind, b.name), step)[b.edit.corner]


#: Analytic derivative of each hard-row kind's targets (:data:`solver.constraints.rows.TARGETS`).
ANALYTIC: dict[str, Callable[[Block, np.ndarray, _Along], np.ndarray]] = {
    "fixed": _zero, "tie": _zero, "sliding": _zero, "handle": _d_handle, "point": _d_point,
    "motion": _d_motion, "relative": _d_scaled, "feature": _d_scaled, **{kind: _d_edit for kind in EDIT_KINDS},
}


def _block_derivative(b: Block, a: _Along, shifted: Callable[[float], tuple[ResolvedMove, np.ndarray]]) -> np.ndarray:
    """Derivative of one hard-row block's targets along shape ``a.k``."""
    def rot_at(rr: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        return lambda ids: rr[a.bpos[ids]]

    rule = ANALYTIC.get(b.kind)
    if rule is not None:
        return rule(b, np.asarray(block_target(b, a.move, rot_at(a.r)), np.float64), a)
    # a kind without an analytic rule: central difference in the MOVE (exact for kinds linear in it)
    mp, rp = shifted(TARGET_STEP)
    mm, rm = shifted(-TARGET_STEP)
    tp = np.asarray(block_target(b, mp, rot_at(rp)), np.float64)
    tm = np.asarray(block_target(b, mm, rot_at(rm)), np.float64)
    return (tp - tm) / (2.0 * TARGET_STEP)


def shape_sensitivities(deformer: Deformer, shapes: Shapes, theta: Any = None,
                        where: str = "variant") -> Sensitivities:
    """``dX / d theta_k`` of every node for every shape at parameters ``theta``.

    Parameters
    ----------
    deformer : Deformer
    shapes : Shapes
    theta : (K,) array_like, optional
        Default 0: the rest shape.
    where : str
        Names the variant in error messages.

    Returns
    -------
    Sensitivities

    Raises
    ------
    SpecError
        ``theta`` is not a valid variant (:func:`~solver.workflows.shapes.variant_move`).
    """
    data = deformer.data
    mesh, cs = data.mesh, data.constraints
    K = shapes.count
    th = np.zeros(K) if theta is None else np.asarray(theta, np.float64)
    mv = variant_move(deformer, shapes, th, where)
    rest = data.rhs(ResolvedMove({}))
    here = data.rhs(mv)
    r, sigma = data.rotation.solve(mv)
    Phi = data.rotation.Phi
    bidx = cs.bidx
    bpos = np.full(mesh.n, -1, np.int64)
    bpos[bidx] = np.arange(bidx.size)
    wb = np.exp(sigma)[:, None] * rotate_by_log(data.delta[bidx], r) if bidx.size else np.zeros((0, 3))
    walls = data.walls
    rows = data.positions.rows
    asm = cs.pasm if data.positions.system is not None else None

    def shifted(k: int) -> Callable[[float], tuple[ResolvedMove, np.ndarray]]:
        def at(h: float) -> tuple[ResolvedMove, np.ndarray]:
            t2 = th.copy()
            t2[k] += h
            m2 = variant_move(deformer, shapes, t2, where)
            return m2, data.rotation.solve(m2)[0]
        return at

    rhss = [rest]
    for k in range(K):
        dU = _handle_derivative(deformer, shapes, mv, cs.constrained, here.U, k)
        dr = Phi @ shapes.log_rotation[k]
        ds = Phi @ shapes.log_scale[k]
        db = np.zeros((mesh.n, 3))
        if bidx.size:
            db[bidx] = ds[:, None] * wb + rotation_derivative(wb, r, dr)
        dc = db[rows]
        if walls is not None:
            a, b = bpos[walls.E[:, 0]], bpos[walls.E[:, 1]]
            W = walls.rhs(r, sigma, bpos)
            dW = 0.5 * (ds[a] + ds[b])[:, None] * W + rotation_derivative(W, 0.5 * (r[a] + r[b]),
                                                                          0.5 * (dr[a] + dr[b]))
            dc = np.vstack([dc, dW])
        dd = None
        if asm is not None and rest.d is not None:
            along = _Along(k, shapes, mv, r, dr, bpos)
            per = {int(b_i): _block_derivative(cs.blocks[int(b_i)], along, shifted(k)) for b_i in unique(asm.block)}
            dd = rest.d + _layout(cs.blocks, asm, per)
        rhss.append(RightHandSides(rest.U + dU, rest.c + dc, dd))
    solves = data.positions.solve_many(mesh.V, cs.constrained, rhss)
    D = np.stack([s.P - solves[0].P for s in solves[1:]]) if K else np.zeros((0, mesh.n, 3))
    if data.midside is not None:
        pinned = data.pinned_mid
        at_pinned = data.pinned_targets(mv)
        for k in range(K):
            dpin = _handle_derivative(deformer, shapes, mv, pinned, at_pinned, k)
            D[k] = data.midside.place(D[k], None, pinned, dpin).P
    X = deformer.solve_positions(mv).P
    return Sensitivities(shapes.names, th, X, D)


def write_sensitivities(mesh: Mesh, sens: Sensitivities, path: str | os.PathLike[str],
                        file_format: str | None = None) -> None:
    """Write the variant's mesh with the sensitivities as point data (``d_<shape>`` vectors).

    Also writes ``displacement`` (``X(theta) - X_rest``). The file holds the
    mesh's cells and these arrays only (no sets); any format meshio writes
    with point data, VTU (``.vtu``) for ParaView.

    Raises
    ------
    InvalidMeshError
        meshio cannot write the format (``unwritable_format``).
    """
    pd = {"displacement": sens.positions - mesh.V, **sens.point_data()}
    if mesh.source is not None:
        cells = [(c.type, c.data) for c in mesh.source.cells]
    else:
        cells = [("tetra", mesh.T)] if not mesh.is_surface else [("triangle", mesh.surface)]
    target = os.fspath(path)
    os.makedirs(os.path.dirname(os.path.abspath(target)), exist_ok=True)
    try:
        meshio.write(target, meshio.Mesh(sens.positions, cells, point_data=pd), file_format=file_format)
    except Exception as e:
        raise InvalidMeshError(f"cannot write {target!r} as {file_format or 'its extension'}: {e}",
                               code="unwritable_format") from e
