"""Volume meshes (tetrahedra, and hexahedra, wedges and pyramids next to them) or triangle
surfaces: reading, validation, named sets, writing.

A :class:`Mesh` keeps the :class:`meshio.Mesh` it was read from, so that
:func:`write_mesh` changes nothing but point coordinates: other cell blocks,
point and cell data, node and element sets and physical groups survive.
"""

from __future__ import annotations

import copy
import os
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import meshio
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .boundary_facets import boundary_facets
from .elements import (
    LINEAR_TYPES,
    boundary_faces,
    corner_jacobians,
    element_blocks,
    element_edges,
    oriented,
)
from .errors import InvalidMeshError, UnsupportedElementError, format_ids
from .quality import degenerate_mask, signed_volumes

__all__ = ["Mesh", "read_mesh", "write_mesh", "mesh_from_arrays", "VOLUME_TYPES", "MIXED_TYPES",
           "IGNORED_TYPES"]

#: Cell types that carry no volume and are kept untouched (boundary
#: annotations, beams, point masses).
IGNORED_TYPES = {"vertex", "line", "line3", "triangle", "quad", "triangle6", "quad8", "quad9"}
#: Linear volume types deformed next to tetrahedra (:mod:`solver.elements`).
MIXED_TYPES = set(LINEAR_TYPES[1:])
#: Higher-order cell types other than tetra10; refused.
VOLUME_TYPES = {"tetra4", "hexahedron20", "hexahedron27", "wedge15", "pyramid13"}


