"""Validation of mesh arrays: shapes, indices, orientation and boundary manifoldness."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import InvalidMeshError, format_ids
from ..ops.boundary_facets import boundary_facets
from ..ops.elements import LINEAR_TYPES, boundary_faces, corner_jacobians, element_blocks
from ..validity.quality import degenerate_mask, signed_volumes

__all__ = ["validate", "component_labels"]


def component_labels(E: np.ndarray, n: int, mask: np.ndarray) -> np.ndarray:
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
             cells: dict[str, np.ndarray] | None = None) -> None:
    """Raise :class:`InvalidMeshError` naming the first defect of ``(V, T)``.

    Checks, in order: shapes, non-finite coordinates of used vertices, element
    indices out of range, repeated indices within an element, no elements,
    inverted and zero-volume tets, inverted or flat hexahedra, wedges and
    pyramids (a corner Jacobian <= 0), non-manifold faces and boundary edges.

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int array
    surface : (k, 3) int array, optional
        Triangles, for a surface-only mesh (``T`` empty).
    cells : dict, optional
        Other linear volume elements (:attr:`Mesh.cells`).

    Raises
    ------
    InvalidMeshError
    """
    if V.ndim != 2 or V.shape[1] != 3:
        raise InvalidMeshError(f"vertices must have shape (n, 3), got {V.shape}", code="bad_shape")
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
    if T.shape[0]:
        vol = signed_volumes(V, T)
        degen = degenerate_mask(V, T, vol)
        inv = np.flatnonzero((vol < 0) & ~degen)
        if inv.size:
            raise InvalidMeshError(
                f"{inv.size} of {len(T)} input tetrahedra are inverted (negative volume); first "
                f"tets {format_ids(inv)}. Swap two nodes of each to fix the orientation.",
                code="inverted_input", tets=inv[:100].tolist(), count=int(inv.size))
        zero = np.flatnonzero(degen)
        if zero.size:
            raise InvalidMeshError(
                f"{zero.size} input tetrahedra have zero volume; first tets {format_ids(zero)}",
                code="degenerate_input", tets=zero[:100].tolist(), count=int(zero.size))
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
                code="inverted_input", elements=(bad[:100] + base).tolist(), count=int(bad.size))
        base += len(det)
    if cells:
        F, _ = boundary_faces(element_blocks(T, cells), n)
    elif T.shape[0]:
        F, _ = boundary_facets(T, n)
    else:
        F = surface
    _check_manifold_edges(F, n)


def _check_indices(V: np.ndarray, C: np.ndarray, what: str) -> None:
    """Index range, repeated nodes and finite coordinates of one block of elements."""
    n = V.shape[0]
    bad = np.flatnonzero((C < 0).any(1) | (C >= n).any(1))
    if bad.size:
        raise InvalidMeshError(
            f"{bad.size} {what} reference vertices outside 0..{n - 1}; first elements "
            f"{format_ids(bad)}, e.g. element {bad[0]} = {C[bad[0]].tolist()}",
            code="index_out_of_range", elements=bad[:100].tolist(), vertices=n)
    used = np.zeros(n, bool)
    used[C.ravel()] = True
    nonfinite = np.flatnonzero(used & ~np.isfinite(V).all(1))
    if nonfinite.size:
        raise InvalidMeshError(
            f"{nonfinite.size} vertices have non-finite coordinates; first vertices "
            f"{format_ids(nonfinite)}", code="non_finite_coordinates", vertices=nonfinite[:100].tolist())
    S = np.sort(C, axis=1)
    rep = np.flatnonzero((S[:, 1:] == S[:, :-1]).any(1))
    if rep.size:
        raise InvalidMeshError(
            f"{rep.size} {what} repeat a vertex index; first elements {format_ids(rep)}, "
            f"e.g. element {rep[0]} = {C[rep[0]].tolist()}",
            code="repeated_index", elements=rep[:100].tolist())


def _check_manifold_edges(F: np.ndarray, n: int) -> None:
    """Each boundary edge must be in exactly two faces, with opposite orientations."""
    He = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    key = np.minimum(He[:, 0], He[:, 1]) * n + np.maximum(He[:, 0], He[:, 1])
    uniq, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
    bad = np.flatnonzero(counts != 2)
    if bad.size:
        e = np.stack([uniq[bad] // n, uniq[bad] % n], 1)
        kinds = "open (in one face)" if (counts[bad] == 1).all() else "non-manifold"
        raise InvalidMeshError(
            f"{bad.size} boundary edges are not shared by exactly two boundary faces "
            f"({kinds}); first edges {e[:5].tolist()}",
            code="non_manifold_boundary", edges=e[:100].tolist())
    directed = He[:, 0] * n + He[:, 1]
    if np.unique(directed).size != directed.size:
        raise InvalidMeshError(
            "the boundary surface is not consistently oriented (an edge is used twice in "
            "the same direction)", code="inconsistent_orientation")


