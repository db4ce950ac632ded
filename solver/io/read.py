"""Reading meshes with meshio: element blocks, named sets and material regions."""

from __future__ import annotations

import os

import meshio
import numpy as np

from ..errors import InvalidMeshError, UnsupportedElementError
from ..mesh.mesh import IGNORED_TYPES, MIXED_TYPES, Mesh
from ..mesh.validate import validate
from ..ops.elements import LINEAR_TYPES, oriented
from .patchers import patcher_for

__all__ = ["read_mesh", "mesh_from_meshio"]


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
    if patcher_for(path, file_format) is not None:  # kept to be written back in place
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
    try:  # either winding in the file; tetmorph keeps its own copy (:func:`solver.ops.elements.oriented`)
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


