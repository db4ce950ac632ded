"""Boundary faces and edges of a tetrahedral (or triangle) mesh."""

from __future__ import annotations

import numpy as np

from ..errors import MAX_IDS, InvalidMeshError, format_ids
from .unique import unique_rows

__all__ = ["TET_FACES", "boundary_facets", "face_keys", "simplex_edges"]

#: Local vertex indices of the four faces of a positively oriented tet
#: ``(a, b, c, d)``, ordered so that each face's normal points away from the
#: opposite vertex: face ``k`` is opposite local vertex ``k``.
TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], dtype=np.int64)


def simplex_edges(S: np.ndarray, unique: bool = True) -> np.ndarray:
    """Edges of simplices: every pair of an element's vertices.

    Parameters
    ----------
    S : (k, d) int array
        Triangles (d = 3) or tetrahedra (d = 4).
    unique : bool
        Return each edge once, as a sorted pair, rows sorted. Otherwise every
        element's pairs in the order (0, 1), (0, 2), ... (d-2, d-1), element-major
        per pair, as given.

    Returns
    -------
    (e, 2) int array

    Examples
    --------
    >>> simplex_edges(np.array([[0, 1, 2], [2, 1, 3]])).tolist()
    [[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]]
    """
    d = S.shape[1]
    E = np.concatenate([S[:, [a, b]] for a in range(d) for b in range(a + 1, d)])
    if not unique:
        return E
    return unique_rows(np.sort(E, axis=1))


def face_keys(S: np.ndarray, n: int) -> np.ndarray:
    """Return one int64 key per sorted triple, equal for equal vertex sets.

    Parameters
    ----------
    S : (k, 3) int array
        Vertex triples, each sorted ascending.
    n : int
        Number of vertices (an upper bound of the entries).

    Returns
    -------
    keys : (k,) int64 array, or (k,) void array when ``n**3`` overflows int64.
    """
    n = max(int(n), 1)
    if n < 2_000_000:
        S = S.astype(np.int64, copy=False)
        return (S[:, 0] * n + S[:, 1]) * n + S[:, 2]
    S = np.ascontiguousarray(S.astype(np.int64))
    return S.view(np.dtype((np.void, S.dtype.itemsize * 3))).ravel()


def boundary_facets(T: np.ndarray, n: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Faces that belong to exactly one tetrahedron, oriented outward.

    Parameters
    ----------
    T : (m, 4) int array
        Positively oriented tetrahedra.
    n : int, optional
        Number of vertices; defaults to ``T.max() + 1``.

    Returns
    -------
    F : (k, 3) int64 array
        Boundary faces; the right-hand normal points out of the volume.
    FT : (k,) int64 array
        For each boundary face the tet it belongs to.

    Raises
    ------
    InvalidMeshError
        If a face is shared by more than two tetrahedra (non-manifold volume).

    Examples
    --------
    >>> F, FT = boundary_facets(np.array([[0, 1, 2, 3]]))
    >>> F.tolist()
    [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]
    """
    T = np.asarray(T, dtype=np.int64)
    m = T.shape[0]
    if m == 0:
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64)
    n = int(T.max()) + 1 if n is None else n
    allF = T[:, TET_FACES].reshape(-1, 3)
    a, b, c = allF[:, 0], allF[:, 1], allF[:, 2]
    lo = np.minimum(np.minimum(a, b), c)  # sorting each triple with min/max: 4x np.sort(axis=1)
    hi = np.maximum(np.maximum(a, b), c)
    keys = face_keys(np.column_stack([lo, a + b + c - lo - hi, hi]), n)
    order = np.argsort(keys)  # no stability needed: only keys seen once are kept, then sorted
    ks = keys[order]
    starts = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
    counts = np.diff(np.r_[starts, ks.size])
    if np.any(counts > 2):
        bad = order[starts[counts > 2]] // 4
        raise InvalidMeshError(
            f"{int(np.sum(counts > 2))} faces are shared by more than two tetrahedra "
            f"(non-manifold volume); first tets: {format_ids(bad)}",
            code="non_manifold_volume",
            tets=bad[:MAX_IDS].tolist(),
        )
    once = order[starts[counts == 1]]
    once.sort()
    return allF[once], once // 4