@dataclass(eq=False)
class Mesh:
    """A volume mesh (tetrahedra, optionally with other linear elements), or a triangle
    surface, with its source file.

    Parameters
    ----------
    V : (n, 3) float64 array
        Vertex positions in file order.
    T : (m, 4) int64 array
        Positively oriented tetrahedra (empty for a surface mesh).
    surface : (k, 3) int64 array, optional
        Triangles of a surface-only mesh (then ``T`` is empty).
    sets : dict of str to (j,) int64 array
        Named vertex selections from the file (node sets, element sets,
        physical groups), 0-based.
    source : meshio.Mesh, optional
        The mesh as read, written back by :func:`write_mesh`.
    raw : bytes, optional
        The file's bytes, kept for Abaqus decks so that :func:`write_mesh`
        changes only node coordinates (:mod:`solver.inp_patch`).
    T10 : (m, 10) int64 array, optional
        For quadratic tetrahedra (tetra10 / C3D10): every element's ten nodes in
        VTK order (four corners, then the mid-side nodes of edges 01, 12, 02,
        03, 13, 23). ``T`` is then its first four columns; the mid-side nodes
        are placed after each solve (:mod:`solver.quadratic`).
    cells : dict of str to (m, c) int array
        Linear hexahedra, wedges and pyramids (meshio/VTK node order), per type
        in file order. Elements are numbered tets first, then these in
        :data:`solver.elements.LINEAR_TYPES` order (report ids, cell data).
    """

    V: np.ndarray
    T: np.ndarray
    surface: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int64))
    sets: dict[str, np.ndarray] = field(default_factory=dict)
    source: meshio.Mesh | None = None
    path: str | None = None
    T10: np.ndarray | None = None
    raw: bytes | None = field(default=None, repr=False)
    cells: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n(self) -> int:
        """Number of vertices."""
        return int(self.V.shape[0])

    @property
    def is_surface(self) -> bool:
        """True for a triangle-only mesh (deformed by the boundary method alone)."""
        return self.T.shape[0] == 0 and not self.cells

    @property
    def blocks(self) -> list[tuple[str, np.ndarray]]:
        """Volume element blocks ``(type, connectivity)`` in element-numbering order."""
        return element_blocks(self.T, self.cells)

    @property
    def elements(self) -> int:
        """Number of volume elements."""
        return int(sum(len(b) for _, b in self.blocks))

    @cached_property
    def F(self) -> np.ndarray:
        """(k, 3) boundary faces, outward oriented (boundary quads as two triangles)."""
        if self.is_surface:
            return self.surface
        if self.cells:
            return boundary_faces(self.blocks, self.n)[0]
        return boundary_facets(self.T, self.n)[0]

    @cached_property
    def edges(self) -> np.ndarray:
        """(k, 2) vertex pairs of every element edge (repeats kept; tet edges first)."""
        from .boundary_facets import simplex_edges

        parts = [simplex_edges(self.T if self.T.shape[0] else self.surface, unique=False)]
        parts += [element_edges(b, k) for k, b in self.blocks if k != "tetra"]
        return np.concatenate(parts)

    @cached_property
    def referenced(self) -> np.ndarray:
        """(n,) bool: vertices used by an element."""
        used = np.zeros(self.n, bool)
        used[(self.surface if self.is_surface else self.T).ravel()] = True
        for _, b in self.cells.items():
            used[b.ravel()] = True
        return used

    @cached_property
    def boundary(self) -> np.ndarray:
        """(n,) bool: vertices on a boundary face."""
        b = np.zeros(self.n, bool)
        b[self.F.ravel()] = True
        return b

    @cached_property
    def interior(self) -> np.ndarray:
        """(n,) bool: referenced vertices that are not on the boundary."""
        return self.referenced & ~self.boundary

    @cached_property
    def body_labels(self) -> np.ndarray:
        """(n,) int: connected component (body) of each vertex, -1 if unreferenced."""
        E = self.surface if self.is_surface else (self.edges if self.cells else self.T)
        return _component_labels(E, self.n, self.referenced)

    @cached_property
    def shell_labels(self) -> np.ndarray:
        """(n,) int: connected component of the boundary surface, -1 off the boundary."""
        return _component_labels(self.F, self.n, self.boundary)

    def info(self) -> dict[str, Any]:
        """Counts, element types, sets and a quality summary (``tetmorph info``)."""
        out: dict[str, Any] = {
            "vertices": self.n,
            "tetrahedra": int(self.T.shape[0]),
            "elements": self.elements,
            "boundary_faces": int(self.F.shape[0]),
            "boundary_vertices": int(self.boundary.sum()),
            "interior_vertices": int(self.interior.sum()),
            "unreferenced_vertices": int((~self.referenced).sum()),
            "bodies": int(self.body_labels.max() + 1) if self.n else 0,
            "boundary_shells": int(self.shell_labels.max() + 1) if self.boundary.any() else 0,
            "cell_types": ({t: int(sum(len(c.data) for c in self.source.cells if c.type == t))
                            for t in dict.fromkeys(c.type for c in self.source.cells)}
                           if self.source is not None else {}),
            "element_order": 2 if self.T10 is not None else 1,
            "sets": {k: int(len(v)) for k, v in sorted(self.sets.items())},
        }
        if not self.is_surface:
            from .quality import element_quality

            q = element_quality(self.V, self.T, self.cells)
            sj, vol = q["scaled_jacobian"], q["volume"]
            out["quality"] = {
                "min_scaled_jacobian": float(sj.min()),
                "p01_scaled_jacobian": float(np.percentile(sj, 1)),
                "median_scaled_jacobian": float(np.median(sj)),
                "min_volume": float(vol.min()),
                "total_volume": float(vol.sum()),
            }
        lo, hi = (self.V[self.referenced].min(0), self.V[self.referenced].max(0)) if self.n else (0, 0)
        out["bounding_box"] = {"min": np.asarray(lo).tolist(), "max": np.asarray(hi).tolist()}
        return out


def _component_labels(E: np.ndarray, n: int, mask: np.ndarray) -> np.ndarray:
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


