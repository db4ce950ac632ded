"""What a mesh file may expand to, checked before its reader allocates anything.

A reader trusts the counts a file declares: a few hundred bytes of header
can make it allocate terabytes (``MemoryError: Unable to allocate 291 TiB``)
or loop over a billion empty lines, and a few hundred kilobytes of zlib can
inflate to gigabytes. :func:`check_declared_sizes` reads only the head (or
the headers) of a file and refuses, with a typed error naming the count, the
bound and the setting that holds it:

- declared nodes over :attr:`ReadBounds.points` (``too_many_points``) and
  elements over :attr:`ReadBounds.cells` (``too_many_cells``): VTU, legacy
  VTK, Gmsh, Medit (ASCII and binary), TetGen ``.node``/``.ele`` (attribute
  counts included), PLY, OFF, binary STL, SU2, UGRID;
- compressed VTU data arrays whose zlib/LZMA block headers, or HDF5 datasets
  (XDMF's, CGNS, MED...) whose shapes, add up to more than
  :attr:`ReadBounds.expanded_bytes` (``too_many_bytes``);
- counts a file could not hold, however small (``truncated_file``).

While a VTU file is read, :func:`expansion_budget` makes meshio's
decompression stop at the same byte bound, for block headers that lie.
"""

from __future__ import annotations

import base64
import contextlib
import lzma
import os
import re
import struct
import threading
import zlib
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..errors import SolverError, UnreadableFileError
from .binary_headers import gmsh41_binary, medit_binary
from .read_bounds import ReadBounds, check_block, check_node_tags, check_read_sizes
from .read_bounds import check_bounds as _check
from .read_bounds import check_holds as _holds

__all__ = ["ReadBounds", "check_declared_sizes", "check_read_sizes", "expansion_budget", "memory_error"]


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
    check = _CHECKS.get(fmt)
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


# ------------------------------------------------------------------ VTU, VTK, Gmsh


def _total(pat: bytes, head: bytes) -> int:
    return sum(int(x) for x in re.findall(pat, head))


