"""Resolve SPEC selections to vertex ids."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import MAX_IDS, SpecError, format_ids
from ..mesh import Mesh
from ..ops.boundary_facets import simplex_edges
from ..ops.elements import midside_edges
from ..ops.unique import unique

__all__ = ["select", "node_masks", "midside_mask"]


def midside_mask(mesh: Mesh) -> np.ndarray:
    """(n,) bool: the mid-side nodes of a quadratic (tetra10) mesh; all False otherwise."""
    mid = np.zeros(mesh.n, bool)
    if mesh.T10 is not None:
        mid[mesh.T10[:, 4:].ravel()] = True
        mid[mesh.T.ravel()] = False
    return mid


def node_masks(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Nodes a selection may name, and those on the boundary: (used (n,) bool, boundary (n,) bool).

    Every node of an element counts, mid-side nodes of quadratic elements
    included; a mid-side node is on the boundary when its edge is an edge of a
    boundary face.
    """
    used = mesh.referenced.copy()
    boundary = mesh.boundary.copy()
    if mesh.T10 is not None:
        ids, a, b = midside_edges(mesh.T10)
        used[ids] = True
        n = mesh.n
        FE = simplex_edges(mesh.F)
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        boundary[ids] = np.isin(lo * n + hi, FE[:, 0] * n + FE[:, 1])
    return used, boundary


def select(mesh: Mesh, sel: dict[str, Any], name: str = "selection") -> np.ndarray:
    """Vertex ids chosen by one SELECTION of a SPEC.

    Parameters
    ----------
    mesh : Mesh
    sel : dict
        ``{"ids": [...]}``, ``{"set": NAME}``, ``{"box": {"min", "max"}}``,
        ``{"sphere": {"center", "radius"}}`` or
        ``{"plane": {"point", "normal", "tolerance"}}`` (already checked by
        :func:`solver.constraints.spec.parse_spec`). Geometric selections are closed sets
        and only pick vertices used by an element. ``"boundary_only": true``
        keeps the boundary vertices of any selection.
    name : str
        Selection name, for error messages.

    Returns
    -------
    ids : (k,) int64 array
        Sorted, unique, non-empty. Every node of an element may be selected,
        mid-side nodes of quadratic elements included (:func:`node_masks`).

    Raises
    ------
    SpecError
        Ids out of range or unused, an unknown set name, or an empty selection.

    Examples
    --------
    >>> from solver.mesh import mesh_from_arrays
    >>> from solver.testing import cube_mesh
    >>> m = mesh_from_arrays(*cube_mesh(2))
    >>> select(m, {"box": {"min": [0, 0, 0], "max": [0, 1, 1]}}).size
    9
    """
    kind = next(k for k in sel if k != "boundary_only")
    val = sel[kind]
    V = mesh.V
    used, on_boundary = node_masks(mesh)
    if kind == "ids":
        ids = unique(np.asarray(val, dtype=np.int64))
        if ids.size == 0:
            raise SpecError(f"selection {name!r} (ids) selects no vertex", code="empty_selection",
                            selection=name)
        bad = ids[(ids < 0) | (ids >= mesh.n)]
        if bad.size:
            raise SpecError(f"selection {name!r}: ids {format_ids(bad)} are outside 0..{mesh.n - 1}",
                            code="bad_selection", selection=name, ids=bad[:MAX_IDS].tolist())
        unused = ids[~used[ids]]
        if unused.size:
            raise SpecError(f"selection {name!r}: vertices {format_ids(unused)} belong to no element",
                            code="bad_selection", selection=name, ids=unused[:MAX_IDS].tolist())
    elif kind == "set":
        if val not in mesh.sets:
            raise SpecError(f"selection {name!r}: the mesh has no set {val!r}; sets: "
                            f"{sorted(mesh.sets)}", code="unknown_set", selection=name, set=val)
        ids = mesh.sets[val]
        ids = ids[(ids >= 0) & (ids < mesh.n)]
        ids = ids[used[ids]]
    else:
        if kind == "box":
            lo, hi = np.asarray(val["min"], float), np.asarray(val["max"], float)
            hit = np.all((V >= lo) & (V <= hi), axis=1)
        elif kind == "sphere":
            c = np.asarray(val["center"], float)
            hit = np.linalg.norm(V - c, axis=1) <= float(val["radius"])
        else:  # plane
            p, nrm = np.asarray(val["point"], float), np.asarray(val["normal"], float)
            nrm = nrm / np.linalg.norm(nrm)
            hit = np.abs((V - p) @ nrm) <= float(val.get("tolerance", 0.0))
        ids = np.flatnonzero(hit & used)
    if sel.get("boundary_only", False):
        ids = ids[on_boundary[ids]]
    if ids.size == 0:
        raise SpecError(f"selection {name!r} ({kind}) selects no vertex", code="empty_selection",
                        selection=name)
    return ids