def mesh_from_arrays(V: Any, T: Any = None, surface: Any = None,
                     sets: dict[str, Any] | None = None) -> Mesh:
    """Build and validate a :class:`Mesh` from arrays.

    Parameters
    ----------
    V : (n, 3) array_like
    T : (m, 4) array_like of int, optional
    surface : (k, 3) array_like of int, optional
        Triangles of a surface-only mesh.
    sets : dict, optional
        Named vertex selections.

    Returns
    -------
    Mesh

    Raises
    ------
    InvalidMeshError

    Examples
    --------
    >>> m = mesh_from_arrays([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]])
    >>> m.n, int(m.interior.sum())
    (4, 0)
    """
    try:
        V = np.asarray(V, dtype=np.float64)
        T = np.zeros((0, 4), np.int64) if T is None else np.asarray(T)
        surface = np.zeros((0, 3), np.int64) if surface is None else np.asarray(surface)
    except (TypeError, ValueError) as e:
        raise InvalidMeshError(f"mesh arrays are not numeric: {e}", code="bad_shape") from e
    for name, arr in (("T", T), ("surface", surface)):
        if arr.size and not np.issubdtype(arr.dtype, np.integer):
            if arr.dtype.kind != "f" or not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
                raise InvalidMeshError(f"{name} must hold integer vertex indices", code="bad_shape")
    T = T.astype(np.int64).reshape(-1, 4) if T.size else np.zeros((0, 4), np.int64)
    surface = surface.astype(np.int64).reshape(-1, 3) if surface.size else np.zeros((0, 3), np.int64)
    validate(V, T, surface)
    ids = {k: np.unique(np.asarray(v, dtype=np.int64)) for k, v in (sets or {}).items()}
    return Mesh(V=V, T=T, surface=surface if not T.shape[0] else np.zeros((0, 3), np.int64), sets=ids)


def _named_sets(m: meshio.Mesh) -> dict[str, np.ndarray]:
    """Node sets, element sets (their nodes) and physical groups of a meshio mesh."""
    sets: dict[str, np.ndarray] = {}
    for name, ids in (m.point_sets or {}).items():
        sets[name] = np.unique(np.asarray(ids, dtype=np.int64))
    for name, per_block in (m.cell_sets or {}).items():
        if name.startswith("gmsh:"):  # meshio's entity bookkeeping (bounding entities), not a set
            continue
        nodes = [np.asarray(m.cells[b].data)[np.asarray(ix, dtype=np.int64)].ravel()
                 for b, ix in enumerate(per_block)
                 if ix is not None and np.ndim(ix) == 1 and len(ix) and b < len(m.cells)]
        if nodes and name not in sets:
            sets[name] = np.unique(np.concatenate(nodes))
    # gmsh physical groups: cell data "gmsh:physical" with names in field_data
    phys = m.cell_data.get("gmsh:physical")
    if phys is not None:
        names = {int(v[0]): k for k, v in (m.field_data or {}).items() if len(v) >= 1}
        groups: dict[str, list[np.ndarray]] = {}
        for block, tags in zip(m.cells, phys):
            for tag in np.unique(tags):
                label = names.get(int(tag), f"physical:{int(tag)}")
                groups.setdefault(label, []).append(np.asarray(block.data)[tags == tag].ravel())
        for label, parts in groups.items():
            sets.setdefault(label, np.unique(np.concatenate(parts)))
    # material regions of volume elements as integer cell data (Medit references,
    # VTK/Exodus-style block ids): a node set per value, e.g. "medit:ref=2"
    for key in ("medit:ref", "CellEntityIds", "MaterialIds"):
        data = m.cell_data.get(key)
        if data is None:
            continue
        regions: dict[int, list[np.ndarray]] = {}
        for block, vals in zip(m.cells, data, strict=False):
            vals = np.asarray(vals).ravel()
            if block.type not in VOLUME_CELLS or vals.shape[0] != len(block.data) \
                    or not np.issubdtype(vals.dtype, np.integer):
                continue
            for v in np.unique(vals):
                regions.setdefault(int(v), []).append(np.asarray(block.data)[vals == v].ravel())
        if len(regions) > 1:  # one value everywhere is no region
            for v, parts in regions.items():
                sets.setdefault(f"{key}={v}", np.unique(np.concatenate(parts)))
    return sets