def _vtu(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    _check(name, bounds, _total(rb'NumberOfPoints\s*=\s*"(\d+)"', head), _total(rb'NumberOfCells\s*=\s*"(\d+)"', head))
    m = re.search(rb'compressor\s*=\s*"(vtkZLibDataCompressor|vtkLZMADataCompressor)"', head)
    if m is None:
        return  # uncompressed data is no larger than the file
    _check(name, bounds, nbytes=_vtu_expanded(path, name, head))


def _vtu_expanded(path: str, name: str, head: bytes) -> int:
    """The bytes a compressed VTU's data arrays expand to, summed from their block headers."""
    with open(path, "rb") as fh:
        data = fh.read()
    wide = re.search(rb'header_type\s*=\s*"UInt64"', head) is not None
    big = re.search(rb'byte_order\s*=\s*"BigEndian"', head) is not None
    item = 8 if wide else 4
    fmt = (">" if big else "<") + ("Q" if wide else "I")
    total = 0
    for m in re.finditer(rb'<DataArray\b[^>]*\bformat\s*=\s*"binary"[^>]*>\s*', data):
        total += _blocks(name, _b64_reader(data, m.end()), item, fmt, len(data))
    app = re.search(rb'<AppendedData\b([^>]*)>\s*_', data)
    if app is not None:
        raw = b'"raw"' in app[1]
        start = app.end()
        for m in re.finditer(rb'<DataArray\b[^>]*\bformat\s*=\s*"appended"[^>]*\boffset\s*=\s*"(\d+)"', data):
            at = start + int(m[1])
            read = (lambda k, at=at: data[at:at + k]) if raw else _b64_reader(data, at)
            total += _blocks(name, read, item, fmt, len(data))
    return total


def _b64_reader(data: bytes, at: int) -> Any:
    """``read(k)``: the first ``k`` bytes the base64 text at ``data[at:]`` decodes to."""
    def read(k: int) -> bytes:
        chars = -(-k // 3) * 4
        try:
            return base64.b64decode(data[at:at + chars] + b"=" * (-chars % 4))[:k]
        except ValueError:
            return b""
    return read


def _blocks(name: str, read: Any, item: int, fmt: str, size: int) -> int:
    """Bytes one compressed array expands to: ``[blocks, block size, last size, compressed sizes...]``."""
    first = read(3 * item)
    if len(first) < 3 * item:
        return 0  # the reader names what is wrong with it
    nblocks, block, last = struct.unpack(fmt[0] + 3 * fmt[1], first)
    _holds(name, "compressed blocks", nblocks, item, size)
    if nblocks == 0:
        return 0
    return (nblocks - 1) * block + (last or block)


def _vtk(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    cells = _total(rb"(?m)^\s*CELLS\s+(\d+)", head)
    if re.match(rb"#\s*vtk DataFile Version 5", head) and cells:  # 5.x: CELLS counts the offsets, one more
        cells -= len(re.findall(rb"(?m)^\s*CELLS\s+\d+", head))
    _check(name, bounds, _total(rb"(?m)^\s*POINTS\s+(\d+)", head), cells)
    size = os.path.getsize(path)
    least = 1 if re.search(rb"(?m)^\s*BINARY\s*$", head[:1024]) else 2  # bytes a number takes at the least
    with open(path, "rb") as fh:
        data = fh.read()
    # every section the reader allocates from its count: POINTS n (3n numbers), CELLS n m (m), CELL_TYPES n,
    # FIELD arrays "name components tuples type"
    numbers = [("POINTS", 3 * int(n)) for n in re.findall(rb"(?m)^\s*POINTS\s+(\d+)", data)]
    numbers += [("CELLS", int(m)) for m in re.findall(rb"(?m)^\s*CELLS\s+\d+\s+(\d+)", data)]
    numbers += [("CELL_TYPES", int(n)) for n in re.findall(rb"(?m)^\s*CELL_TYPES\s+(\d+)", data)]
    numbers += [(f"field array {a.decode(errors='replace')}", int(c) * int(t)) for a, c, t in re.findall(
        rb"(?m)^[ \t]*(\S+)[ \t]+(\d+)[ \t]+(\d+)[ \t]+(?:bit|unsigned_char|char|unsigned_short|short|"
        rb"unsigned_int|int|unsigned_long|long|float|double|vtktypeint64|vtktypeuint64)[ \t]*\r?$", data)]
    for what, n in numbers:
        _check(name, bounds, nbytes=8 * n)
        _holds(name, f"numbers in {what}", n, least, size)


def _gmsh(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    fmt = re.search(rb"\$MeshFormat[ \t]*\r?\n[ \t]*(\S+)[ \t]+1[ \t]+(\d+)[ \t]*\r?\n", head[:1 << 16])
    if fmt and fmt[1] != b"4.0" and fmt[1].split(b".")[0] == b"4":
        # binary, read as 4.1 (meshio reads "4", "4.1", "4.10", ... so): the sections' headers are
        # machine integers, not text; the integer 1 after the format line tells the byte order
        one = head[fmt.end():fmt.end() + 4]
        order = {struct.pack("<i", 1): "<", struct.pack(">i", 1): ">"}.get(one)
        return gmsh41_binary(path, name, head, int(fmt[2]), order, bounds) if order else None
    nodes = elems = tag = 0
    m = re.search(rb"\$Nodes\s*\r?\n\s*(\d+)(?:[ \t]+(\d+)[ \t]+(\d+)[ \t]+(\d+))?", head)
    if m:  # 2.2: the count; 4.1: blocks, count, smallest and largest tag
        nodes = int(m[2]) if m[2] else int(m[1])
        tag = int(m[4]) if m[4] else 0
    m = re.search(rb"\$Elements\s*\r?\n\s*(\d+)(?:[ \t]+(\d+)[ \t]+(\d+)[ \t]+(\d+))?", head)
    if m:
        elems = int(m[2]) if m[2] else int(m[1])
    # 4.1: a block may declare more than the section's total (a count a reader allocates)
    for section, per, total, code, bound in ((b"Nodes", 2, nodes, "too_many_points", bounds.points),
                                             (b"Elements", 1, elems, "too_many_cells", bounds.cells)):
        block = _gmsh_blocks(head, section, per) if b"$MeshFormat\n4" in head[:64] else 0
        if block > 0:
            check_block(name, section.decode(), block, max(total, 0), code, bound)
    if nodes <= bounds.points:  # else the count itself is named below
        check_node_tags(name, tag, bounds)
    _check(name, bounds, nodes, elems)
    size = os.path.getsize(path)
    _holds(name, "nodes", nodes, 2, size)  # at least a tag and a blank each (binary: more)
    _holds(name, "elements", elems, 2, size)


def _gmsh_blocks(head: bytes, section: bytes, lines_per_item: int) -> int:
    """The largest count a Gmsh 4.1 ``$Nodes`` or ``$Elements`` block declares, over the blocks in ``head``.

    Each block is a header ``dim tag (parametric | type) count`` followed by
    ``lines_per_item * count`` lines; the walk stops at the end of the head or
    at a line that is no block header (a 2.2 file, a binary one).
    """
    k = head.find(b"$" + section)
    if k < 0:
        return 0
    lines = head[k:].split(b"\n")[2:]  # the section's name and its totals line
    i, largest = 0, 0
    while i < len(lines) - 1:  # the last line may be cut by the head
        f = lines[i].split()
        if len(f) != 4 or not all(x.isdigit() for x in f):
            break
        n = int(f[3])
        largest = max(largest, n)
        i += 1 + lines_per_item * n
    return largest


# ------------------------------------------------------------------ Medit

#: Medit keywords meshio reads as points; every other counted keyword is checked as elements.
_MEDIT_POINTS = {"Vertices", "Corners", "RequiredVertices", "Normals", "NormalAtVertices", "Tangents",
                 "TangentAtVertices", "VertexOnGeometricVertex", "VertexOnGeometricEdge"}


def _medit(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    size = os.path.getsize(path)
    if head[:4] in (struct.pack("<i", 1), struct.pack(">i", 1)):
        return medit_binary(path, name, size, bounds)
    with open(path, "rb") as fh:
        data = fh.read()
    # meshio reads the count on the line after the keyword, and skips that many lines or numbers
    for m in re.finditer(rb"(?m)^[ \t]*([A-Za-z]+)[ \t]*\r?\n[ \t]*(\d+)[ \t]*$", data):
        word, n = m[1].decode(), int(m[2])
        if word in ("Dimension", "MeshVersionFormatted"):
            continue
        _check(name, bounds, *((n, 0) if word in _MEDIT_POINTS else (0, n)))
        _holds(name, f"{word} entries", n, 2, size)


# ------------------------------------------------------------------ TetGen


def _tetgen(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    from .tetgen import tetgen_paths

    node, ele = tetgen_paths(path)
    for p, what, width in ((node, "points", 4), (ele, "cells", 3)):
        if not os.path.isfile(p):
            continue  # the reader names the missing companion
        with open(p, "rb") as fh:
            text = fh.read(1 << 16)
        first = next((ln.split(b"#", 1)[0].split() for ln in text.splitlines() if ln.split(b"#", 1)[0].split()),
                     [])
        try:
            nums = [int(t) for t in first[:width]]
        except ValueError:
            continue  # the reader names the header's defect
        nums += [0] * (width - len(nums))
        pname = os.path.basename(p)
        count, attrs = nums[0], nums[2]
        _check(pname, bounds, *((count, 0) if what == "points" else (0, count)))
        # a table of count x (id, data, attributes, marker) numbers, allocated before it is read
        per = 1 + (3 + (nums[3] != 0) if what == "points" else max(nums[1], 4)) + max(attrs, 0)
        _check(pname, bounds, nbytes=count * per * 8)
        _holds(pname, f"{'nodes' if what == 'points' else 'elements'} with {per} numbers each", count, 2 * per,
               os.path.getsize(p))


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
    points = _total(rb"(?m)^\s*NPOIN\s*=\s*(\d+)", head)
    cells = _total(rb"(?m)^\s*(?:NELEM|MARKER_ELEMS)\s*=\s*(\d+)", head)
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


_CHECKS = {"vtu": _vtu, "vtk": _vtk, "gmsh": _gmsh, "medit": _medit, "tetgen": _tetgen, "ply": _ply,
           "off": _off, "stl": _stl, "su2": _su2, "ugrid": _ugrid, "xdmf": _xdmf, "cgns": _hdf5,
           "med": _hdf5, "h5m": _hdf5, "hmf": _hdf5}


# ------------------------------------------------------------------ the decompression budget

_budget = threading.local()


class _Bounded:
    """A compression module whose ``decompress`` stops at the thread's :func:`expansion_budget`."""

    def __init__(self, module: Any) -> None:
        self.module = module

    def __getattr__(self, attr: str) -> Any:
        return getattr(self.module, attr)

    def decompress(self, data: bytes) -> bytes:
        left: int | None = getattr(_budget, "left", None)
        if left is None:
            return bytes(self.module.decompress(data))
        if self.module is zlib:
            d = zlib.decompressobj()
            out = d.decompress(data, left + 1)
            if len(out) <= left and not d.unconsumed_tail:
                out += d.flush()
        else:
            out = lzma.LZMADecompressor().decompress(data, max_length=left + 1)
        if len(out) > left:
            raise _budget.error
        _budget.left = left - len(out)
        return bytes(out)


def _install() -> None:
    from meshio.vtu import _vtu

    for attr in ("zlib", "lzma"):
        mod = getattr(_vtu, attr, None)
        if mod is not None and not isinstance(mod, _Bounded):
            setattr(_vtu, attr, _Bounded(mod))


@contextlib.contextmanager
def expansion_budget(path: str, bounds: ReadBounds) -> Iterator[None]:
    """While meshio reads a VTU file in this thread, stop its decompression past ``bounds.expanded_bytes``.

    Block headers are checked before reading (:func:`check_declared_sizes`);
    this bounds what the blocks really expand to when the headers lie.

    Raises
    ------
    UnreadableFileError
        ``too_many_bytes``, from inside the reader.
    """
    _install()
    name = os.path.basename(path)
    _budget.left = bounds.expanded_bytes
    _budget.error = UnreadableFileError(
        f"{name!r}: its compressed data expands to more than {bounds.expanded_bytes:,} bytes "
        f"({bounds.bytes_setting}), more than its block headers declare; reading stopped there",
        code="too_many_bytes", file=name, bound=bounds.expanded_bytes, setting=bounds.bytes_setting)
    try:
        yield
    finally:
        _budget.left = None
        _budget.error = None


def memory_error(path: str, fmt: str, e: MemoryError, bounds: ReadBounds) -> UnreadableFileError:
    """The typed error for a reader that ran out of memory (what the bounds could not tell beforehand)."""
    name = os.path.basename(path)
    return UnreadableFileError(
        f"reading {name!r} as {fmt} needed more memory than this process could allocate; the file's declared "
        f"sizes passed the bounds ({bounds.points:,} nodes, {bounds.cells:,} elements, "
        f"{bounds.expanded_bytes:,} bytes expanded: {bounds.points_setting}, {bounds.cells_setting}, "
        f"{bounds.bytes_setting}); lower them, or split or coarsen the mesh", code="too_large_to_read", file=name,
        bound=bounds.expanded_bytes, setting=bounds.bytes_setting)
