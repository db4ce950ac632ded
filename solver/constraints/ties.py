"""Ties between coincident nodes of different bodies (assemblies)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..mesh import Mesh
from .rows import check_ids

__all__ = ["tie_pairs", "TIE_TOL"]

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
        check_ids(pairs.ravel().tolist(), mesh.n, "SPEC.ties", mesh.referenced)
        return pairs
    ref = np.flatnonzero(mesh.referenced)
    lab = mesh.body_labels
    if not ref.size or lab[ref].min() == lab[ref].max():  # one body: no node of another body to tie to
        return np.zeros((0, 2), np.int64)
    from scipy.spatial import cKDTree  # loaded for meshes of several bodies only

    V = mesh.V[ref]
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    tol = float(ties.get("tolerance", TIE_TOL * diag)) if isinstance(ties, dict) else TIE_TOL * diag
    pairs = cKDTree(V).query_pairs(tol, output_type="ndarray")
    if not len(pairs):
        return np.zeros((0, 2), np.int64)
    pairs = ref[pairs]
    return np.sort(pairs[lab[pairs[:, 0]] != lab[pairs[:, 1]]], axis=1)


