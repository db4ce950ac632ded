"""What a mesh file may expand to, checked before its reader allocates anything.

A reader trusts the counts a file declares: a few hundred bytes of header
can make it allocate terabytes (``MemoryError: Unable to allocate 291 TiB``)
or loop over a billion empty lines, and a few hundred kilobytes of zlib can
inflate to gigabytes. :func:`check_declared_sizes` reads only the head (or
the headers) of a file and refuses, with a typed error naming the count, the
bound and the setting that holds it:

- declared nodes over :attr:`ReadBounds.points` (``too_many_points``) and
  elements over :attr:`ReadBounds.cells` (``too_many_cells``);
- data that adds up to more than :attr:`ReadBounds.expanded_bytes`
  (``too_many_bytes``): compressed VTU arrays by their block headers, HDF5
  datasets (XDMF's, CGNS, MED...) by their shapes;
- counts a file could not hold, however small (``truncated_file``).

Each format that tetmorph writes back in place checks its own counts (its
:attr:`~solver.io.registry.FileFormat.check_sizes`: VTU, legacy VTK, Gmsh,
Medit, TetGen); the meshio formats it only reads are checked here: PLY, OFF,
binary STL, SU2, UGRID, XDMF and the HDF5 formats.
"""

from __future__ import annotations

import os
import re
import struct
from typing import Any

import numpy as np

from ..errors import SolverError, UnreadableFileError
from .read_bounds import ReadBounds, check_read_sizes, declared_total
from .read_bounds import check_bounds as _check
from .read_bounds import check_holds as _holds
from .registry import FORMATS

__all__ = ["ReadBounds", "check_declared_sizes", "check_read_sizes", "memory_error"]


#: Bytes of a file's head read for the counts it declares (XML headers, Gmsh sections before $Nodes).
_HEAD = 4 << 20


def check_declared_sizes(path: str, fmt: str, bounds: ReadBounds | None = None) -> None:
    """Refuse a file that declares more nodes, elements or bytes than ``bounds``, before it is read.

    Parameters
    ----------
    path : str
    fmt : str
        meshio format name (``tetgen`` for the ``.node`` of a TetGen pair).
    bounds : ReadBounds, optional

    Raises
    ------
    UnreadableFileError
        ``too_many_points``, ``too_many_cells`` or ``too_many_bytes`` naming
        the count declared, the bound and its setting (details ``declared``,
        ``bound``, ``setting``); ``truncated_file`` for a count the file
        cannot hold.
    """
    bounds = bounds or ReadBounds()
    own = FORMATS.get(fmt)
    check = own.check_sizes if own is not None else _CHECKS.get(fmt)
    if check is None:
        return  # text formats without declared counts: what they hold is bounded by their size
    with open(path, "rb") as fh:
        head = fh.read(_HEAD)
    try:
        check(path, os.path.basename(path), head, bounds)
    except SolverError:
        raise
    except (struct.error, ValueError, IndexError, OverflowError, OSError, UnicodeDecodeError):
        return  # a header too short or malformed to read a count from: the format's reader names the defect


# ------------------------------------------------------------------ surfaces: PLY, OFF, STL


