"""Hard constraint rows of a SPEC, one builder per constraint kind, and their targets for a MOVE.

Every hard constraint is a set of linear rows over vertex positions, in one of
two forms:

*replicated*
    ``sum_k a_k p_{v_k} = u`` with one coefficient per vertex and a target
    ``u`` in R^3: the same row for x, y and z. Positional constraints (eq.
    2.6, 3.3), points on edges and faces, relative constraints ``a - b = v``
    (ECLS eq. 28) and the spanning-tree rows of form features (Form features
    §3) are replicated.
*vector*
    ``sum_k a_k n . p_{v_k} = t`` with a normal ``n``: motion on a plane or a
    line (Form features §3.2) and per-node sliding. These couple the three
    coordinates, so a solve that has any of them works on 3n unknowns.

A :class:`Block` is data only: its rows, and the rest quantities its target
is computed from. :func:`block_target` turns a block and a MOVE into target
values through one small function per kind (:data:`TARGETS`). Rows are listed
in priority order (fixed, handles, targets, edits, ties, points, relative,
features, motion, sliding): when constraints are dependent, earlier rows are kept and later
ones are reported (ECLS §5).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

from ..errors import MAX_IDS, SpecError, format_ids
from ..mesh import Mesh
from ..ops.boundary_facets import simplex_edges
from ..ops.rotation import log_to_matrix, rotate_by_log
from ..ops.unique import unique
from .correspondence import Correspondences
from .edit_kinds import EDIT_KINDS
from .matching import Matching
from .move import ResolvedMove
from .spec import FeatureEntry, MotionEntry, PointDef, PointEntry, RelativeEntry, ResolvedSpec, SlidingEntry

if TYPE_CHECKING:
    from .edits import Edit

__all__ = ["Block", "KINDS", "TARGETS", "block_target", "check_ids", "point_weights", "position_blocks",
           "rotation_blocks", "fixed_rows", "handle_rows", "tie_rows", "point_rows", "relative_rows",
           "feature_rows", "motion_rows", "sliding_rows", "edit_rows", "edit_slide_rows"]

KINDS = ("fixed", "handle", "target", *EDIT_KINDS, "tie", "symmetry", "cyclic", "point", "relative", "feature",
         "motion", "sliding")
#: How many ids a REPORT or an error's details list.
REPORT_IDS = MAX_IDS

#: ``rot_at(ids) -> (k, 3)`` quaternion logarithms of boundary vertices.
RotAt = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class Block:
    """One SPEC entry's rows: data only.

    Attributes
    ----------
    kind : str
        One of ``KINDS``.
    index : int
        Position of the entry in its SPEC list (handles: SPEC order).
    name : str
    nrows : int
    row, vert, coeff : (e,) arrays
        Entries: row ``row[e]`` has coefficient ``coeff[e]`` on vertex ``vert[e]``.
    normal : (nrows, 3) array or None
        For vector rows, the normal that multiplies each row's coefficients.
    entry_normal : (e, 3) array or None
        For vector rows that couple coordinates differently per vertex (mirror
        and cyclic maps), the normal of each entry instead.
    rest : array
        What the target is made from: the rest positions of fixed and handle
        vertices (nrows, 3), a point's default target (3,), a relative
        constraint's rest offset (3,), a feature tree's rest edge vectors
        (nrows, 3), a motion point's rest position (3,), sliding nodes' rest
        normal coordinates (nrows,); zeros for ties.
    pivot : (3,) array or None
        A handle's default pivot (the centroid of all its nodes).
    aux : array or None
        A target surface's projections (nrows, 3) of the rest positions.
    rot_vertex : int
        Boundary vertex whose rotation turns the target (relative ``rotate``,
        rigid features), or -1.
    vertices : (k,) int array
        Every vertex of the entry, for reports.
    edit : Edit or None
        An edit's resolved nodes (:mod:`solver.constraints.edits`), which place them per MOVE.
    """

    kind: str
    index: int
    name: str
    nrows: int
    row: np.ndarray
    vert: np.ndarray
    coeff: np.ndarray
    rest: np.ndarray = field(default_factory=lambda: np.zeros(0))
    normal: np.ndarray | None = None
    entry_normal: np.ndarray | None = None
    pivot: np.ndarray | None = None
    aux: np.ndarray | None = None
    rot_vertex: int = -1
    vertices: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    edit: Edit | None = None

    @property
    def vector(self) -> bool:
        """Whether the rows couple the coordinates."""
        return self.normal is not None or self.entry_normal is not None

    @property
    def uses_rotation(self) -> bool:
        """Whether the target depends on the rotation field."""
        return self.rot_vertex >= 0

    def row_vertices(self, k: int) -> list[int]:
        """Vertices of row ``k``."""
        return self.vert[self.row == k].tolist()


# --------------------------------------------------------------------- targets
def _fixed_target(b: Block, mv: ResolvedMove, rot: RotAt) -> np.ndarray:
    return b.rest


def _handle_target(b: Block, mv: ResolvedMove, rot: RotAt) -> np.ndarray:
    hm = mv.handles.get(b.name)
    if hm is None:
        return b.rest
    assert b.pivot is not None
    return hm.apply(b.rest, b.pivot)


def _tie_target(b: Block, mv: ResolvedMove, rot: RotAt) -> np.ndarray:
    return np.zeros((b.nrows, 3))


def _point_target(b: Block, mv: ResolvedMove, rot: RotAt) -> np.ndarray:
    return np.asarray(mv.points.get(b.name, b.rest))[None, :]


def _relative_target(b: Block, mv: ResolvedMove, rot: RotAt) -> np.ndarray:
    o = mv.relative.get(b.name, {})
    if "offset" in o:
        return np.asarray(o["offset"])[None, :]
    v = rotate_by_log(b.rest[None, :], rot(np.array([b.rot_vertex]))) if b.uses_rotation else b.rest[None, :]
    return o.get("scale", 1.0) * v


def _feature_target(b: Block, mv: ResolvedMove, rot: RotAt) -> np.ndarray:
    s = mv.features.get(b.name, 1.0)
    if not b.uses_rotation:
        return s * b.rest
    return (s * b.rest) @ log_to_matrix(rot(np.array([b.rot_vertex]))[0]).T


def _target_target(b: Block, mv: ResolvedMove, rot: RotAt) -> np.ndarray:
    a = mv.targets.get(b.name, 0.0)
    assert b.aux is not None
    return b.rest + a * (b.aux - b.rest)


def _motion_target(b: Block, mv: ResolvedMove, rot: RotAt) -> np.ndarray:
    assert b.normal is not None
    return b.normal @ np.asarray(mv.motion.get(b.name, b.rest))


def _edit_target(b: Block, mv: ResolvedMove, rot: RotAt) -> np.ndarray:
    if b.edit is None:  # an edit's nodes sliding on a plane (a fillet's faces)
        return b.rest
    return b.edit.positions(mv.edit(b.kind, b.name))[b.edit.corner]


#: Target of each kind: ``(block, move, rot_at) -> (nrows, 3)`` replicated or ``(nrows,)`` vector.
TARGETS: dict[str, Callable[[Block, ResolvedMove, RotAt], np.ndarray]] = {
    "fixed": _fixed_target, "handle": _handle_target, "tie": _tie_target, "point": _point_target,
    "relative": _relative_target, "feature": _feature_target, "motion": _motion_target, "sliding": _fixed_target,
    "target": _target_target, "symmetry": _fixed_target, "cyclic": _fixed_target,
    **{kind: _edit_target for kind in EDIT_KINDS},
}


def block_target(b: Block, mv: ResolvedMove, rot_at: RotAt) -> np.ndarray:
    """Target values of a block's rows for a MOVE (:data:`TARGETS`)."""
    return TARGETS[b.kind](b, mv, rot_at)


