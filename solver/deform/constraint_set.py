"""The resolved hard constraints of a SPEC on a mesh: who is fixed, who moves, which rows, which solve.

:func:`constraint_set` resolves every selection, splits fixed and handle
selections into the corner nodes the method solves for and the mid-side
nodes of quadratic elements that are set exactly afterwards, checks that
every body and shell is determined, builds the constraint rows of both
systems (:mod:`solver.constraints.rows`), picks the split or joint position
solve, and ranks the rows (ECLS §5) before any factorization, so that a SPEC
whose constraints conflict with ``"conflicts": "reject"`` is refused at once.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..constraints.assembly import Assembly, assemble, block_targets, describe
from ..constraints.correspondence import Correspondences, InteriorMirror, correspondences
from ..constraints.edit_kinds import EDIT_KINDS, NOMINAL_KINDS
from ..constraints.matching import Matching
from ..constraints.move import MoveBounds, ResolvedMove, RestTargets
from ..constraints.rows import (
    REPORT_IDS,
    Block,
    mapped_rows,
    point_weights,
    position_blocks,
    projected_rows,
    rotation_blocks,
)
from ..constraints.selection import select
from ..constraints.spec import ResolvedSpec
from ..constraints.ties import tie_pairs
from ..errors import ConstraintError, SpecError, format_ids
from ..linalg.rank import RankAnalysis, rank_analysis
from ..mesh import Mesh
from ..ops.unique import unique
from .conflicts import conflict_details
from .determinacy import free_shells

if TYPE_CHECKING:
    from ..constraints.edits import Edit

__all__ = ["ConstraintSet", "constraint_set", "entry_text", "edit_owner", "CONFLICT_TOL"]

#: A dropped constraint row whose residual exceeds this fraction of the mesh
#: diagonal (positions) or this many radians/2 (rotation logarithms) conflicts.
CONFLICT_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class ConstraintSet:
    """Every resolved hard constraint of one SPEC on one mesh (immutable).

    Attributes
    ----------
    sel_ids : dict of str to (k,) int array
        Every node each selection names (mid-side nodes included).
    fixed : (k,) int array
        Fixed corner nodes.
    fixed_mid : (k,) int array
        Fixed mid-side nodes (quadratic meshes), held exactly at rest.
    owner : (n,) int array
        -2 fixed, ``h >= 0`` handle index, -1 free, ``-3 - j`` in edit ``j`` (every node, mid-side nodes
        included).
    handle_names : tuple of str
    handle_ids, handle_mid : dict of str to (k,) int array
        Corner and mid-side nodes of each handle.
    handle_pivots : dict of str to (3,) array
        Default pivot of each handle: the centroid of all its nodes.
    constrained : (k,) int array
        Fixed and handle corner nodes, sorted.
    ties : (t, 2) int array
    free_shell : (n,) bool array
        Boundary vertices of internal voids held by nothing (positioned by the volume).
    blocks, rblocks : list of Block
        Rows of the position and the rotation system.
    rbasis : list of (nrows, H) arrays
        Rotation targets per unit handle rotation.
    rvector : bool
        Whether the rotation system couples coordinates (mirror and cyclic symmetry): its
        unknowns are 3 per vertex, and the log-scales get their own scalar system.
    sblocks, sbasis, sasm, sra : the log-scale system's rows, targets, assembly and rank
        analysis when ``rvector`` (else empty and None).
    corr : Correspondences
        Resolved symmetry, cyclic, surface-tie and target constraints.
    vector : bool
        Whether the position system couples coordinates (3 unknowns per vertex).
    mode : {"split", "joint"}
    diag : float
        Diagonal of the referenced vertices' bounding box.
    conflict_tol : float
    bidx : (b,) int array
        Boundary vertices.
    unknowns : (u,) int array
        Unknowns of the position system (boundary for split, every referenced vertex for joint).
    pasm, pra : Assembly, RankAnalysis or None
        Position rows over ``unknowns`` and their rank analysis.
    rbidx : (r,) int array
        Rotation unknowns (boundary vertices not on a free void).
    rasm, rra : Assembly, RankAnalysis or None
        Rotation rows and their rank analysis.
    rest_constraints : dict
        Redundant and conflicting entries with every handle at rest.
    movable : (n,) bool array
        Free interior vertices (in no hard constraint), which repair may move.
    rest : RestTargets
        Rest values of MOVE-addressable targets (for scaled moves).
    bounds : MoveBounds
        The mesh's extent, bounding MOVE translations and points.
    mirrors : tuple of InteriorMirror
        Interior nodes of every mirror symmetry, held as images of their partners.
    edits : tuple of Edit
        The resolved edits (``radius``, ..., ``lattice``, ``fillet``, ``distance``, ``angle``): their nodes are
        held like a handle's, edit ``j``'s with ``owner`` :func:`edit_owner` ``(j)``.
    roles : (n,) int array or None
        ``owner`` with every edit node counted as a handle's (the REPORT's displacement maxima).
    """

    sel_ids: dict[str, np.ndarray]
    fixed: np.ndarray
    fixed_mid: np.ndarray
    owner: np.ndarray
    handle_names: tuple[str, ...]
    handle_ids: dict[str, np.ndarray]
    handle_mid: dict[str, np.ndarray]
    handle_pivots: dict[str, np.ndarray]
    constrained: np.ndarray
    ties: np.ndarray
    free_shell: np.ndarray
    blocks: list[Block]
    rblocks: list[Block]
    rbasis: list[np.ndarray]
    rvector: bool
    sblocks: list[Block]
    sbasis: list[np.ndarray]
    sasm: Assembly | None
    sra: RankAnalysis | None
    corr: Correspondences
    vector: bool
    mode: str
    diag: float
    conflict_tol: float
    bidx: np.ndarray
    unknowns: np.ndarray
    pasm: Assembly | None
    pra: RankAnalysis | None
    rbidx: np.ndarray
    rasm: Assembly | None
    rra: RankAnalysis | None
    rest_constraints: dict[str, list[dict[str, Any]]]
    movable: np.ndarray
    rest: RestTargets
    bounds: MoveBounds
    mirrors: tuple[InteriorMirror, ...] = ()
    edits: tuple[Edit, ...] = ()
    roles: np.ndarray | None = None

    @property
    def pinned_mid(self) -> np.ndarray:
        """Every mid-side node held by a fixed, handle, target or edit selection, sorted."""
        return _union([self.fixed_mid, *self.handle_mid.values(), *[t.mid_ids for t in self.corr.targets],
                       *[e.mid_ids for e in self.edits]])


def edit_owner(j: int) -> int:
    """The ``owner`` code of the nodes of edit ``j`` (-3, -4, ...)."""
    return -3 - j


def entry_text(e: dict[str, Any]) -> str:
    """One REPORT constraint entry as text, for error messages."""
    txt = f"{e['kind']} {e['name']!r} (#{e['index']}) on vertices {e['vertices']}"
    if "residual" in e:
        txt += f", residual {e['residual']:.3g}"
    return txt


def _outside(mesh: Mesh, inside: np.ndarray) -> np.ndarray:
    """The nodes of the elements (corner and mid-side) that are not in ``inside``: held at rest by a domain."""
    used = mesh.referenced.copy()
    if mesh.T10 is not None:
        used[mesh.T10[:, 4:].ravel()] = True
    used[inside] = False
    return np.flatnonzero(used)


def _union(parts: list[np.ndarray]) -> np.ndarray:
    return unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)


def constraint_set(mesh: Mesh, spec: ResolvedSpec) -> ConstraintSet:
    """Resolve and check the hard constraints of ``spec`` on ``mesh``.

    Parameters
    ----------
    mesh : Mesh
    spec : ResolvedSpec

    Returns
    -------
    ConstraintSet

    Raises
    ------
    SpecError
        Unknown or empty selections, overlapping handles, a vertex both fixed
        and in a handle, a handle with no corner node, a split solve that
        cannot hold its constraints.
    ConstraintError
        A body or a shell is undetermined; constraints conflict at rest and
        ``SPEC.conflicts`` is ``"reject"``.
    """
    n = mesh.n
    V0 = mesh.V
    corner = mesh.referenced
    sel_ids = {name: select(mesh, sel, name) for name, sel in spec.selections.items()}
    held = [sel_ids[f] for f in spec.fixed]
    if spec.domain is not None:
        held.append(_outside(mesh, sel_ids[spec.domain]))
    fixed_all = _union(held)
    fixed, fixed_mid = fixed_all[corner[fixed_all]], fixed_all[~corner[fixed_all]]
    owner = np.full(n, -1, np.int64)  # -2 fixed, h >= 0 handle index (every node)
    owner[fixed_all] = -2
    handle_names = tuple(spec.handles)
    handle_ids: dict[str, np.ndarray] = {}
    handle_mid: dict[str, np.ndarray] = {}
    pivots: dict[str, np.ndarray] = {}
    for h, name in enumerate(handle_names):
        ids = sel_ids[spec.handles[name]]
        if spec.domain is not None:
            out = np.setdiff1d(ids, sel_ids[spec.domain], assume_unique=True)
            if out.size:
                raise SpecError(f"handle {name!r} has {out.size} vertices outside the domain {spec.domain!r} "
                                f"({format_ids(out)}); a domain must hold its handles", code="handle_outside_domain",
                                handle=name, domain=spec.domain, ids=out[:REPORT_IDS].tolist())
        clash_fixed = ids[owner[ids] == -2]
        if clash_fixed.size:
            raise SpecError(f"handle {name!r} shares vertices {format_ids(clash_fixed)} with the fixed selections",
                            code="overlapping_constraints", handle=name, ids=clash_fixed[:REPORT_IDS].tolist())
        clash = ids[owner[ids] >= 0]
        if clash.size:
            other = handle_names[int(owner[clash[0]])]
            raise SpecError(f"handles {other!r} and {name!r} overlap at vertices {format_ids(clash)}",
                            code="overlapping_constraints", handles=[other, name], ids=clash[:REPORT_IDS].tolist())
        owner[ids] = h
        handle_ids[name] = ids[corner[ids]]
        handle_mid[name] = ids[~corner[ids]]
        if not handle_ids[name].size:
            raise SpecError(f"handle {name!r} (selection {spec.handles[name]!r}) holds only mid-side nodes "
                            f"({ids.size}); a handle needs at least one corner node", code="empty_selection",
                            handle=name, selection=spec.handles[name])
        pivots[name] = V0[ids].mean(axis=0)
    edits: tuple[Edit, ...] = ()
    if spec.edits:  # their modules are loaded by a SPEC that names an edit
        from ..constraints.resolve_edits import resolve_edits

        edits = resolve_edits(mesh, spec.edits, sel_ids)
    for j, e in enumerate(edits):
        clash = e.nodes[owner[e.nodes] != -1]
        if clash.size:
            other = owner[clash[0]]
            what = ("the fixed selections" + (" (or nodes outside the domain)" if spec.domain is not None else "")
                    if other == -2 else f"handle {handle_names[int(other)]!r}" if other >= 0
                    else edits[edit_owner(0) - int(other)].where)
            raise SpecError(f"{e.where} shares vertices {format_ids(clash)} with {what}",
                            code="overlapping_constraints", edit=e.name, ids=clash[:REPORT_IDS].tolist())
        owner[e.nodes] = edit_owner(j)
    edits = tuple(e.with_free(owner == -1) for e in edits)
    constrained_mask = (owner != -1) & corner
    ref = mesh.referenced
    diag = float(np.linalg.norm(V0[ref].max(0) - V0[ref].min(0))) if ref.any() else 0.0
    center = 0.5 * (V0[ref].max(0) + V0[ref].min(0)) if ref.any() else np.zeros(3)
    ties = tie_pairs(mesh, spec.ties)
    corr = correspondences(mesh, spec, sel_ids, diag)
    for t in corr.targets:  # target nodes are held (by the surface) like handle nodes
        constrained_mask[t.ids] = True
    free_shell = free_shells(mesh, constrained_mask, np.r_[ties, corr.links].astype(np.int64), spec.voids)
    for t in corr.targets:
        constrained_mask[t.ids] = owner[t.ids] != -1
    blocks = position_blocks(mesh, spec, sel_ids, fixed, handle_ids, pivots, ties, corr, edits)
    rblocks, rbasis = rotation_blocks(mesh, spec, sel_ids, fixed, handle_ids, ties, corr)
    rvector = any(b.vector for b in rblocks)
    sblocks, sbasis = rotation_blocks(mesh, spec, sel_ids, fixed, handle_ids, ties, corr, "scales") if rvector \
        else ([], [])
    vector = any(b.vector for b in blocks)
    mode = _solve_mode(mesh, spec, blocks, free_shell)
    mirrors = _interior_mirrors(corr, constrained_mask)
    if mode == "split":  # a free partner of a fixed or handle node is held like one (its target: the image)
        for mi in mirrors:
            constrained_mask[mi.dst[mi.derived]] = True
    else:  # the joint system holds every interior pair as rows, as it does the boundary's
        blocks += _interior_rows(corr, mirrors)
    conflict_tol = CONFLICT_TOL * max(diag, 1e-300)
    bidx = np.flatnonzero(mesh.boundary)
    unknowns = bidx if mode == "split" else np.flatnonzero(mesh.referenced)
    pasm = pra = None
    if unknowns.size:
        umap = np.full(n, -1, np.int64)
        umap[unknowns] = np.arange(unknowns.size)
        pasm = assemble(blocks, umap, unknowns.size, vector)
        pra = rank_analysis(pasm.C)
    rbidx = bidx[~free_shell[bidx]]
    rasm = rra = sasm = sra = None
    if handle_names and rbidx.size:
        umap = np.full(n, -1, np.int64)
        umap[rbidx] = np.arange(rbidx.size)
        rasm = assemble(rblocks, umap, rbidx.size, vector=rvector)
        rra = rank_analysis(rasm.C)
        if rvector:
            sasm = assemble(sblocks, umap, rbidx.size, vector=False)
            sra = rank_analysis(sasm.C)
    rest_constraints = _rest_constraints(blocks, rblocks, pasm, pra, rasm, rra, conflict_tol)
    conflicting = rest_constraints["conflicting_constraints"]
    if conflicting and spec.conflicts == "reject":
        raise ConstraintError(
            f"{len(conflicting)} hard constraints conflict with the ones before them (first: "
            f"{entry_text(conflicting[0])}); SPEC.conflicts is 'reject'",
            code="conflicting_constraints", conflicting_constraints=conflicting,
            redundant_constraints=rest_constraints["redundant_constraints"], **conflict_details(conflicting, sel_ids))
    movable = mesh.interior & mesh.referenced & ~constrained_mask
    for b in blocks:
        movable[b.vert] = False
    rest = RestTargets(
        points={e.name: (_point_at(mesh, sel_ids, e.at), None if e.target is None else np.asarray(e.target))
                for e in spec.points},
        motion={e.name: _point_at(mesh, sel_ids, e.at) for e in spec.motion},
        relative={e.name: _point_at(mesh, sel_ids, e.a) - _point_at(mesh, sel_ids, e.b) for e in spec.relative},
        nominal=_nominal(edits))
    return ConstraintSet(
        sel_ids=sel_ids, fixed=fixed, fixed_mid=fixed_mid, owner=owner, handle_names=handle_names,
        handle_ids=handle_ids, handle_mid=handle_mid, handle_pivots=pivots,
        constrained=np.flatnonzero(constrained_mask), ties=ties, free_shell=free_shell, blocks=blocks,
        rblocks=rblocks, rbasis=rbasis, rvector=rvector, sblocks=sblocks, sbasis=sbasis, sasm=sasm, sra=sra,
        corr=corr, vector=vector, mode=mode, diag=diag, conflict_tol=conflict_tol, bidx=bidx,
        unknowns=unknowns, pasm=pasm, pra=pra, rbidx=rbidx, rasm=rasm, rra=rra, rest_constraints=rest_constraints,
        movable=movable, rest=rest, bounds=MoveBounds(center, diag), mirrors=mirrors, edits=edits,
        roles=np.where(owner <= edit_owner(0), 0, owner) if edits else None)


def _nominal(edits: tuple[Edit, ...]) -> dict[str, dict[str, float]]:
    """The nominal rest value of each edit whose MOVE may give a value (:data:`NOMINAL_KINDS`)."""
    out: dict[str, dict[str, float]] = {}
    for e in edits:
        if e.kind in NOMINAL_KINDS:
            out.setdefault(e.kind, {})[e.name] = float(e.nominal)  # type: ignore[attr-defined]
    return out


def _interior_mirrors(corr: Correspondences, constrained: np.ndarray) -> tuple[InteriorMirror, ...]:
    """Each mirror symmetry's interior pairs with their roles: a constrained node is its free partner's source."""
    out = []
    for e in corr.mapped:
        if e.kind != "symmetry" or not (len(e.inner) or e.inner_on.size):
            continue
        neg, pos = e.inner[:, 0], e.inner[:, 1]
        cn, cp = constrained[neg], constrained[pos]
        keep = ~(cn & cp)  # both held: their own targets decide (a MOVE that breaks the symmetry conflicts there)
        from_neg = cn & ~cp
        src = np.where(from_neg, neg, pos)[keep]
        dst = np.where(from_neg, pos, neg)[keep]
        derived = (cn ^ cp)[keep]
        on = e.inner_on[~constrained[e.inner_on]]
        n = e.N[0]
        out.append(InteriorMirror(e.name, e.matching.A, e.matching.t, src, dst, derived, on, n, e.c))
    return tuple(out)


def _interior_rows(corr: Correspondences, mirrors: tuple[InteriorMirror, ...]) -> list[Block]:
    """Rows ``p_dst = A p_src + t`` and on-plane rows of the interior pairs, for the joint system."""
    named = {e.name: e for e in corr.mapped if e.kind == "symmetry"}
    blocks = []
    for mi in mirrors:
        e = named[mi.name]
        if mi.dst.size:
            k = mi.dst.size
            m = Matching(mi.dst, np.repeat(mi.src[:, None], 3, axis=1), np.tile([1.0, 0.0, 0.0], (k, 1)), mi.A, mi.t,
                         np.zeros(k))
            blocks.append(mapped_rows("symmetry", e.index, e.name, m))
        if mi.on.size:
            blocks.append(projected_rows("symmetry", e.index, e.name, mi.on, e.N, e.c))
    return blocks


def _point_at(mesh: Mesh, sel_ids: dict[str, np.ndarray], p: Any) -> np.ndarray:
    ids, w = point_weights(p, mesh, sel_ids, "point")
    return w @ mesh.V[ids]


def _solve_mode(mesh: Mesh, spec: ResolvedSpec, blocks: list[Block], free_shell: np.ndarray) -> str:
    """Split where it is exact, else joint (module docstring of :mod:`solver.deform.positions`)."""
    general = [b for b in blocks if b.kind not in ("fixed", "handle", "target", *EDIT_KINDS)]
    touches_interior = any(mesh.interior[b.vert].any() for b in general)
    if free_shell.any():
        on_void = [b for b in blocks if free_shell[b.vert].any()]
        if on_void:
            raise SpecError(f"{on_void[0].kind} {on_void[0].name!r} uses vertices of an internal void that "
                            "has no fixed or handle vertex; fix or select a vertex of that void, or "
                            "drop the constraint", code="constraint_on_free_void")
        if spec.solve == "split":
            raise SpecError("SPEC.solve 'split' cannot position an internal void with no fixed or handle "
                            "vertex (its translation comes from the interior's mean-value rows); use "
                            "'joint' or 'auto'", field="solve")
        touches_interior = True  # auto: the joint solve
    if spec.solve == "split" and touches_interior:
        b = next(b for b in general if mesh.interior[b.vert].any())
        raise SpecError(f"SPEC.solve 'split' needs every constraint other than fixed and handle "
                        f"vertices on the boundary; {b.kind} {b.name!r} uses interior vertices "
                        f"{format_ids(b.vert[mesh.interior[b.vert]])}. Use 'joint' or 'auto'.",
                        field="solve", kind=b.kind, name=b.name)
    if spec.method == "penalty" or (spec.solve == "auto" and touches_interior):
        return "joint"
    return "split" if spec.solve == "auto" else spec.solve


def _rest_constraints(blocks: list[Block], rblocks: list[Block], pasm: Assembly | None, pra: RankAnalysis | None,
                      rasm: Assembly | None, rra: RankAnalysis | None, tol: float) -> dict[str, list[dict[str, Any]]]:
    """Redundant and conflicting rows with every handle at rest (dependent rows have one value everywhere)."""
    redundant: list[dict[str, Any]] = []
    conflicting: list[dict[str, Any]] = []
    if pra is not None and pasm is not None and not pra.kept.all():
        d = block_targets(blocks, pasm, ResolvedMove({}), lambda ids: np.zeros((len(ids), 3)))
        res = pra.dropped_residuals(pasm.C, d)
        drop = np.flatnonzero(~pra.kept)
        bad = res > tol
        redundant += describe(blocks, pasm, drop[~bad], "positions")
        conflicting += describe(blocks, pasm, drop[bad], "positions", res[bad])
    if rra is not None and rasm is not None:  # at rest every rotation target is 0: dropped rows are redundant
        redundant += describe(rblocks, rasm, np.flatnonzero(~rra.kept), "rotations")
    return {"redundant_constraints": redundant, "conflicting_constraints": conflicting}