#: Cell types whose integer cell data can name material regions.
VOLUME_CELLS = {"tetra", "tetra10", "hexahedron", "wedge", "pyramid"}


def read_mesh(path: str | os.PathLike[str], file_format: str | None = None) -> Mesh:
    """Read and validate a linear tet mesh (or a triangle surface) with meshio.

    Parameters
    ----------
    path : str or path
        Any format meshio reads: ``.msh``, ``.vtu``, ``.vtk``, ``.mesh``,
        ``.inp``, ``.node``/``.ele`` (TetGen), ``.bdf``/``.nas`` (Nastran), ...
    file_format : str, optional
        meshio format name when the extension does not tell.

    Returns
    -------
    Mesh

    Raises
    ------
    InvalidMeshError
        The file cannot be read, has no tets or triangles, or fails :func:`validate`.
    UnsupportedElementError
        The file holds quadratic or non-tet volume elements.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InvalidMeshError(f"no such file: {path}", code="file_not_found")
    try:
        m = meshio.read(path, file_format=file_format)
    except FileNotFoundError as e:
        raise InvalidMeshError(f"no such file: {path}", code="file_not_found") from e
    except (Exception, SystemExit) as e:  # meshio raises many types, and sys.exit()s on
        # files that no reader of the extension accepts: never let that end the process
        raise InvalidMeshError(f"cannot read {os.path.basename(path)!r} "
                               f"(format {file_format or 'from extension'}): {e}",
                               code="unreadable_file") from e
    mesh = mesh_from_meshio(m)
    mesh.path = path
    if (file_format or "").lower() in ("abaqus", "inp", "gmsh", "vtu") or path.lower().endswith((".inp", ".msh", ".vtu")):
        with open(path, "rb") as fh:
            mesh.raw = fh.read()
    return mesh


def mesh_from_meshio(m: meshio.Mesh) -> Mesh:
    """Convert a :class:`meshio.Mesh` to a validated :class:`Mesh`, keeping it as source.

    Parameters
    ----------
    m : meshio.Mesh

    Returns
    -------
    Mesh

    Raises
    ------
    InvalidMeshError, UnsupportedElementError
    """
    types = [c.type for c in m.cells]
    if "tetra10" in types and "tetra" not in types:
        return _quadratic_from_meshio(m)
    unsupported = sorted({t for t in types if t != "tetra" and t not in MIXED_TYPES
                          and t not in IGNORED_TYPES})
    if unsupported:
        counts = {t: int(sum(len(c.data) for c in m.cells if c.type == t)) for t in unsupported}
        raise UnsupportedElementError(
            f"element types {counts} are not supported: tetmorph deforms linear tetrahedra, "
            "hexahedra, wedges and pyramids, quadratic tetrahedra (tetra10) alone, and triangle "
            "surfaces; other elements are refused rather than silently mangled",
            types=counts)
    tets = [np.asarray(c.data, dtype=np.int64) for c in m.cells if c.type == "tetra"]
    T = np.concatenate(tets) if tets else np.zeros((0, 4), np.int64)
    V = _points(m)
    cells = {k: np.concatenate([np.asarray(c.data, np.int64) for c in m.cells if c.type == k])
             for k in LINEAR_TYPES[1:] if k in types}
    try:  # either winding in the file; tetmorph keeps its own copy (:func:`solver.elements.oriented`)
        cells = {k: oriented(V, E, k) for k, E in cells.items()}
    except IndexError:
        pass  # out-of-range indices: validate() names them
    tris = [np.asarray(c.data, dtype=np.int64) for c in m.cells if c.type == "triangle"]
    surface = np.concatenate(tris) if (tris and not len(T) and not cells) else np.zeros((0, 3), np.int64)
    validate(V, T, surface, cells)
    return Mesh(V=V, T=T, surface=surface, sets=_named_sets(m), source=m, cells=cells)


def _points(m: meshio.Mesh) -> np.ndarray:
    """The points as float64 (n, 3); planar files get z = 0."""
    V = np.asarray(m.points, dtype=np.float64)
    if V.ndim == 2 and V.shape[1] == 2:
        V = np.c_[V, np.zeros(len(V))]
    return V


def _quadratic_from_meshio(m: meshio.Mesh) -> Mesh:
    """A tetra10 mesh: corners as the linear mesh, the ten-node connectivity kept as ``T10``."""
    types = [c.type for c in m.cells]
    unsupported = sorted({t for t in types if t != "tetra10" and t not in IGNORED_TYPES})
    if unsupported:
        counts = {t: int(sum(len(c.data) for c in m.cells if c.type == t)) for t in unsupported}
        raise UnsupportedElementError(
            f"element types {counts} next to quadratic tetrahedra are not supported yet", types=counts)
    T10 = np.concatenate([np.asarray(c.data, np.int64) for c in m.cells if c.type == "tetra10"])
    V = _points(m)
    T = np.ascontiguousarray(T10[:, :4])
    validate(V, T, None)
    mid = np.setdiff1d(np.unique(T10[:, 4:]), np.unique(T))
    if mid.size != np.unique(T10[:, 4:]).size:
        raise InvalidMeshError("some tetra10 mid-side nodes are also corner nodes", code="bad_connectivity")
    return Mesh(V=V, T=T, sets=_named_sets(m), source=m, T10=T10)


def write_mesh(mesh: Mesh, V: np.ndarray, path: str | os.PathLike[str],
               file_format: str | None = None, point_data: dict[str, np.ndarray] | None = None,
               cell_data: dict[str, list[np.ndarray]] | None = None,
               point_sets: dict[str, np.ndarray] | None = None, quality: bool = False) -> None:
    """Write ``mesh`` with new coordinates ``V``, changing nothing else.

    An Abaqus deck read from a file and written as ``.inp``, an ASCII Gmsh
    file written as ``.msh`` and a VTU file written as ``.vtu`` keep every byte
    except their node coordinates (materials, steps, comments, physical names,
    data arrays and formatting included); other targets go through meshio.

    Parameters
    ----------
    mesh : Mesh
    V : (n, 3) float array
        New positions, in file order.
    path : str or path
    file_format : str, optional
        meshio format name; defaults to the extension.
    point_data, cell_data : dict, optional
        Extra arrays to add (for example per-element quality).
    quality : bool
        Add the per-element metrics of :func:`solver.quality.element_quality`
        at ``V`` as cell data (``quality:scaled_jacobian`` ...; NaN on
        non-tet cells), where the format stores cell data (VTU, VTK, Gmsh).
    point_sets : dict of str to int array, optional
        Extra node sets (vertex ids) to add, e.g. detected features; written
        where the format has node sets (Abaqus NSET, Gmsh physical groups are
        not created).

    Raises
    ------
    InvalidMeshError
        If ``V`` has the wrong shape or meshio cannot write the format.
    """
    V = np.asarray(V)
    if V.shape != mesh.V.shape:
        raise InvalidMeshError(f"positions have shape {V.shape}, mesh has {mesh.V.shape}",
                               code="bad_shape")
    target = os.fspath(path)
    if mesh.raw is not None and not (point_data or cell_data or point_sets or quality):
        patched = _patched_original(mesh, V, target, file_format)
        if patched is not None:  # the original file, byte for byte, with new coordinates
            with open(target, "wb") as fh:
                fh.write(patched)
            return
    if mesh.source is not None:
        out = copy.copy(mesh.source)
        src_pts = np.asarray(mesh.source.points)
        pts = V[:, : src_pts.shape[1]].astype(src_pts.dtype)
        out.points = pts
        out.point_data = dict(mesh.source.point_data)
        out.cell_data = dict(mesh.source.cell_data)
        if not target.lower().endswith(".msh") and file_format not in ("gmsh", "gmsh22"):
            # meshio keeps Gmsh 4.1 entity relations as a cell set, which other writers
            # cannot convert (VTU: "index out of bounds"); the physical groups stay
            out.cell_sets = {k: v for k, v in mesh.source.cell_sets.items() if not k.startswith("gmsh:")}
    else:
        cells = [("tetra", mesh.T)] if not mesh.is_surface else [("triangle", mesh.surface)]
        out = meshio.Mesh(V, cells, point_sets={k: v for k, v in mesh.sets.items()})
    if quality and not mesh.is_surface:
        from .quality import element_quality

        q = element_quality(V, mesh.T, mesh.cells)
        cell_data = {**(cell_data or {}),
                     **{f"quality:{k}": tet_cell_data(mesh, v, out) for k, v in q.items()}}
    if point_sets:
        out.point_sets = {**out.point_sets, **{k: np.asarray(v, np.int64) for k, v in point_sets.items()}}
    if point_data:
        out.point_data.update(point_data)
    if cell_data:
        out.cell_data.update(cell_data)
    try:
        if _needs_gmsh22(out, os.fspath(path), file_format):
            # meshio's Gmsh 4.1 writer needs gmsh:dim_tags to write several cell
            # types (a converted .inp deck has tets and faces): write Gmsh 2.2 ASCII
            meshio.gmsh.write(os.fspath(path), out, fmt_version="2.2", binary=False)
        else:
            meshio.write(os.fspath(path), out, file_format=file_format)
    except Exception as e:
        raise InvalidMeshError(f"cannot write {os.fspath(path)!r} as "
                               f"{file_format or 'its extension'}: {e}", code="unwritable_format") from e


def _patched_original(mesh: Mesh, V: np.ndarray, target: str, file_format: str | None) -> bytes | None:
    """The mesh's own file with coordinates ``V``, when the target has its format (.inp, .msh, .vtu)."""
    from .inp_patch import node_line_count, patch_inp, patch_msh, patch_vtu

    fmt = (file_format or "").lower()
    ext = target.lower().rsplit(".", 1)[-1] if file_format is None else ""
    raw = mesh.raw
    if fmt in ("abaqus", "inp") or ext == "inp":
        return patch_inp(raw, V) if node_line_count(raw) == mesh.n else None
    if (fmt == "gmsh" or ext == "msh") and raw.lstrip().startswith(b"$MeshFormat"):
        return patch_msh(raw, V)
    if (fmt == "vtu" or ext == "vtu") and b"<VTKFile" in raw[:400]:
        return patch_vtu(raw, V)
    return None


