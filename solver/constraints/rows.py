"""Hard constraint rows of a SPEC and their targets for a MOVE.

Every hard constraint is a set of linear rows over vertex positions, in one of
two forms:

*replicated*
    ``sum_k a_k p_{v_k} = u`` with one coefficient per vertex and a target
    ``u`` in R^3: the same row for x, y and z. Positional constraints (eq.
    2.6, 3.3), points on edges and faces, relative constraints ``p_i - p_j =
    v`` (ECLS eq. 28) and the spanning-tree rows of form features (Form
    features §3) are replicated.
*vector*
    ``sum_k a_k n . p_{v_k} = t`` with a normal ``n``: motion on a plane or a
    line (Form features §3.2) and per-node sliding. These couple the three
    coordinates, so a solve that has any of them works on 3n unknowns.

Rows are listed in priority order (fixed, handles, points, relative,
features, motion, sliding): when constraints are dependent, earlier rows are
kept and later ones are reported (ECLS §5).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

from ..errors import SpecError, format_ids
from ..mesh import Mesh
from ..ops.boundary_facets import simplex_edges
from ..ops.rotation import log_to_matrix, rotate_by_log
from .spec import Move, Spec

__all__ = ["Block", "position_blocks", "rotation_blocks", "assemble", "block_targets", "describe"]

KINDS = ("fixed", "handle", "tie", "point", "relative", "feature", "motion", "sliding")


@dataclass
class Block:
    """One SPEC entry's rows.

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
    target : callable
        ``target(move, rot_at) -> (nrows, 3)`` for replicated rows, ``(nrows,)``
        for vector rows; ``rot_at(ids)`` gives quaternion logarithms (k, 3) of
        boundary vertices.
    uses_rotation : bool
        Whether the target depends on the rotation field.
    """

    kind: str
    index: int
    name: str
    nrows: int
    row: np.ndarray
    vert: np.ndarray
    coeff: np.ndarray
    target: Callable[[Move, Callable[[np.ndarray], np.ndarray]], np.ndarray]
    normal: np.ndarray | None = None
    uses_rotation: bool = False
    vertices: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))

    @property
    def vector(self) -> bool:
        """Whether the rows couple the coordinates."""
        return self.normal is not None

    def row_vertices(self, k: int) -> list[int]:
        """Vertices of row ``k``."""
        return self.vert[self.row == k].tolist()


def _check_ids(ids: list[int], n: int, where: str, referenced: np.ndarray) -> np.ndarray:
    a = np.asarray(ids, np.int64)
    bad = a[(a < 0) | (a >= n)]
    if bad.size:
        raise SpecError(f"{where}: vertex ids {format_ids(bad)} out of range [0, {n})", field=where,
                        ids=bad[:100].tolist())
    unused = a[~referenced[a]]
    if unused.size:
        raise SpecError(f"{where}: vertices {format_ids(unused)} are used by no element", field=where,
                        ids=unused[:100].tolist())
    return a


def _point(entry: dict, mesh: Mesh, sel_ids: dict[str, np.ndarray], where: str
           ) -> tuple[np.ndarray, np.ndarray]:
    if "selection" in entry:
        ids = sel_ids[entry["selection"]]
        return ids, np.full(ids.size, 1.0 / ids.size)
    ids = _check_ids(entry["vertices"], mesh.n, where, mesh.referenced)
    return ids, np.asarray(entry["weights"], np.float64)


def _unit(v: list[float]) -> np.ndarray:
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


#: Coincidence tolerance of automatic ties, relative to the mesh diagonal.
TIE_TOL = 1e-9


def tie_pairs(mesh: Mesh, ties: Any) -> np.ndarray:
    """(k, 2) vertex pairs tied by ``SPEC.ties`` (coincident nodes of different bodies).

    Raises
    ------
    SpecError
        Ids out of range or unused in an explicit list.
    """
    if ties is False:
        return np.zeros((0, 2), np.int64)
    if isinstance(ties, list):
        pairs = np.asarray(ties, np.int64).reshape(-1, 2)
        _check_ids(pairs.ravel().tolist(), mesh.n, "SPEC.ties", mesh.referenced)
        return pairs
    from scipy.spatial import cKDTree

    ref = np.flatnonzero(mesh.referenced)
    if not ref.size:
        return np.zeros((0, 2), np.int64)
    V = mesh.V[ref]
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    tol = float(ties["tolerance"]) if isinstance(ties, dict) else TIE_TOL * diag
    pairs = cKDTree(V).query_pairs(tol, output_type="ndarray")
    if not len(pairs):
        return np.zeros((0, 2), np.int64)
    pairs = ref[pairs]
    lab = mesh.body_labels
    return np.sort(pairs[lab[pairs[:, 0]] != lab[pairs[:, 1]]], axis=1)


def position_blocks(mesh: Mesh, spec: Spec, sel_ids: dict[str, np.ndarray], fixed: np.ndarray,
                    handle_ids: dict[str, np.ndarray], handle_centroids: dict[str, np.ndarray],
                    ties: np.ndarray | None = None) -> list[Block]:
    """Rows of every hard positional constraint of ``spec``, in priority order.

    Parameters
    ----------
    mesh : Mesh
    spec : Spec
    sel_ids : dict of str to (k,) int array
        Resolved selections.
    fixed : (k,) int array
        Fixed vertices.
    handle_ids, handle_centroids : dict
        Vertices and rest centroids of each handle.

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
    B = mesh.boundary
    blocks: list[Block] = []

    def single(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return np.arange(ids.size), ids, np.ones(ids.size)

    if fixed.size:
        r, v, c = single(fixed)
        blocks.append(Block("fixed", 0, "fixed", fixed.size, r, v, c,
                            lambda mv, rot, ids=fixed: V0[ids], vertices=fixed))
    for h, (name, ids) in enumerate(handle_ids.items()):
        r, v, c = single(ids)

        def tgt(mv: Move, rot: Callable, ids: np.ndarray = ids, name: str = name) -> np.ndarray:
            hm = mv.handles.get(name)
            return V0[ids] if hm is None else hm.apply(V0[ids], handle_centroids[name])

        blocks.append(Block("handle", h, name, ids.size, r, v, c, tgt, vertices=ids))
    if ties is not None and len(ties):
        m = len(ties)
        blocks.append(Block("tie", 0, "ties", m, np.repeat(np.arange(m), 2), ties.ravel(), np.tile([1.0, -1.0], m),
                            lambda mv, rot, m=m: np.zeros((m, 3)), vertices=np.unique(ties)))
    for k, e in enumerate(spec.points):
        ids, w = _point(e, mesh, sel_ids, f"SPEC.points[{k}]")
        default = np.asarray(e["target"]) if "target" in e else w @ V0[ids]

        def tgt(mv: Move, rot: Callable, name: str = e["name"], default: np.ndarray = default
                ) -> np.ndarray:
            return mv.points.get(name, default)[None, :]

        blocks.append(Block("point", k, e["name"], 1, np.zeros(ids.size, np.int64), ids, w, tgt,
                            vertices=ids))
    for k, e in enumerate(spec.relative):
        ids = _check_ids(e["vertices"], mesh.n, f"SPEC.relative[{k}]", mesh.referenced)
        i, j = int(ids[0]), int(ids[1])
        d0 = V0[i] - V0[j]
        rv = -1
        if e["mode"] == "rotate":
            on_b = [x for x in (i, j) if B[x]]
            if not on_b:
                raise SpecError(f"SPEC.relative[{k}] ({e['name']!r}) rotates with the rotation field, "
                                f"which lives on the boundary, but vertices {i} and {j} are both "
                                "interior; use mode 'translate' or a boundary vertex",
                                code="no_boundary_vertex", field=f"relative[{k}]")
            rv = on_b[0]

        def tgt(mv: Move, rot: Callable, name: str = e["name"], d0: np.ndarray = d0, rv: int = rv
                ) -> np.ndarray:
            o = mv.relative.get(name, {})
            if "offset" in o:
                return o["offset"][None, :]
            v = rotate_by_log(d0[None, :], rot(np.array([rv]))) if rv >= 0 else d0[None, :]
            return o.get("scale", 1.0) * v

        blocks.append(Block("relative", k, e["name"], 1, np.zeros(2, np.int64), ids, np.array([1.0, -1.0]),
                            tgt, uses_rotation=rv >= 0, vertices=ids))
    for k, e in enumerate(spec.features):
        ids = sel_ids[e["selection"]]
        if ids.size < 2:
            continue
        par, chi = _tree(ids, mesh)
        D0 = V0[chi] - V0[par]
        root = -1
        if e["mode"] == "rigid":
            bids = ids[B[ids]]
            if not bids.size:
                raise SpecError(f"SPEC.features[{k}] ({e['name']!r}) is rigid but has no boundary vertex "
                                "to take its rotation from", code="no_boundary_vertex",
                                field=f"features[{k}]")
            root = int(bids[0])
        m = par.size

        def tgt(mv: Move, rot: Callable, name: str = e["name"], D0: np.ndarray = D0, root: int = root
                ) -> np.ndarray:
            s = mv.features.get(name, 1.0)
            if root < 0:
                return s * D0
            return (s * D0) @ log_to_matrix(rot(np.array([root]))[0]).T

        rows = np.repeat(np.arange(m), 2)
        verts = np.stack([chi, par], axis=1).ravel()
        coef = np.tile([1.0, -1.0], m)
        blocks.append(Block("feature", k, e["name"], m, rows, verts, coef, tgt, uses_rotation=root >= 0,
                            vertices=ids))
    for k, e in enumerate(spec.motion):
        ids, w = _point(e, mesh, sel_ids, f"SPEC.motion[{k}]")
        N = _unit(e["plane"]["normal"])[None, :] if "plane" in e else _perp_pair(_unit(e["line"]["direction"]))
        x0 = w @ V0[ids]

        def tgt(mv: Move, rot: Callable, name: str = e["name"], N: np.ndarray = N, x0: np.ndarray = x0
                ) -> np.ndarray:
            return N @ mv.motion.get(name, x0)

        nr = N.shape[0]
        blocks.append(Block("motion", k, e["name"], nr, np.repeat(np.arange(nr), ids.size),
                            np.tile(ids, nr), np.tile(w, nr), tgt, normal=N, vertices=ids))
    for k, e in enumerate(spec.sliding):
        ids = sel_ids[e["selection"]]
        n = _unit(e["normal"])
        t0 = V0[ids] @ n
        blocks.append(Block("sliding", k, e["selection"], ids.size, np.arange(ids.size), ids,
                            np.ones(ids.size), lambda mv, rot, t0=t0: t0,
                            normal=np.repeat(n[None, :], ids.size, axis=0), vertices=ids))
    return blocks


def rotation_blocks(mesh: Mesh, spec: Spec, sel_ids: dict[str, np.ndarray], fixed: np.ndarray,
                    handle_ids: dict[str, np.ndarray], ties: np.ndarray | None = None
                    ) -> tuple[list[Block], list[np.ndarray]]:
    """Rows of the rotation system (ECLS eq. 26-29) and their targets per handle.

    The unknowns are the quaternion logarithms of the boundary vertices.
    Fixed vertices have ``r = 0``, handle ``h`` has ``r = c_h``; a rigid
    feature ties its boundary vertices' rotations together (``r_i - r_root =
    0``) and a ``keep_direction`` feature holds them at ``r = 0``.

    Returns
    -------
    blocks : list of Block
        Replicated rows over vertex ids (boundary vertices only).
    basis : list of (nrows, H) arrays
        Each block's targets as coefficients of the handles' logarithms.
    """
    B = mesh.boundary
    H = len(handle_ids)
    blocks: list[Block] = []
    basis: list[np.ndarray] = []

    def add(kind: str, index: int, name: str, ids: np.ndarray, tgt: np.ndarray) -> None:
        blocks.append(Block(kind, index, name, ids.size, np.arange(ids.size), ids, np.ones(ids.size),
                            lambda mv, rot: None, vertices=ids))
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
            m = len(tb)
            blocks.append(Block("tie", 0, "ties", m, np.repeat(np.arange(m), 2), tb.ravel(), np.tile([1.0, -1.0], m),
                                lambda mv, rot: None, vertices=np.unique(tb)))
            basis.append(np.zeros((m, H)))
    for k, e in enumerate(spec.features):
        ids = sel_ids[e["selection"]]
        bids = ids[B[ids]]
        if e["mode"] == "keep_direction":
            if bids.size:
                add("feature", k, e["name"], bids, np.zeros((bids.size, H)))
        elif bids.size > 1:
            m = bids.size - 1
            rows = np.repeat(np.arange(m), 2)
            verts = np.stack([bids[1:], np.full(m, bids[0])], axis=1).ravel()
            blocks.append(Block("feature", k, e["name"], m, rows, verts, np.tile([1.0, -1.0], m),
                                lambda mv, rot: None, vertices=bids))
            basis.append(np.zeros((m, H)))
    return blocks, basis


@dataclass
class Assembly:
    """Constraint rows of a set of blocks over one system's unknowns.

    Attributes
    ----------
    C : (m, N) csr matrix
    block : (m,) int array
        Block of each row.
    local : (m,) int array
        Row within its block.
    coord : (m,) int array
        Coordinate of an expanded replicated row (vector layout), else -1.
    vector : bool
        Whether unknowns are interleaved coordinates (3 per vertex).
    """

    C: sp.csr_matrix
    block: np.ndarray
    local: np.ndarray
    coord: np.ndarray
    vector: bool


def assemble(blocks: list[Block], umap: np.ndarray, N: int, vector: bool) -> Assembly:
    """Rows of ``blocks`` over unknowns ``umap[vertex]`` (``-1``: not an unknown).

    With ``vector`` the unknowns are ``3 * umap[v] + c``; replicated rows expand
    to three rows (x, y, z). Rows whose vertices are all non-unknowns are left
    out (their vertices are known to the caller).

    Raises
    ------
    ValueError
        A row mixes unknown and non-unknown vertices.
    """
    Cr, Cc, Cv = [], [], []
    blk, loc, crd = [], [], []
    m = 0
    for b_i, b in enumerate(blocks):
        u = umap[b.vert]
        has = np.zeros(b.nrows, bool)
        has[b.row[u >= 0]] = True
        mixed = np.zeros(b.nrows, bool)
        mixed[b.row[u < 0]] = True
        if np.any(has & mixed):
            raise ValueError(f"{b.kind} {b.name!r}: a row mixes unknown and known vertices")
        keep_rows = np.flatnonzero(has)
        if not keep_rows.size:
            continue
        newrow = np.full(b.nrows, -1, np.int64)
        newrow[keep_rows] = np.arange(keep_rows.size)
        e = has[b.row]
        r, uu, cv = newrow[b.row[e]], u[e], b.coeff[e]
        k = keep_rows.size
        if not vector:
            Cr.append(m + r), Cc.append(uu), Cv.append(cv)
            blk.append(np.full(k, b_i)), loc.append(keep_rows), crd.append(np.full(k, -1))
            m += k
        elif b.vector:
            nrm = b.normal[b.row[e]]  # (e, 3)
            Cr.append(np.repeat(m + r, 3)), Cc.append((3 * uu[:, None] + np.arange(3)).ravel())
            Cv.append((cv[:, None] * nrm).ravel())
            blk.append(np.full(k, b_i)), loc.append(keep_rows), crd.append(np.full(k, -1))
            m += k
        else:
            for c in range(3):
                Cr.append(m + 3 * r + c), Cc.append(3 * uu + c), Cv.append(cv)
            blk.append(np.full(3 * k, b_i)), loc.append(np.repeat(keep_rows, 3))
            crd.append(np.tile(np.arange(3), k))
            m += 3 * k
    cat = (lambda p, dt: np.concatenate(p).astype(dt) if p else np.zeros(0, dt))
    C = sp.csr_matrix((cat(Cv, float), (cat(Cr, np.int64), cat(Cc, np.int64))),
                      shape=(m, 3 * N if vector else N))
    return Assembly(C, cat(blk, np.int64), cat(loc, np.int64), cat(crd, np.int64), vector)


def block_targets(blocks: list[Block], asm: Assembly, move: Move,
                  rot_at: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Targets ``d`` of the assembled rows: (m, 3) replicated, (m, 1) vector layout."""
    per = {}
    for b_i in np.unique(asm.block):
        per[int(b_i)] = np.asarray(blocks[b_i].target(move, rot_at), np.float64)
    if not asm.vector:
        d = np.zeros((asm.C.shape[0], 3))
        for b_i, t in per.items():
            rows = asm.block == b_i
            d[rows] = t[asm.local[rows]]
        return d
    d = np.zeros((asm.C.shape[0], 1))
    for b_i, t in per.items():
        rows = np.flatnonzero(asm.block == b_i)
        if blocks[b_i].vector:
            d[rows, 0] = t[asm.local[rows]]
        else:
            d[rows, 0] = t[asm.local[rows], asm.coord[rows]]
    return d


def describe(blocks: list[Block], asm: Assembly, rows: np.ndarray, system: str,
             residual: np.ndarray | None = None, limit: int = 100) -> list[dict]:
    """REPORT entries (kind, index, name, vertices[, residual]) for constraint rows ``rows``.

    Rows of one SPEC entry that only differ in coordinate are merged (largest residual).
    """
    out: dict[tuple[int, int], dict] = {}
    for k, r in enumerate(rows):
        b = blocks[int(asm.block[r])]
        key = (int(asm.block[r]), int(asm.local[r]))
        ent = out.get(key)
        if ent is None:
            if len(out) >= limit:
                continue
            ent = {"system": system, "kind": b.kind, "index": b.index, "name": b.name,
                   "vertices": b.row_vertices(int(asm.local[r]))[:20]}
            out[key] = ent
        if residual is not None:
            ent["residual"] = max(ent.get("residual", 0.0), float(residual[k]))
    return list(out.values())
