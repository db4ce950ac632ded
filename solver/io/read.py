"""Reading meshes with meshio: element blocks, named sets and material regions."""

from __future__ import annotations

import contextlib
import os
import warnings
from typing import Any

import meshio
import numpy as np

from ..errors import InvalidMeshError, UnreadableFileError, UnsupportedElementError
from ..mesh.mesh import IGNORED_TYPES, MIXED_TYPES, Mesh
from ..ops.elements import LINEAR_TYPES, oriented
from ..ops.unique import unique
from .bounds import ReadBounds, check_declared_sizes, check_read_sizes, memory_error
from .diagnose import check_complete, check_file, diagnose
from .element_words import SHELL_TYPES, cell_counts, element_words, no_volume_words
from .formats import SURFACE_FORMATS, format_of
from .patchers import patcher_for
from .registry import FORMATS

__all__ = ["read_mesh", "read_surface", "mesh_from_meshio", "REGION_KEYS", "SET_PREFIX"]


#: Integer cell data that label material regions of volume elements (Medit references,
#: VTK/Exodus block ids, sfepy material ids, Nastran property ids, TetGen region attributes).
REGION_KEYS = ("medit:ref", "CellEntityIds", "MaterialIds", "mat_id", "nastran:ref", "tetgen:ref")
#: Prefix of the 0/1 point and cell data arrays that hold named sets in formats without
#: sets (VTU, VTK): ``set:FIXED`` (see :mod:`solver.io.conversion`).
SET_PREFIX = "set:"
#: Topological dimension of meshio cell types (Gmsh physical groups are named per dimension).
CELL_DIM = {"vertex": 0, "line": 1, "line3": 1, "triangle": 2, "triangle6": 2, "quad": 2, "quad8": 2,
            "quad9": 2}


def integral(a: np.ndarray) -> bool:
    """Whether an array holds integers (as integers, or as whole floats: Gmsh element data).

    Examples
    --------
    >>> integral(np.array([1, 2])), integral(np.array([1.0, 2.0])), integral(np.array([0.5]))
    (True, True, False)
    """
    a = np.asarray(a)
    if np.issubdtype(a.dtype, np.integer):
        return True
    return bool(np.issubdtype(a.dtype, np.floating) and np.isfinite(a).all() and (a == np.round(a)).all())


def _named_sets(m: meshio.Mesh) -> dict[str, np.ndarray]:
    """Node sets, element sets (their nodes), physical groups and material regions of a meshio mesh."""
    sets: dict[str, np.ndarray] = {}
    for name, ids in (m.point_sets or {}).items():
        sets[name] = unique(np.asarray(ids, dtype=np.int64))
    for name, per_block in (m.cell_sets or {}).items():
        if name.startswith("gmsh:"):  # meshio's entity bookkeeping (bounding entities), not a set
            continue
        nodes = [np.asarray(m.cells[b].data)[np.asarray(ix, dtype=np.int64)].ravel()
                 for b, ix in enumerate(per_block)
                 if ix is not None and np.ndim(ix) == 1 and len(ix) and b < len(m.cells)]
        if nodes and name not in sets:
            sets[name] = unique(np.concatenate(nodes))
    for key, vals in m.point_data.items():  # sets kept as 0/1 arrays (VTU, VTK)
        v = np.asarray(vals)
        if key.startswith(SET_PREFIX) and v.ndim == 1 and v.size == len(m.points) and np.isin(v, (0, 1)).all():
            sets.setdefault(key[len(SET_PREFIX):], np.flatnonzero(v).astype(np.int64))
    for key, per_block in m.cell_data.items():
        if not key.startswith(SET_PREFIX):
            continue
        parts = [np.asarray(c.data)[np.asarray(v).ravel() == 1].ravel()
                 for c, v in zip(m.cells, per_block, strict=False) if np.asarray(v).ravel().size == len(c.data)]
        if parts and np.concatenate(parts).size:
            sets.setdefault(key[len(SET_PREFIX):], unique(np.concatenate(parts)).astype(np.int64))
    # gmsh physical groups: cell data "gmsh:physical", names in field_data as [tag, dim]
    phys = m.cell_data.get("gmsh:physical")
    if phys is not None:
        named = {(int(v[0]), int(v[1]) if len(v) > 1 else -1): k for k, v in (m.field_data or {}).items()
                 if np.ndim(v) == 1 and len(v) >= 1}
        by_tag = {t: k for (t, _), k in named.items()}
        groups: dict[str, list[np.ndarray]] = {}
        for block, tags in zip(m.cells, phys, strict=False):
            dim = CELL_DIM.get(block.type, 3)
            tags = np.asarray(tags).ravel()
            for tag in unique(tags):
                if tag == 0 and (0, dim) not in named:
                    continue  # Gmsh's tag 0: in no physical group
                label = named.get((int(tag), dim), by_tag.get(int(tag), f"physical:{int(tag)}"))
                groups.setdefault(label, []).append(np.asarray(block.data)[tags == tag].ravel())
        for label, parts in groups.items():
            sets.setdefault(label, unique(np.concatenate(parts)))
    # material regions: a node set per value, e.g. "medit:ref=2"
    for key in REGION_KEYS:
        data = m.cell_data.get(key)
        if data is None:
            continue
        regions: dict[int, list[np.ndarray]] = {}
        for block, vals in zip(m.cells, data, strict=False):
            vals = np.asarray(vals).ravel()
            if block.type not in VOLUME_CELLS or vals.shape[0] != len(block.data) or not integral(vals):
                continue
            vals = vals.astype(np.int64)
            for value in unique(vals):
                regions.setdefault(int(value), []).append(np.asarray(block.data)[vals == value].ravel())
        if len(regions) > 1:  # one value everywhere is no region
            for label, parts in regions.items():
                sets.setdefault(f"{key}={label}", unique(np.concatenate(parts)))
    return sets