# --------------------------------------------------------------------- helpers
def check_ids(ids: list[int] | tuple[int, ...], n: int, where: str, referenced: np.ndarray) -> np.ndarray:
    """Vertex ids as an int64 array, refusing ids out of range or used by no element (corner) node."""
    a = np.asarray(ids, np.int64)
    bad = a[(a < 0) | (a >= n)]
    if bad.size:
        raise SpecError(f"{where}: vertex ids {format_ids(bad)} out of range [0, {n})", field=where,
                        ids=bad[:REPORT_IDS].tolist())
    unused = a[~referenced[a]]
    if unused.size:
        raise SpecError(f"{where}: vertices {format_ids(unused)} are not corner nodes of any element (constraints "
                        "other than fixed and handle selections act on corner nodes; mid-side nodes follow them)",
                        field=where, ids=unused[:REPORT_IDS].tolist())
    return a


def point_weights(p: PointDef, mesh: Mesh, sel_ids: dict[str, np.ndarray], where: str
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and weights of a POINT: its own, or the corner nodes of a selection with equal weights."""
    if p.selection is not None:
        ids = sel_ids[p.selection]
        ids = ids[mesh.referenced[ids]]
        if not ids.size:
            raise SpecError(f"{where}: selection {p.selection!r} has no corner node", field=where)
        return ids, np.full(ids.size, 1.0 / ids.size)
    return check_ids(p.vertices, mesh.n, where, mesh.referenced), np.asarray(p.weights, np.float64)


def _unit(v: tuple[float, ...] | list[float]) -> np.ndarray:
    a = np.asarray(v, np.float64)
    return a / np.linalg.norm(a)


def _perp_pair(t: np.ndarray) -> np.ndarray:
    """Two unit normals orthogonal to ``t`` and to each other (2, 3)."""
    a = np.eye(3)[int(np.argmin(np.abs(t)))]
    n1 = np.cross(t, a)
    n1 /= np.linalg.norm(n1)
    return np.stack([n1, np.cross(t, n1)])


def _tree(ids: np.ndarray, mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Spanning tree (parent, child) of the mesh edges among ``ids``; components joined at roots."""
    n = mesh.n
    inside = np.zeros(n, bool)
    inside[ids] = True
    if mesh.cells:  # mixed elements: their edges
        E = mesh.edges
    else:
        T = mesh.T
        T = T[inside[T].sum(axis=1) >= 2]
        E = simplex_edges(T, unique=False)  # repeats sum in G: the tree is as before
    E = E[inside[E].all(axis=1)]
    loc = np.full(n, -1, np.int64)
    loc[ids] = np.arange(ids.size)
    e = loc[E]
    L = np.linalg.norm(mesh.V[E[:, 0]] - mesh.V[E[:, 1]], axis=1) + 1e-300
    G = sp.coo_matrix((L, (e[:, 0], e[:, 1])), shape=(ids.size, ids.size)).tocsr()
    Tr = minimum_spanning_tree(G + G.T).tocoo()
    par, chi = list(ids[Tr.row]), list(ids[Tr.col])
    ncomp, lab = connected_components(Tr, directed=False)
    roots = [int(ids[np.flatnonzero(lab == c)[0]]) for c in range(ncomp)]
    for r in roots[1:]:  # one rigid body: join the pieces at their first vertices
        par.append(roots[0])
        chi.append(r)
    return np.asarray(par, np.int64), np.asarray(chi, np.int64)


def _pairs(m: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows and coefficients of ``m`` rows ``p_a - p_b``."""
    return np.repeat(np.arange(m), 2), np.tile([1.0, -1.0], m)


# -------------------------------------------------------------------- builders
def fixed_rows(V0: np.ndarray, fixed: np.ndarray) -> Block:
    """``p_i = p0_i`` for every fixed vertex (eq. 2.6)."""
    return Block("fixed", 0, "fixed", fixed.size, np.arange(fixed.size), fixed, np.ones(fixed.size),
                 rest=V0[fixed], vertices=fixed)


def handle_rows(V0: np.ndarray, h: int, name: str, ids: np.ndarray, pivot: np.ndarray) -> Block:
    """``p_i = u_i`` for the vertices of handle ``h`` (eq. 3.3); ``u`` from the MOVE's rigid motion."""
    return Block("handle", h, name, ids.size, np.arange(ids.size), ids, np.ones(ids.size), rest=V0[ids],
                 pivot=pivot, vertices=ids)


def tie_rows(ties: np.ndarray) -> Block:
    """``p_i - p_j = 0`` for tied node pairs."""
    m = len(ties)
    r, c = _pairs(m)
    return Block("tie", 0, "ties", m, r, ties.ravel(), c, rest=np.zeros((m, 3)), vertices=unique(ties))


def point_rows(mesh: Mesh, k: int, e: PointEntry, sel_ids: dict[str, np.ndarray]) -> Block:
    """``sum_j w_j p_j = target`` for one SPEC point."""
    ids, w = point_weights(e.at, mesh, sel_ids, f"SPEC.points[{k}]")
    default = np.asarray(e.target) if e.target is not None else w @ mesh.V[ids]
    return Block("point", k, e.name, 1, np.zeros(ids.size, np.int64), ids, w, rest=default, vertices=ids)


def relative_rows(mesh: Mesh, k: int, e: RelativeEntry, sel_ids: dict[str, np.ndarray]) -> Block:
    """``a - b = v`` between two POINTs (ECLS eq. 28): ``v`` the rest offset, turned in mode ``rotate``."""
    where = f"SPEC.relative[{k}]"
    ia, wa = point_weights(e.a, mesh, sel_ids, where)
    ib, wb = point_weights(e.b, mesh, sel_ids, where)
    V0 = mesh.V
    d0 = wa @ V0[ia] - wb @ V0[ib]
    rv = -1
    if e.mode == "rotate":
        on_b = [int(x) for x in np.r_[ia, ib] if mesh.boundary[x]]
        if not on_b:
            raise SpecError(f"{where} ({e.name!r}) rotates with the rotation field, which lives on the boundary, "
                            "but its points use only interior vertices; use mode 'translate' or a boundary vertex",
                            code="no_boundary_vertex", field=f"relative[{k}]")
        rv = on_b[0]
    verts = np.r_[ia, ib]
    return Block("relative", k, e.name, 1, np.zeros(verts.size, np.int64), verts, np.r_[wa, -wb], rest=d0,
                 rot_vertex=rv, vertices=unique(verts))


def feature_rows(mesh: Mesh, k: int, e: FeatureEntry, ids: np.ndarray) -> Block | None:
    """Spanning-tree rows ``p_c - p_p = s R d0`` keeping a feature rigid (Form features §3)."""
    if ids.size < 2:
        return None
    par, chi = _tree(ids, mesh)
    D0 = mesh.V[chi] - mesh.V[par]
    root = -1
    if e.mode == "rigid":
        bids = ids[mesh.boundary[ids]]
        if not bids.size:
            raise SpecError(f"SPEC.features[{k}] ({e.name!r}) is rigid but has no boundary vertex to take its "
                            "rotation from", code="no_boundary_vertex", field=f"features[{k}]")
        root = int(bids[0])
    r, c = _pairs(par.size)
    return Block("feature", k, e.name, par.size, r, np.stack([chi, par], axis=1).ravel(), c, rest=D0,
                 rot_vertex=root, vertices=ids)


def motion_rows(mesh: Mesh, k: int, e: MotionEntry, sel_ids: dict[str, np.ndarray]) -> Block:
    """``n . x = n . q`` for a point on a plane (one row) or a line (two rows) through ``q``."""
    ids, w = point_weights(e.at, mesh, sel_ids, f"SPEC.motion[{k}]")
    N = _unit(e.normal)[None, :] if e.normal is not None else _perp_pair(_unit(e.direction or (0.0, 0.0, 1.0)))
    nr = N.shape[0]
    return Block("motion", k, e.name, nr, np.repeat(np.arange(nr), ids.size), np.tile(ids, nr), np.tile(w, nr),
                 rest=w @ mesh.V[ids], normal=N, vertices=ids)


def sliding_rows(mesh: Mesh, k: int, e: SlidingEntry, ids: np.ndarray) -> Block:
    """``n . p_i = n . p0_i`` for every node of a selection."""
    n = _unit(e.normal)
    return Block("sliding", k, e.selection, ids.size, np.arange(ids.size), ids, np.ones(ids.size),
                 rest=mesh.V[ids] @ n, normal=np.repeat(n[None, :], ids.size, axis=0), vertices=ids)


def mapped_rows(kind: str, index: int, name: str, m: Matching, system: str = "positions") -> Block:
    """``p_s = A sum_k w_k p_{m_k} + t`` for every matched slave: 3 coupled rows each.

    ``system="rotations"``: the quaternion logarithms transform as axial
    vectors, ``r_s = det(A) A sum_k w_k r_{m_k}`` (target 0).
    """
    s = m.slaves.size
    sign = float(np.sign(np.linalg.det(m.A))) if system == "rotations" else 1.0
    rows, verts, coef, nrm = [], [], [], []
    eye = np.eye(3)
    for e in range(3):
        r = 3 * np.arange(s) + e
        rows.append(r)
        verts.append(m.slaves)
        coef.append(np.ones(s))
        nrm.append(np.repeat(eye[e][None, :], s, axis=0))
        for k in range(3):
            w = m.weights[:, k]
            on = w != 0.0
            rows.append(r[on])
            verts.append(m.masters[on, k])
            coef.append(-sign * w[on])
            nrm.append(np.repeat(m.A[e][None, :], int(on.sum()), axis=0))
    rest = np.tile(m.t, s) if system == "positions" else np.zeros(3 * s)
    return Block(kind, index, name, 3 * s, np.concatenate(rows), np.concatenate(verts), np.concatenate(coef),
                 rest=rest, entry_normal=np.concatenate(nrm), vertices=unique(np.r_[m.slaves, m.masters.ravel()]))


def projected_rows(kind: str, index: int, name: str, ids: np.ndarray, N: np.ndarray, c: np.ndarray,
                   system: str = "positions") -> Block:
    """``N_k . p_i = N_k . c`` for every node (``N`` (r, 3) unit rows): nodes held on a plane or an axis.

    ``system="rotations"``: ``N_k . r_i = 0``.
    """
    r = N.shape[0]
    nrows = ids.size * r
    rows = np.arange(nrows)
    normal = np.tile(N, (ids.size, 1))
    rest = np.tile(N @ c, ids.size) if system == "positions" else np.zeros(nrows)
    return Block(kind, index, name, nrows, rows, np.repeat(ids, r), np.ones(nrows), rest=rest, normal=normal,
                 vertices=ids)


def tied_rows(name: str, index: int, m: Matching) -> Block:
    """``p_s - sum_k w_k p_{m_k} = 0``: a non-matching tie, one replicated row per slave (rotations alike)."""
    rows, verts, coef = [np.arange(m.slaves.size)], [m.slaves], [np.ones(m.slaves.size)]
    for k in range(3):
        w = m.weights[:, k]
        on = w != 0.0
        rows.append(np.flatnonzero(on))
        verts.append(m.masters[on, k])
        coef.append(-w[on])
    return Block("tie", index, name, m.slaves.size, np.concatenate(rows), np.concatenate(verts), np.concatenate(coef),
                 rest=np.zeros((m.slaves.size, 3)), vertices=unique(np.r_[m.slaves, m.masters.ravel()]))


def target_rows(index: int, name: str, V0: np.ndarray, ids: np.ndarray, q: np.ndarray) -> Block:
    """``p_i = p0_i + a (q_i - p0_i)``: nodes moved toward their target-surface points by the MOVE's amount."""
    return Block("target", index, name, ids.size, np.arange(ids.size), ids, np.ones(ids.size), rest=V0[ids], aux=q,
                 vertices=ids)


def edit_rows(V0: np.ndarray, e: Edit) -> Block:
    """``p_i = u_i`` for the corner nodes of an edit; ``u`` from the MOVE's value (:meth:`Edit.positions`)."""
    ids = e.ids
    return Block(e.kind, e.index, e.name, ids.size, np.arange(ids.size), ids, np.ones(ids.size), rest=V0[ids],
                 vertices=ids, edit=e)


def edit_slide_rows(V0: np.ndarray, e: Edit) -> Block | None:
    """``n_i . p_i = n_i . p0_i`` for the nodes an edit holds on planes (a fillet's faces), or None."""
    ids, N = e.slides
    if not ids.size:
        return None
    return Block(e.kind, e.index, e.name, ids.size, np.arange(ids.size), ids, np.ones(ids.size),
                 rest=np.einsum("ij,ij->i", N, V0[ids]), normal=N, vertices=ids)


def _corners(mesh: Mesh, ids: np.ndarray) -> np.ndarray:
    return ids[mesh.referenced[ids]]


def position_blocks(mesh: Mesh, spec: ResolvedSpec, sel_ids: dict[str, np.ndarray], fixed: np.ndarray,
                    handle_ids: dict[str, np.ndarray], handle_pivots: dict[str, np.ndarray],
                    ties: np.ndarray | None = None, corr: Correspondences | None = None,
                    edits: tuple[Edit, ...] = ()) -> list[Block]:
    """Rows of every hard positional constraint of ``spec``, in priority order.

    Parameters
    ----------
    mesh : Mesh
    spec : ResolvedSpec
    sel_ids : dict of str to (k,) int array
        Resolved selections (every node they name).
    fixed : (k,) int array
        Fixed corner nodes.
    handle_ids, handle_pivots : dict
        Corner nodes and default pivots of each handle.
    ties : (t, 2) int array, optional
    corr : Correspondences, optional
        Resolved symmetry, cyclic, surface-tie and target constraints.
    edits : tuple of Edit, optional
        Resolved edits (their rows follow the targets').

    Returns
    -------
    list of Block

    Raises
    ------
    SpecError
        Vertex ids out of range or unused; a rigid feature or a rotating
        relative constraint with no boundary vertex to take its rotation from.
    """
    V0 = mesh.V
    blocks: list[Block] = []
    if fixed.size:
        blocks.append(fixed_rows(V0, fixed))
    for h, (name, ids) in enumerate(handle_ids.items()):
        blocks.append(handle_rows(V0, h, name, ids, handle_pivots[name]))
    corr = corr or Correspondences()
    blocks += [target_rows(t.index, t.name, V0, t.ids, t.q) for t in corr.targets]
    blocks += [edit_rows(V0, e) for e in edits]
    blocks += [b for b in (edit_slide_rows(V0, e) for e in edits) if b is not None]
    if ties is not None and len(ties):
        blocks.append(tie_rows(ties))
    blocks += [tied_rows(name, k, m) for k, (name, m) in enumerate(corr.surface_ties)]
    for e in corr.mapped:
        if e.matching.slaves.size:
            blocks.append(mapped_rows(e.kind, e.index, e.name, e.matching))
        if e.fixed_nodes.size:
            blocks.append(projected_rows(e.kind, e.index, e.name, e.fixed_nodes, e.N, e.c))
    blocks += [point_rows(mesh, k, e, sel_ids) for k, e in enumerate(spec.points)]
    blocks += [relative_rows(mesh, k, e, sel_ids) for k, e in enumerate(spec.relative)]
    for k, f in enumerate(spec.features):
        b = feature_rows(mesh, k, f, _corners(mesh, sel_ids[f.selection]))
        if b is not None:
            blocks.append(b)
    blocks += [motion_rows(mesh, k, e, sel_ids) for k, e in enumerate(spec.motion)]
    blocks += [sliding_rows(mesh, k, e, _corners(mesh, sel_ids[e.selection])) for k, e in enumerate(spec.sliding)]
    return blocks


def rotation_blocks(mesh: Mesh, spec: ResolvedSpec, sel_ids: dict[str, np.ndarray], fixed: np.ndarray,
                    handle_ids: dict[str, np.ndarray], ties: np.ndarray | None = None,
                    corr: Correspondences | None = None, system: str = "rotations"
                    ) -> tuple[list[Block], list[np.ndarray]]:
    """Rows of the rotation system (ECLS eq. 26-29) and their targets per handle.

    The unknowns are the quaternion logarithms of the boundary vertices.
    Fixed vertices have ``r = 0``, handle ``h`` has ``r = c_h``; a rigid
    feature ties its boundary vertices' rotations together (``r_i - r_root =
    0``) and a ``keep_direction`` feature holds them at ``r = 0``; tied nodes
    share their rotation. Mirror and cyclic symmetry map rotations as axial
    vectors (:func:`mapped_rows`), which couples their coordinates:
    ``system="scales"`` gives the scalar system of the log-scales instead,
    where those become plain ties.

    Returns
    -------
    blocks : list of Block
        Rows over vertex ids (boundary vertices only); replicated, except the
        symmetry and cyclic ones in the rotation system.
    basis : list of (nrows, H) arrays
        Each block's targets as coefficients of the handles' logarithms.
    """
    B = mesh.boundary
    H = len(handle_ids)
    blocks: list[Block] = []
    basis: list[np.ndarray] = []

    def add(kind: str, index: int, name: str, ids: np.ndarray, tgt: np.ndarray) -> None:
        blocks.append(Block(kind, index, name, ids.size, np.arange(ids.size), ids, np.ones(ids.size), vertices=ids))
        basis.append(tgt)

    fb = fixed[B[fixed]]
    if fb.size:
        add("fixed", 0, "fixed", fb, np.zeros((fb.size, H)))
    for h, (name, ids) in enumerate(handle_ids.items()):
        hb = ids[B[ids]]
        if hb.size:
            t = np.zeros((hb.size, H))
            t[:, h] = 1.0
            add("handle", h, name, hb, t)
    if ties is not None and len(ties):
        tb = ties[B[ties].all(axis=1)]
        if len(tb):
            r, c = _pairs(len(tb))
            blocks.append(Block("tie", 0, "ties", len(tb), r, tb.ravel(), c, vertices=unique(tb)))
            basis.append(np.zeros((len(tb), H)))
    for k, e in enumerate(spec.features):
        ids = _corners(mesh, sel_ids[e.selection])
        bids = ids[B[ids]]
        if e.mode == "keep_direction":
            if bids.size:
                add("feature", k, e.name, bids, np.zeros((bids.size, H)))
        elif bids.size > 1:
            m = bids.size - 1
            r, c = _pairs(m)
            verts = np.stack([bids[1:], np.full(m, bids[0])], axis=1).ravel()
            blocks.append(Block("feature", k, e.name, m, r, verts, c, vertices=bids))
            basis.append(np.zeros((m, H)))
    corr = corr or Correspondences()
    for k, (name, mt) in enumerate(corr.surface_ties):
        on = B[mt.slaves] & B[mt.masters].all(axis=1)
        if on.any():
            blocks.append(tied_rows(name, k, _subset(mt, on)))
            basis.append(np.zeros((int(on.sum()), H)))
    for me in corr.mapped:
        mt = me.matching
        if mt.slaves.size:
            b = tied_rows(me.name, me.index, mt) if system == "scales" else mapped_rows(me.kind, me.index, me.name, mt,
                                                                                      "rotations")
            blocks.append(Block(me.kind, *_fields(b)) if system == "scales" else b)
            basis.append(np.zeros((blocks[-1].nrows, H)))
        if me.fixed_nodes.size and system == "rotations":
            # on the plane only rotations about its normal are symmetric; on the axis, about the axis
            N = _perp_pair(me.N[0]) if me.kind == "symmetry" else me.N
            blocks.append(projected_rows(me.kind, me.index, me.name, me.fixed_nodes, N, np.zeros(3), "rotations"))
            basis.append(np.zeros((blocks[-1].nrows, H)))
    return blocks, basis


def _subset(m: Matching, keep: np.ndarray) -> Matching:
    return Matching(m.slaves[keep], m.masters[keep], m.weights[keep], m.A, m.t, m.gap[keep])


def _fields(b: Block) -> tuple:
    """A block's fields after its kind (to rebuild it under another kind)."""
    return (b.index, b.name, b.nrows, b.row, b.vert, b.coeff, b.rest, b.normal, b.entry_normal, b.pivot, b.aux,
            b.rot_vertex, b.vertices, b.edit)
