"""Validation of mesh arrays: shapes, indices, orientation, and edge and vertex manifoldness.

:func:`validate` raises a typed error naming the first defect that makes the
mesh impossible to morph, and returns a :class:`Validation` with what it found
that is not fatal: tetrahedra that are flat at rest, and coincident nodes of
bodies that are otherwise manifold (the parts of an assembly, tied by the SPEC).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import MAX_IDS, InvalidMeshError, TopologyError, format_ids
from ..limits import COORD_MAX
from ..ops.boundary_facets import boundary_facets
from ..ops.elements import LINEAR_TYPES, boundary_faces, corner_jacobians, element_blocks
from ..ops.unique import unique
from ..validity.quality import degenerate_mask, signed_volumes

__all__ = ["validate", "Validation", "component_labels", "coincident_pairs", "fan_counts", "link_euler"]

#: Nodes closer than this fraction of the bounding-box diagonal are coincident.
COINCIDENT_TOL = 1e-10


@dataclass(frozen=True)
class Validation:
    """What :func:`validate` found that does not stop a morph.

    Attributes
    ----------
    degenerate_at_rest : (k,) int64 array
        Tetrahedra with zero volume at rest (:func:`solver.validity.quality.degenerate_mask`),
        element ids as :attr:`solver.mesh.Mesh.blocks` numbers them.
    coincident_nodes : (p, 2) int64 array
        Pairs of used vertices at the same position (lower id first).
    """

    degenerate_at_rest: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    coincident_nodes: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))


def component_labels(E: np.ndarray, n: int, mask: np.ndarray) -> np.ndarray:
    """(n,) connected component of each masked vertex over the elements ``E``, -1 elsewhere."""
    labels = np.full(n, -1, dtype=np.int64)
    if E.size == 0:
        return labels
    k = E.shape[1]
    r = np.repeat(E[:, 0], k - 1)
    c = E[:, 1:].ravel()
    G = sp.csr_matrix((np.ones(r.size), (r, c)), shape=(n, n))
    _, lab = connected_components(G, directed=False)
    # renumber the components of masked vertices 0..c-1 in order of first vertex
    sub = lab[mask]
    _, first, inv = np.unique(sub, return_index=True, return_inverse=True)
    rank = np.argsort(np.argsort(first))
    labels[mask] = rank[inv]
    return labels


def validate(V: np.ndarray, T: np.ndarray, surface: np.ndarray | None = None,
             cells: dict[str, np.ndarray] | None = None) -> Validation:
    """Raise a typed error naming the first defect of a mesh; return what is not fatal.

    Checks, in order: shapes, element indices, non-finite coordinates of used
    vertices, repeated indices within an element, no elements, inverted tets
    (negative volume), inverted or flat hexahedra, wedges and pyramids (a corner
    Jacobian <= 0), edges in more than two boundary faces, the orientation of
    the boundary, and vertex manifoldness: the boundary faces around every
    boundary vertex form one fan, and (tetrahedra only) the link of every
    vertex is a disk (boundary) or a sphere (interior). Zero-volume tets are
    not refused: they are returned. A triangle surface may be open (its rim
    edges are in one face).

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array
    surface : (k, 3) int array, optional
        Triangles, for a surface-only mesh (``T`` empty).
    cells : dict, optional
        Other linear volume elements (:attr:`Mesh.cells`).

    Returns
    -------
    Validation

    Raises
    ------
    InvalidMeshError
        ``bad_shape``, ``index_out_of_range``, ``non_finite_coordinates``,
        ``repeated_index``, ``no_elements``, ``inverted_input``, ``degenerate_input``
        (every tetrahedron flat).
    TopologyError
        ``non_manifold_boundary``, ``inconsistent_orientation``,
        ``non_manifold_vertex``, or ``duplicate_nodes`` when coincident nodes
        come with one of these.
    """
    V = np.asarray(V)
    if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] == 0:
        what = "no vertices" if V.size == 0 else f"vertices of shape {V.shape}"
        raise InvalidMeshError(f"vertices must have shape (n, 3) with n >= 4, got {what}", code="bad_shape",
                               shape=list(V.shape))
    E = T if T.shape[0] else (surface if surface is not None else T)
    k = 4 if T.shape[0] else 3
    if E.ndim != 2 or E.shape[1] != k:
        raise InvalidMeshError(f"elements must have shape (m, {k}), got {E.shape}", code="bad_shape")
    cells = {k: v for k, v in (cells or {}).items() if len(v)}
    for kind, C in cells.items():
        _check_indices(V, C, f"{kind} elements")
    if E.shape[0] == 0 and cells:
        E = np.zeros((0, 4), np.int64)
    elif E.shape[0] == 0:
        raise InvalidMeshError("the mesh has no tetrahedra (and no triangles)", code="no_elements")
    n = V.shape[0]
    _check_indices(V, E, "elements")
    degenerate = np.zeros(0, np.int64)
    if T.shape[0]:
        vol = signed_volumes(V, T)
        degen = degenerate_mask(V, T, vol)
        inv = np.flatnonzero((vol < 0) & ~degen)
        if inv.size:
            raise InvalidMeshError(
                f"{inv.size} of {len(T)} input tetrahedra are inverted (negative volume); first "
                f"tets {format_ids(inv)}. Swap two nodes of each to fix the orientation.",
                code="inverted_input", tets=inv[:MAX_IDS].tolist(), count=int(inv.size))
        degenerate = np.flatnonzero(degen).astype(np.int64)
        if degenerate.size == len(T) and not cells:
            raise InvalidMeshError(
                f"all {len(T)} input tetrahedra have zero volume: the mesh is flat, there is no volume to "
                "morph (a surface belongs in a triangle file)", code="degenerate_input", count=int(len(T)))
    base = int(T.shape[0])
    for kind in LINEAR_TYPES[1:]:
        if kind not in cells:
            continue
        det, _ = corner_jacobians(V, cells[kind], kind)
        bad = np.flatnonzero(det <= 0)
        if bad.size:
            raise InvalidMeshError(
                f"{bad.size} of {len(det)} input {kind} elements are inverted or flat (a corner "
                f"Jacobian <= 0); first elements {format_ids(bad + base)} (tets first, then "
                f"{', '.join(LINEAR_TYPES[1:])}), e.g. {kind} {bad[0]} = {cells[kind][bad[0]].tolist()}",
                code="inverted_input", elements=(bad[:MAX_IDS] + base).tolist(), count=int(bad.size))
        base += len(det)
    if cells:
        F, _ = boundary_faces(element_blocks(T, cells), n)
    elif T.shape[0]:
        F, _ = boundary_facets(T, n)
    else:
        F = surface if surface is not None else np.zeros((0, 3), np.int64)
    used = np.zeros(n, bool)
    used[E.ravel()] = True
    for C in cells.values():
        used[C.ravel()] = True
    pairs = coincident_pairs(V, used)
    try:
        _check_manifold_edges(F, n)
        _check_manifold_vertices(F, n, T if (T.shape[0] and not cells) else None, used)
        if not T.shape[0] and not cells and pairs.size:
            _check_rim_pairs(F, n, pairs)
    except TopologyError as e:
        if pairs.size:
            raise _duplicates(pairs, e) from e
        raise
    return Validation(degenerate_at_rest=degenerate, coincident_nodes=pairs)


def _check_indices(V: np.ndarray, C: np.ndarray, what: str) -> None:
    """Index range, repeated nodes and finite coordinates of one block of elements."""
    n = V.shape[0]
    bad = np.flatnonzero((C < 0).any(1) | (C >= n).any(1))
    if bad.size:
        raise InvalidMeshError(
            f"{bad.size} {what} reference vertices outside 0..{n - 1}; first elements "
            f"{format_ids(bad)}, e.g. element {bad[0]} = {C[bad[0]].tolist()}",
            code="index_out_of_range", elements=bad[:MAX_IDS].tolist(), vertices=n)
    used = np.zeros(n, bool)
    used[C.ravel()] = True
    nonfinite = np.flatnonzero(used & ~np.isfinite(V).all(1))
    if nonfinite.size:
        raise InvalidMeshError(
            f"{nonfinite.size} vertices have non-finite coordinates; first vertices "
            f"{format_ids(nonfinite)}", code="non_finite_coordinates", vertices=nonfinite[:MAX_IDS].tolist())
    huge = np.flatnonzero(used & (np.abs(V) > COORD_MAX).any(1))
    if huge.size:
        raise InvalidMeshError(
            f"{huge.size} vertices have a coordinate beyond +-{COORD_MAX:g}; first vertices {format_ids(huge)}, "
            f"e.g. vertex {huge[0]} = {V[huge[0]].tolist()}", code="coordinates_out_of_range",
            vertices=huge[:MAX_IDS].tolist(), bound=COORD_MAX)
    S = np.sort(C, axis=1)
    rep = np.flatnonzero((S[:, 1:] == S[:, :-1]).any(1))
    if rep.size:
        raise InvalidMeshError(
            f"{rep.size} {what} repeat a vertex index; first elements {format_ids(rep)}, "
            f"e.g. element {rep[0]} = {C[rep[0]].tolist()}",
            code="repeated_index", elements=rep[:MAX_IDS].tolist())


def coincident_pairs(V: np.ndarray, used: np.ndarray, tol: float = COINCIDENT_TOL) -> np.ndarray:
    """Pairs of used vertices at the same position (within ``tol`` of the bounding-box diagonal).

    Positions are snapped to a grid of that spacing; each vertex of a group is
    paired with the group's lowest id.

    Parameters
    ----------
    V : (n, 3) float array
    used : (n,) bool array
    tol : float

    Returns
    -------
    (p, 2) int64 array
        ``[low, high]`` vertex ids, sorted.

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> coincident_pairs(V, np.ones(5, bool)).tolist()
    [[0, 2], [1, 3]]
    """
    ids = np.flatnonzero(used)
    if ids.size < 2:
        return np.zeros((0, 2), np.int64)
    P = V[ids]
    diag = float(np.linalg.norm(P.max(0) - P.min(0))) or 1.0
    Q = np.round((P - P.min(0)) / (tol * diag))
    order = np.lexsort((Q[:, 2], Q[:, 1], Q[:, 0]))
    Qs = Q[order]
    same = (Qs[1:] == Qs[:-1]).all(1)
    if not same.any():
        return np.zeros((0, 2), np.int64)
    group = np.cumsum(np.r_[True, ~same]) - 1  # group of each sorted row
    srt = ids[order]
    first = np.full(group[-1] + 1, np.iinfo(np.int64).max)
    np.minimum.at(first, group, srt)
    dup = np.r_[False, same] | np.r_[same, False]
    lo, hi = first[group[dup]], srt[dup]
    keep = lo != hi
    out = np.stack([lo[keep], hi[keep]], 1)
    return out[np.lexsort((out[:, 1], out[:, 0]))]


def _check_manifold_edges(F: np.ndarray, n: int) -> None:
    """Refuse boundary edges in more than two faces, or used twice in one direction.

    An edge in one face is the rim of an open surface.
    """
    if not F.size:
        return
    He = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    key = np.minimum(He[:, 0], He[:, 1]) * n + np.maximum(He[:, 0], He[:, 1])
    uniq, counts = np.unique(key, return_counts=True)
    bad = np.flatnonzero(counts > 2)
    if bad.size:
        e = np.stack([uniq[bad] // n, uniq[bad] % n], 1)
        raise TopologyError(
            f"{bad.size} boundary edges are shared by more than two boundary faces (non-manifold: "
            f"bodies that touch along an edge); first edges {e[:5].tolist()} (in "
            f"{counts[bad][:5].tolist()} faces)", code="non_manifold_boundary", edges=e[:MAX_IDS].tolist(),
            count=int(bad.size))
    directed = He[:, 0] * n + He[:, 1]
    if unique(directed).size != directed.size:
        s = np.sort(directed)
        d = s[1:][s[1:] == s[:-1]][0]
        raise TopologyError(
            "the boundary surface is not consistently oriented: edge "
            f"[{d // n}, {d % n}] is used twice in the same direction (flip the triangles on one side "
            "of it)", code="inconsistent_orientation", edge=[int(d // n), int(d % n)])


def fan_counts(F: np.ndarray, n: int) -> np.ndarray:
    """Number of fans the faces around each vertex make (0 off the faces; 1 for a manifold vertex).

    Two faces at a vertex ``v`` are in one fan when a chain of faces around
    ``v`` joins them, each sharing an edge ``(v, x)`` with the next.

    Parameters
    ----------
    F : (k, 3) int array
    n : int

    Returns
    -------
    (n,) int64 array

    Examples
    --------
    >>> bowtie = np.array([[0, 1, 2], [0, 3, 4]])  # two triangles sharing vertex 0 only
    >>> fan_counts(bowtie, 5).tolist()
    [2, 1, 1, 1, 1]
    """
    k = F.shape[0]
    out = np.zeros(n, np.int64)
    if k == 0:
        return out
    v = F.ravel()  # corner i = 3 f + c
    x1 = F[:, [1, 2, 0]].ravel()
    x2 = F[:, [2, 0, 1]].ravel()
    keys = np.concatenate([v * n + x1, v * n + x2])
    ids = np.tile(np.arange(3 * k), 2)
    order = np.argsort(keys, kind="stable")
    ks, io = keys[order], ids[order]
    same = ks[1:] == ks[:-1]
    G = sp.coo_matrix((np.ones(int(same.sum())), (io[:-1][same], io[1:][same])), shape=(3 * k, 3 * k))
    _, comp = connected_components(G, directed=False)
    pairs = unique(v * (3 * k) + comp)
    np.add.at(out, pairs // (3 * k), 1)
    return out


def link_euler(T: np.ndarray, n: int, F: np.ndarray | None = None) -> np.ndarray:
    """Euler characteristic of each vertex's link in a tet mesh.

    1 for a boundary vertex whose link is a disk, 2 for an interior vertex
    whose link is a sphere, 0 for unused vertices.

    The link of ``v`` has a vertex per edge at ``v``, an edge per face at ``v``
    and a triangle per tet at ``v``. With every face in one or two tets, the
    faces at ``v`` number ``(3 tets(v) + boundary faces(v)) / 2``, so
    ``chi(v) = edges(v) - (tets(v) + boundary faces(v)) / 2``.

    Parameters
    ----------
    T : (m, 4) int array
    n : int
    F : (k, 3) int array, optional
        The boundary faces (:func:`solver.ops.boundary_facets.boundary_facets`).

    Returns
    -------
    (n,) int64 array

    Examples
    --------
    >>> link_euler(np.array([[0, 1, 2, 3], [0, 4, 5, 6]]), 7).tolist()  # two tets sharing vertex 0
    [2, 1, 1, 1, 1, 1, 1]
    """
    T = np.asarray(T, np.int64)
    if F is None:
        F = boundary_facets(T, n)[0]
    a = np.concatenate([T[:, i] for i in (0, 0, 0, 1, 1, 2)])
    b = np.concatenate([T[:, j] for j in (1, 2, 3, 2, 3, 3)])
    e = unique(np.minimum(a, b) * n + np.maximum(a, b))
    edges = np.bincount(e // n, minlength=n) + np.bincount(e % n, minlength=n)
    tets = np.bincount(T.ravel(), minlength=n)
    bf = np.bincount(np.asarray(F, np.int64).ravel(), minlength=n)
    return (edges - (tets + bf) // 2).astype(np.int64)


def _check_manifold_vertices(F: np.ndarray, n: int, T: np.ndarray | None, used: np.ndarray) -> None:
    """Refuse vertices where the boundary pinches (several fans) or whose link is not a disk or sphere."""
    fans = fan_counts(F, n)
    bad = np.flatnonzero(fans > 1)
    if bad.size:
        raise TopologyError(
            f"{bad.size} vertices are non-manifold: the boundary faces around each form {fans[bad].max()} or "
            f"more separate fans (parts that touch at a vertex or along an edge through the body, a "
            f"bow-tie); first vertices {format_ids(bad)}. Separate the parts (duplicate the shared nodes "
            "and tie them in the SPEC) or remove the elements that touch.",
            code="non_manifold_vertex", vertices=bad[:MAX_IDS].tolist(), count=int(bad.size), kind="boundary_fans")
    if T is None:
        return
    chi = link_euler(T, n, F)
    on_boundary = np.zeros(n, bool)
    on_boundary[F.ravel()] = True
    want = np.where(on_boundary, 1, 2)
    bad = np.flatnonzero(used & (chi != want))
    if bad.size:
        raise TopologyError(
            f"{bad.size} vertices are non-manifold: the tetrahedra around each do not form one ball (the "
            f"link of vertex {bad[0]} has Euler characteristic {chi[bad[0]]}, not {want[bad[0]]}); first "
            f"vertices {format_ids(bad)}", code="non_manifold_vertex", vertices=bad[:MAX_IDS].tolist(),
            count=int(bad.size), kind="link")


def _check_rim_pairs(F: np.ndarray, n: int, pairs: np.ndarray) -> None:
    """A surface whose open rims meet at coincident nodes is one surface that was not merged."""
    He = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, counts = np.unique(He[:, 0] * n + He[:, 1], return_counts=True)
    rim = np.zeros(n, bool)
    rim[uniq[counts == 1] // n] = True
    rim[uniq[counts == 1] % n] = True
    hit = rim[pairs[:, 0]] & rim[pairs[:, 1]]
    if hit.any():
        raise TopologyError(f"open rims meet at {int(hit.sum())} coincident node pairs",
                            code="non_manifold_boundary")


def _duplicates(pairs: np.ndarray, cause: TopologyError) -> TopologyError:
    shown = ", ".join(f"{a}-{b}" for a, b in pairs[:10].tolist()) + (" ..." if len(pairs) > 10 else "")
    return TopologyError(
        f"{len(pairs)} pairs of nodes are coincident (same position, different ids): {shown}. They split the "
        f"mesh where it should be one piece ({cause.message[:1].lower() + cause.message[1:]}). Merge them "
        "if the mesh is one part; if the parts are meant to be separate bodies that stay joined, keep them "
        "apart and let the SPEC's ties (default \"auto\") join coincident nodes of different bodies.",
        code="duplicate_nodes", pairs=pairs[:MAX_IDS].tolist(), count=int(len(pairs)), cause=cause.code)