#: Cell types whose integer cell data can name material regions.
VOLUME_CELLS = {"tetra", "tetra10", "hexahedron", "wedge", "pyramid"}


def read_mesh(path: str | os.PathLike[str], file_format: str | None = None, volume: bool = False, *,
              bounds: ReadBounds | None = None) -> Mesh:
    """Read and validate a tet mesh (linear, quadratic or mixed) or a triangle surface.

    Parameters
    ----------
    path : str or path
        Any format meshio reads: ``.msh`` (Gmsh), ``.vtu``, ``.vtk``, ``.mesh``,
        ``.inp``, ``.node``/``.ele`` (TetGen), ``.bdf``/``.nas`` (Nastran),
        ``.stl``/``.obj``/``.off``/``.ply`` (surfaces), ...
    file_format : str, optional
        meshio format name (or extension) when the extension does not tell.
    volume : bool
        Refuse a triangle surface (``surface_not_volume``, pointing to
        ``tetmorph tetrahedralize``) where a volume mesh is expected.
    bounds : ReadBounds, optional
        Most nodes, elements and expanded bytes the file may declare, checked
        before anything is read or decompressed (``too_many_points``,
        ``too_many_cells``, ``too_many_bytes``; :mod:`solver.io.bounds`).
        Default: the library's (:mod:`solver.limits`).

    Returns
    -------
    Mesh
        With ``raw`` (and ``companions``) kept when the format has an in-place
        writer (:mod:`solver.io.patchers`).

    Raises
    ------
    UnreadableFileError
        The file is missing, empty, truncated, of another format than its
        name says, names undefined nodes, defines no nodes, declares more
        than ``bounds``, does not fit in memory (``too_large_to_read``), or
        (with ``volume``) holds a surface; every message names the defect.
    InvalidMeshError
        The mesh fails :func:`validate`.
    UnsupportedElementError
        The file holds element types tetmorph does not deform.
    """
    path = os.fspath(path)
    name = os.path.basename(path)
    fmt = reading_name(format_of(path, file_format))
    own = FORMATS.get(fmt or "")
    if own is not None and own.main_path is not None:  # the file the mesh is read from (TetGen: the .node)
        path = own.main_path(path)
    if not os.path.isfile(path):
        raise UnreadableFileError(f"no such file: {path}", code="file_not_found", file=name)
    check_file(path, fmt)
    assert fmt is not None  # check_file refuses unknown extensions
    check_complete(path, fmt)
    bounds = bounds or ReadBounds()
    m = _read(path, fmt, bounds)
    if np.asarray(m.points).size == 0:
        raise UnreadableFileError(f"{name!r} defines no nodes ({_where_nodes(fmt)}): there is no mesh in it",
                                  code="no_nodes", file=name)
    if volume and fmt in SURFACE_FORMATS | {"obj"}:
        raise _surface_error(name, m)
    try:
        mesh = mesh_from_meshio(m)
    except MemoryError as e:
        raise memory_error(path, fmt, e, bounds) from None
    if volume and mesh.is_surface:
        raise _surface_error(name, m)
    mesh.path = path
    mesh.file_format = fmt
    p = patcher_for(path, fmt)
    if p is not None:  # kept to be written back in place
        main, companions = p.files(path)
        with open(main, "rb") as fh:
            mesh.raw = fh.read()
        for ext, cp in companions.items():
            with open(cp, "rb") as fh:
                mesh.companions[ext] = fh.read()
        if p.includes is not None:  # the files a deck includes, written back beside the deck
            folder = os.path.dirname(os.path.abspath(path))
            for rel in p.includes(path):
                with open(os.path.join(folder, rel), "rb") as fh:
                    mesh.companions[rel] = fh.read()
    return mesh