def _ply(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    end = head.find(b"end_header")
    header = head[:end if end >= 0 else len(head)]
    size = os.path.getsize(path)
    for m in re.finditer(rb"(?m)^element[ \t]+(\w+)[ \t]+(\d+)", header):
        kind, n = m[1].decode(), int(m[2])
        _check(name, bounds, *((n, 0) if kind == "vertex" else (0, n)))
        _holds(name, f"{kind} entries", n, 1, size)


def _off(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    lines = [ln.split(b"#", 1)[0].split() for ln in head.splitlines()[:64]]
    lines = [ln for ln in lines if ln]
    if not lines or lines[0][0] != b"OFF":
        return
    counts = lines[0][1:] if len(lines[0]) > 1 else (lines[1] if len(lines) > 1 else [])
    try:
        nv, nf = int(counts[0]), int(counts[1])
    except (ValueError, IndexError):
        return
    _check(name, bounds, nv, nf)
    size = os.path.getsize(path)
    _holds(name, "vertices", nv, 6, size)  # "0 0 0\n" at the least
    _holds(name, "faces", nf, 8, size)


def _stl(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    size = os.path.getsize(path)
    n = int.from_bytes(head[80:84], "little") if len(head) >= 84 else -1
    if 84 + 50 * n == size:  # binary (a count that does not fit the size is refused by check_file)
        _check(name, bounds, 3 * n, n)


# ------------------------------------------------------------------ SU2, UGRID


def _su2(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    size = os.path.getsize(path)
    points = declared_total(rb"(?m)^\s*NPOIN\s*=\s*(\d+)", head)
    cells = declared_total(rb"(?m)^\s*(?:NELEM|MARKER_ELEMS)\s*=\s*(\d+)", head)
    _check(name, bounds, points, cells)
    _holds(name, "points and elements", points + cells, 4, size)


def _ugrid(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    parts = os.path.basename(path).split(".")
    kind = parts[-2] if len(parts) > 2 else "ascii"
    if kind == "ascii" or kind not in ("b8l", "b8", "b4", "lb8l", "lb8", "lb4"):
        try:
            nums = [int(t) for t in head.split(b"\n", 1)[0].split()[:7]]
        except ValueError:
            return
    else:
        wide = kind.endswith("l")
        k = 8 if wide else 4
        end = "<" if kind.startswith("l") else ">"
        if len(head) < 7 * k:
            return
        nums = list(struct.unpack(end + 7 * ("q" if wide else "i"), head[:7 * k]))
    if len(nums) < 7:
        return
    points, cells = nums[0], sum(nums[1:7])
    _check(name, bounds, points, cells)
    _holds(name, "points and elements", points + cells, 4, os.path.getsize(path))


# ------------------------------------------------------------------ HDF5: XDMF and the rest


def _xdmf(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    """Every DataItem's declared shape, and the shapes of the HDF5 datasets it names (within its folder)."""
    with open(path, "rb") as fh:
        text = fh.read()
    folder = os.path.realpath(os.path.dirname(path))
    total = 0
    files: set[str] = set()
    for m in re.finditer(rb"<DataItem\b([^>]*)>([^<]*)", text):
        attrs, body = m[1], m[2].strip()
        dims = re.search(rb'Dimensions\s*=\s*"([\d\s]+)"', attrs)
        prec = re.search(rb'Precision\s*=\s*"(\d+)"', attrs)
        if dims:
            total += int(np.prod([int(d) for d in dims[1].split()], dtype=object)) * (int(prec[1]) if prec else 4)
        form = re.search(rb'Format\s*=\s*"(\w+)"', attrs)
        if form and form[1] == b"Binary":  # meshio opens the path as given, from the process's folder
            raise UnreadableFileError(
                f"{name!r} holds a DataItem of Format=\"Binary\", whose file its reader opens from the server's "
                "working folder; store the data in HDF5 (Format=\"HDF\") as a companion file",
                code="external_reference", file=name, reference=body.decode(errors="replace")[:200])
        if form and form[1] == b"HDF" and body:
            ref = body.decode(errors="replace").split(":", 1)[0]
            target = os.path.realpath(os.path.join(folder, ref))
            if os.path.dirname(target) != folder:
                raise UnreadableFileError(
                    f"{name!r} refers to {ref!r}, outside the folder of the mesh's own files; upload the data "
                    "file with it as a companion and refer to it by its name", code="external_reference",
                    file=name, reference=ref[:200])
            files.add(target)
    _check(name, bounds, nbytes=total)
    for f in sorted(files):
        if os.path.isfile(f):
            _hdf5(f, os.path.basename(f), b"", bounds)


def _hdf5(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    """The bytes an HDF5 file's datasets declare, summed over their shapes (nothing is read).

    The same walk refuses data kept in other files (:func:`_own_data_only`).
    """
    try:
        import h5py
    except ImportError:
        return
    total = 0

    def visit(where: str, obj: Any) -> None:
        nonlocal total
        _own_data_only(h5py, name, where, obj)
        if isinstance(obj, h5py.Dataset) and obj.shape is not None:
            n = 1
            for d in obj.shape:
                n *= int(d)
            total += n * obj.dtype.itemsize

    try:
        f = h5py.File(path, "r")
    except (OSError, ValueError):
        return  # not HDF5 after all: the reader names it
    with f:
        try:
            _own_data_only(h5py, name, "/", f)  # the root group is not visited
            f.visititems(visit)
        except UnreadableFileError:
            raise
        except Exception:  # noqa: BLE001 - a damaged file (h5py raises RuntimeError, KeyError...): the reader names it
            return
    _check(name, bounds, nbytes=total)


def _own_data_only(h5py: Any, name: str, where: str, obj: Any) -> None:
    """Refuse a group's external links, or a virtual or externally stored dataset, of an HDF5 file.

    Each would make the reader open a path of the uploader's choosing on the server.
    """
    def refuse(at: str, what: str, ref: str) -> None:
        raise UnreadableFileError(
            f"{name!r} holds {what} at {at!r} to {ref!r}, data outside the uploaded files; store the data "
            "in the file itself", code="external_reference", file=name, reference=ref[:200])

    if isinstance(obj, h5py.Group):
        for key in obj:
            link = obj.get(key, getlink=True)
            if isinstance(link, h5py.ExternalLink):
                refuse(f"{obj.name.rstrip('/')}/{key}", "an external link", f"{link.filename}:{link.path}")
    elif isinstance(obj, h5py.Dataset):
        if obj.is_virtual:
            refuse(where, "a virtual dataset", ", ".join(sorted({m.file_name for m in obj.virtual_sources()})))
        if obj.external:
            refuse(where, "a dataset stored in an external file", str(obj.external[0][0]))


#: The size checks of the meshio formats tetmorph reads but does not write back (a registered format's is
#: its :attr:`~solver.io.registry.FileFormat.check_sizes`).
_CHECKS = {"ply": _ply, "off": _off, "stl": _stl, "su2": _su2, "ugrid": _ugrid, "xdmf": _xdmf, "cgns": _hdf5,
           "med": _hdf5, "h5m": _hdf5, "hmf": _hdf5}


def memory_error(path: str, fmt: str, e: MemoryError, bounds: ReadBounds) -> UnreadableFileError:
    """The typed error for a reader that ran out of memory (what the bounds could not tell beforehand)."""
    name = os.path.basename(path)
    return UnreadableFileError(
        f"reading {name!r} as {fmt} needed more memory than this process could allocate; the file's declared "
        f"sizes passed the bounds ({bounds.points:,} nodes, {bounds.cells:,} elements, "
        f"{bounds.expanded_bytes:,} bytes expanded: {bounds.points_setting}, {bounds.cells_setting}, "
        f"{bounds.bytes_setting}); lower them, or split or coarsen the mesh", code="too_large_to_read", file=name,
        bound=bounds.expanded_bytes, setting=bounds.bytes_setting)
