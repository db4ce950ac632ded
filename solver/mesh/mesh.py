"""The :class:`Mesh` dataclass: vertices, elements, named sets and derived topology.

A volume mesh (tetrahedra, optionally with linear hexahedra, wedges and
pyramids) or a triangle surface. Derived topology (boundary faces, edges,
bodies, shells) is computed on first use and cached, as in scikit-fem;
:func:`solver.deform.precompute` fills every cache it needs before any solve,
so updates only read them. Reading and writing files is :mod:`solver.io`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InvalidMeshError
from ..ops.boundary_facets import boundary_facets, simplex_edges
from ..ops.elements import LINEAR_TYPES, boundary_faces, element_blocks, element_edges
from ..ops.unique import unique
from .validate import component_labels, validate

if TYPE_CHECKING:  # meshio loads when a file is read or written (solver.io), not with the mesh
    import meshio

__all__ = ["Mesh", "mesh_from_arrays", "VOLUME_TYPES", "MIXED_TYPES", "IGNORED_TYPES"]

#: Cell types that carry no volume and are kept untouched (boundary
#: annotations, beams, point masses).
IGNORED_TYPES = {"vertex", "line", "line3", "triangle", "quad", "triangle6", "quad8", "quad9"}
#: Linear volume types deformed next to tetrahedra (:mod:`solver.ops.elements`).
MIXED_TYPES = set(LINEAR_TYPES[1:])
#: Higher-order cell types other than tetra10; refused.
VOLUME_TYPES = {"tetra4", "hexahedron20", "hexahedron27", "wedge15", "pyramid13"}


@dataclass(eq=False)
class Mesh:
    """A volume mesh or a triangle surface, with its source file.

    Tetrahedra, optionally with other linear elements (hexahedra, wedges, pyramids).

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
        The file's bytes, kept for formats with an in-place writer (Abaqus,
        Gmsh, VTU, Nastran, TetGen ``.node``) so that :func:`write_mesh`
        changes only node coordinates (:mod:`solver.io.patchers`).
    companions : dict of str to bytes
        Other files of a format spread over several, by extension, kept byte
        for byte (TetGen: ``{"ele": ...}``).
    file_format : str, optional
        meshio format name of the file the mesh was read from.
    T10 : (m, 10) int64 array, optional
        For quadratic tetrahedra (tetra10 / C3D10): every element's ten nodes in
        VTK order (four corners, then the mid-side nodes of edges 01, 12, 02,
        03, 13, 23). ``T`` is then its first four columns; the mid-side nodes
        are placed after each solve (:mod:`solver.validity.midside`).
    cells : dict of str to (m, c) int array
        Linear hexahedra, wedges and pyramids (meshio/VTK node order), per type
        in file order. Elements are numbered tets first, then these in
        :data:`solver.ops.elements.LINEAR_TYPES` order (report ids, cell data).
    degenerate_at_rest : (k,) int64 array
        Ids (numbered as :attr:`blocks`) of the tetrahedra that are flat at rest
        (zero volume, :func:`solver.validity.quality.degenerate_mask`), found by
        :func:`validate`. They are loaded and morphed, and reported apart from
        the elements a morph inverts; tetrahedra of negative volume are refused
        (``inverted_input``).
    coincident_nodes : (p, 2) int64 array
        Pairs of used vertices at the same position, in bodies that are
        otherwise manifold (parts of an assembly; the SPEC's ties join them).
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
    degenerate_at_rest: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    coincident_nodes: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))
    companions: dict[str, bytes] = field(default_factory=dict, repr=False)
    file_format: str | None = None

    @classmethod
    def validated(cls, V: np.ndarray, T: np.ndarray, surface: np.ndarray | None = None,
                  cells: dict[str, np.ndarray] | None = None, **fields: Any) -> Mesh:
        """A mesh of arrays that pass :func:`validate`, with what validation found.

        Raises
        ------
        InvalidMeshError
        """
        found = validate(V, T, surface, cells)
        kw: dict[str, Any] = {"surface": surface} if surface is not None else {}
        return cls(V=V, T=T, cells=cells or {}, degenerate_at_rest=found.degenerate_at_rest,
                   coincident_nodes=found.coincident_nodes, **kw, **fields)

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
    def rim_edges(self) -> np.ndarray:
        """(e, 2) sorted vertex pairs of the open edges of a triangle surface.

        Edges in one face: the rim of a sheet and of its holes. Empty for volume
        meshes and closed surfaces.
        """
        if not self.is_surface or not self.surface.size:
            return np.zeros((0, 2), np.int64)
        F, n = self.surface, self.n
        He = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        uniq, counts = np.unique(He[:, 0] * n + He[:, 1], return_counts=True)
        once = uniq[counts == 1]
        return np.stack([once // n, once % n], 1).astype(np.int64)

    @cached_property
    def rim(self) -> np.ndarray:
        """(n,) bool: vertices on the open rim of a triangle surface (:attr:`rim_edges`)."""
        r = np.zeros(self.n, bool)
        r[self.rim_edges.ravel()] = True
        return r

    @cached_property
    def body_labels(self) -> np.ndarray:
        """(n,) int: connected component (body) of each vertex, -1 if unreferenced."""
        E = self.surface if self.is_surface else (self.edges if self.cells else self.T)
        return component_labels(E, self.n, self.referenced)

    @cached_property
    def shell_labels(self) -> np.ndarray:
        """(n,) int: connected component of the boundary surface, -1 off the boundary."""
        return component_labels(self.F, self.n, self.boundary)

    def info(self) -> dict[str, Any]:
        """Counts, element types, sets and a quality summary (``tetmorph info``, the upload answer).

        Besides counts: ``degenerate_at_rest`` (``{"count", "ids"}``, the first
        1000 ids of :attr:`degenerate_at_rest`), ``coincident_nodes`` (pairs),
        and for surfaces ``open_edges`` and ``rim_vertices``.
        """
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
            "degenerate_at_rest": {"count": int(self.degenerate_at_rest.size),
                                   "ids": self.degenerate_at_rest[:1000].tolist()},
            "coincident_nodes": int(len(self.coincident_nodes)),
        }
        info = getattr(self.source, "info", None)
        if isinstance(info, dict) and info.get("dropped"):  # what the reader left out of the file, named
            out["dropped_on_read"] = list(info["dropped"])
        if self.is_surface:
            out["open_edges"] = int(len(self.rim_edges))
            out["rim_vertices"] = int(self.rim.sum())
        if not self.is_surface:
            from ..validity.quality import element_quality, first_percentile

            q = element_quality(self.V, self.T, self.cells)
            sj, vol = q["scaled_jacobian"], q["volume"]
            out["quality"] = {
                "min_scaled_jacobian": float(sj.min()),
                "p01_scaled_jacobian": first_percentile(sj),
                "median_scaled_jacobian": float(np.median(sj)),
                "min_volume": float(vol.min()),
                "total_volume": float(vol.sum()),
            }
        lo, hi = (self.V[self.referenced].min(0), self.V[self.referenced].max(0)) if self.n else (0, 0)
        out["bounding_box"] = {"min": np.asarray(lo).tolist(), "max": np.asarray(hi).tolist()}
        return out


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
    ids = {k: unique(np.asarray(v, dtype=np.int64)) for k, v in (sets or {}).items()}
    return Mesh.validated(V, T, surface if not T.shape[0] else np.zeros((0, 3), np.int64), sets=ids)