def read_surface(path: str | os.PathLike[str], file_format: str | None = None, *,
                 bounds: ReadBounds | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The triangles of a surface file, for :func:`solver.io.tetrahedralize.tetrahedralize`.

    Parameters
    ----------
    path : str or path
        STL, OBJ, OFF, PLY, or any mesh file with triangle (or quad) cells.
    file_format : str, optional
    bounds : ReadBounds, optional
        As :func:`read_mesh`.

    Returns
    -------
    V : (n, 3) float64 array
    F : (k, 3) int64 array
        Triangles; quads are split in two.

    Raises
    ------
    UnreadableFileError
        As :func:`read_mesh` for the file itself; ``no_triangles`` for a file
        without surface cells, ``not_a_surface`` for a volume mesh.
    """
    path = os.fspath(path)
    name = os.path.basename(path)
    fmt = reading_name(format_of(path, file_format))
    if not os.path.isfile(path):
        raise UnreadableFileError(f"no such file: {path}", code="file_not_found", file=name)
    check_file(path, fmt)
    assert fmt is not None
    check_complete(path, fmt)
    bounds = bounds or ReadBounds()
    m = _read(path, fmt, bounds)
    counts = {c.type: len(c.data) for c in m.cells if len(c.data)}
    if any(t in VOLUME_CELLS or t in MIXED_TYPES for t in counts):
        raise UnreadableFileError(f"{name!r} is a volume mesh already ({element_words(counts)}): morph it directly",
                                  code="not_a_surface", file=name, cells=counts)
    parts = [np.asarray(c.data, np.int64) for c in m.cells if c.type == "triangle"]
    parts += [np.asarray(c.data, np.int64)[:, k] for c in m.cells if c.type == "quad"
              for k in ([0, 1, 2], [0, 2, 3])]
    if not parts or not sum(len(x) for x in parts):
        raise UnreadableFileError(f"{name!r} has no triangles or quadrilaterals to read as a surface, only "
                                  f"{element_words(counts)}", code="no_triangles", file=name, cells=counts)
    return _points(m), np.concatenate(parts)


def reading_name(fmt: str | None) -> str | None:
    """The format that reads a file named as ``fmt``: meshio's Gmsh 2.2 writer name reads as ``gmsh``.

    Examples
    --------
    >>> reading_name("gmsh22"), reading_name("abaqus")
    ('gmsh', 'abaqus')
    """
    return "gmsh" if fmt == "gmsh22" else fmt


def _read(path: str, fmt: str, bounds: ReadBounds) -> meshio.Mesh:
    """The file through its reader, held to ``bounds`` before and after it is read.

    What the file declares is checked before its reader runs, what it held once read (formats that
    declare no counts); the reader's failures become typed errors (:func:`diagnose`).
    """
    check_declared_sizes(path, fmt, bounds)
    m = _read_file(path, fmt, bounds)
    check_read_sizes(os.path.basename(path), len(m.points), sum(len(c.data) for c in m.cells), bounds)
    return m


def _read_file(path: str, fmt: str, bounds: ReadBounds) -> meshio.Mesh:
    own = FORMATS.get(fmt)
    if own is not None and own.read is not None:
        return _read_own(path, fmt, own.read, bounds)
    reader = meshio._helpers.reader_map.get(fmt)
    if reader is None:
        raise UnreadableFileError(f"tetmorph cannot read {fmt!r} files ({os.path.basename(path)!r})",
                                  code="unknown_format", file=os.path.basename(path), format=fmt)
    from .guarded import stop_at_end  # a reader looping at the end of a cut file stops: truncated_file

    reading = own.reading(path, bounds) if own is not None and own.reading is not None else contextlib.nullcontext()
    try:
        with warnings.catch_warnings(), reading, stop_at_end(fmt):
            warnings.simplefilter("ignore")
            m = reader(path)
    except UnreadableFileError:
        raise
    except MemoryError as e:  # what no declared size told: never the reader's "Unable to allocate 291 TiB"
        raise memory_error(path, fmt, e, bounds) from None
    except (Exception, SystemExit) as e:  # meshio raises many types, and sys.exit()s: never end the process
        if fmt == "obj" and "point_data" in str(e):  # vt / vn per face corner: read without them
            from .obj import read_obj

            try:
                return read_obj(path)
            except (OSError, ValueError):
                pass
        raise diagnose(path, fmt, e) from e
    return m


def _read_own(path: str, fmt: str, reader: Any, bounds: ReadBounds) -> meshio.Mesh:
    """A file through a reader of tetmorph's own (:mod:`solver.io.registry`): typed errors pass, others named."""
    try:
        return reader(path, bounds)  # type: ignore[no-any-return]
    except (UnreadableFileError, UnsupportedElementError, InvalidMeshError):
        raise
    except MemoryError as e:
        raise memory_error(path, fmt, e, bounds) from None
    except (Exception, SystemExit) as e:
        raise diagnose(path, fmt, e) from e


def _where_nodes(fmt: str) -> str:
    own = FORMATS.get(fmt)
    return own.nodes_where if own is not None and own.nodes_where else "no points"


def _surface_error(name: str, m: meshio.Mesh) -> UnreadableFileError:
    counts = {c.type: len(c.data) for c in m.cells}
    stem = name.rsplit(".", 1)[0]
    return UnreadableFileError(
        f"{name!r} holds a triangle surface ({counts}), not a volume mesh: fill it with tetrahedra first, "
        f"e.g. `tetmorph tetrahedralize {name} --output {stem}.vtu` (or POST /v1/tetrahedralize)",
        code="surface_not_volume", file=name, cells=counts)


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
            f"{element_words(counts)} {'is' if sum(counts.values()) == 1 else 'are'} not supported: "
            "tetmorph deforms linear tetrahedra, "
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
    if not len(T) and not cells and not len(surface):
        counts = {c.type: len(c.data) for c in m.cells}
        present = cell_counts(m.cells)
        shells = bool(present) and set(present) <= SHELL_TYPES
        raise InvalidMeshError(no_volume_words("the mesh", shells, element_words(present)), code="no_elements",
                               cells=counts)
    return Mesh.validated(V, T, surface, cells, sets=_named_sets(m), source=m)


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
            f"{element_words(counts)} next to quadratic tetrahedra {'is' if sum(counts.values()) == 1 else 'are'} "
            "not supported yet", types=counts)
    T10 = np.concatenate([np.asarray(c.data, np.int64) for c in m.cells if c.type == "tetra10"])
    V = _points(m)
    T = np.ascontiguousarray(T10[:, :4])
    mesh = Mesh.validated(V, T, None, sets=_named_sets(m), source=m, T10=T10)
    mid = np.setdiff1d(unique(T10[:, 4:]), unique(T))
    if mid.size != unique(T10[:, 4:]).size:
        raise InvalidMeshError("some tetra10 mid-side nodes are also corner nodes", code="bad_connectivity")
    return mesh


