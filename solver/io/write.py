"""Writing meshes: the original file patched in place where its format allows, else meshio."""

from __future__ import annotations

import copy
import os

import meshio
import numpy as np

from ..errors import InvalidMeshError
from ..mesh import Mesh
from .patchers import patcher_for

__all__ = ["write_mesh", "tet_cell_data"]


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
        Add the per-element metrics of :func:`solver.validity.quality.element_quality`
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
        from ..validity.quality import element_quality

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
    """The mesh's own file with coordinates ``V``, when the target has its format (:mod:`.patchers`)."""
    p = patcher_for(target, file_format)
    if p is None or mesh.raw is None or not p.accepts(mesh.raw, mesh.n):
        return None
    return p.patch(mesh.raw, V)


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