def tet_cell_data(mesh: Mesh, values: np.ndarray, out: meshio.Mesh | None = None) -> list[np.ndarray]:
    """Per-element ``values`` spread over the cell blocks of the written mesh (NaN elsewhere).

    Elements are numbered as :attr:`Mesh.blocks`: the file's tetra blocks in
    order, then its hexahedron, wedge and pyramid blocks, each type in order.
    """
    blocks = out.cells if out is not None else (mesh.source.cells if mesh.source is not None else None)
    if blocks is None:
        return [np.asarray(values, float)]
    start, k = {}, 0
    for kind, b in mesh.blocks:
        start[kind] = k
        k += len(b)
    parts = []
    for c in blocks:
        nc = len(c.data)
        kind = "tetra" if c.type == "tetra10" and mesh.T10 is not None else c.type
        if kind in start:
            parts.append(np.asarray(values[start[kind]:start[kind] + nc], float))
            start[kind] += nc
        else:
            parts.append(np.full(nc, np.nan))
    return parts


def _needs_gmsh22(m: meshio.Mesh, path: str, file_format: str | None) -> bool:
    gmsh41 = file_format in ("gmsh", "gmsh4", "gmsh41") or (
        file_format is None and path.lower().endswith(".msh"))
    return gmsh41 and "gmsh:dim_tags" not in m.point_data and len({c.type for c in m.cells}) > 1
