"""The counts a binary mesh file declares, read from its section headers without reading its data.

Binary Gmsh 4.1 and binary Medit (``.meshb``) keep their counts in machine
integers between the data; each walker here reads the headers in order and
seeks over the data by its size, so the counts are known before the reader
allocates anything.
"""

from __future__ import annotations

import os
import re
import struct
from collections.abc import Callable

import numpy as np

from .read_bounds import ReadBounds, check_block, check_bounds, check_holds, check_node_tags

__all__ = ["gmsh41_binary", "medit_binary"]


#: Nodes per element of the Gmsh element types a 4.1 file's blocks hold (first and second order).
_GMSH_NODES = {1: 2, 2: 3, 3: 4, 4: 4, 5: 8, 6: 6, 7: 5, 8: 3, 9: 6, 10: 9, 11: 10, 12: 27, 13: 18, 14: 14,
               15: 1, 16: 8, 17: 20, 18: 15, 19: 13}

_SECTION = {s: re.compile(rb"(?m)^[ \t]*\$" + s + rb"[ \t]*\r?\n") for s in (b"Nodes", b"Elements")}


def gmsh41_binary(path: str, name: str, head: bytes, size_t: int, end: str, bounds: ReadBounds) -> None:
    """The totals of a binary Gmsh 4.1 file's ``$Nodes`` and ``$Elements`` headers, and each block's count.

    Each section opens with four ``size_t`` (blocks, entries, smallest and largest tag). A node block
    is three ``int`` (dimension, entity, parametric) and a ``size_t`` count, then the tags and the
    coordinates; an element block three ``int`` (dimension, entity, type) and a count, then a tag and
    the nodes of each element. The walk seeks over the data; a block larger than its section is
    refused, as in a text file.
    """
    m = _SECTION[b"Nodes"].search(head)
    if m is None or size_t not in (4, 8):
        return  # the reader names it
    word = ("Q" if size_t == 8 else "I")
    size = os.path.getsize(path)

    def walk(blocks: int, section: str, total: int, code: str, bound: int,
             entry_bytes: Callable[[int], int | None]) -> bool:
        """Seek over a section's blocks (``entry_bytes`` of a block's third int); False where the walk stops."""
        for _ in range(min(blocks, 100_000)):
            raw = fh.read(12 + size_t)
            if len(raw) < 12 + size_t:
                return False
            _, _, third, n = struct.unpack(end + "iii" + word, raw)
            check_block(name, section, n, total, code, bound)
            width = entry_bytes(third)
            if width is None:
                return False
            fh.seek(n * width, os.SEEK_CUR)
        return True

    with open(path, "rb") as fh:
        fh.seek(m.end())
        raw = fh.read(4 * size_t)
        if len(raw) < 4 * size_t:
            return
        blocks, nodes, _, tag = struct.unpack(end + 4 * word, raw)
        check_bounds(name, bounds, points=nodes)
        check_node_tags(name, tag, bounds)
        check_holds(name, "nodes", nodes, size_t + 24, size)
        # parametric coordinates are sized by the entity's dimension: the reader walks those
        if not walk(blocks, "Nodes", nodes, "too_many_points", bounds.points,
                    lambda parametric: None if parametric else size_t + 24):
            return
        at = fh.tell()
        m = _SECTION[b"Elements"].search(fh.read(1 << 20))
        if m is None:
            return
        fh.seek(at + m.end())
        raw = fh.read(4 * size_t)
        if len(raw) < 4 * size_t:
            return
        blocks, elems, _, _ = struct.unpack(end + 4 * word, raw)
        check_bounds(name, bounds, cells=elems)
        check_holds(name, "elements", elems, 2 * size_t, size)
        walk(blocks, "Elements", elems, "too_many_cells", bounds.cells,  # a type not known here: the reader names it
             lambda kind: (1 + _GMSH_NODES[kind]) * size_t if kind in _GMSH_NODES else None)


def _medit_entry_bytes(template: str, dim: int, isize: int, fsize: int) -> int | None:
    """Bytes of one entry of a binary Medit keyword from its template (None: not a sizable template).

    ``i`` is an integer, ``r`` a real, and ``d`` makes the next letter count ``dim`` times
    (``"dri"``: a vertex, ``dim`` reals and a reference).

    Examples
    --------
    >>> _medit_entry_bytes("dri", 3, 4, 8), _medit_entry_bytes("iiiii", 3, 4, 8), _medit_entry_bytes("hr", 3, 4, 8)
    (28, 20, None)
    """
    width, count = 0, 1
    for ch in template:
        if ch == "d":
            count = dim
            continue
        if ch not in "ir":
            return None
        width += count * (isize if ch == "i" else fsize)
        count = 1
    return width or None


def medit_binary(path: str, name: str, size: int, bounds: ReadBounds) -> None:
    """Walk a ``.meshb`` keyword by keyword (code, position, count), skipping the data by its size."""
    from meshio.medit._medit_internal import medit_codes  # keyword code -> (name, count kind, entry template)

    with open(path, "rb") as fh:
        end = "<" if struct.unpack("<i", fh.read(4))[0] == 1 else ">"
        version = struct.unpack(end + "i", fh.read(4))[0]
        if not 1 <= version <= 4:
            return  # the reader names it
        itype, ftype, ptype = {1: ("i4", "f4", "i4"), 2: ("i4", "f8", "i4"), 3: ("i4", "f8", "i8")}.get(
            version, ("i8", "f8", "i8"))
        dim = 3
        for _ in range(10_000):  # keywords: a handful in any real file
            raw = fh.read(4)
            if len(raw) < 4:
                return
            code = struct.unpack(end + "i", raw)[0]
            entry = medit_codes.get(code)
            if entry is None or entry[0] == "GmfEnd":
                return
            if entry[0] == "GmfReserved":
                continue
            fh.read(np.dtype(ptype).itemsize)
            n = 1
            if entry[1] == "i":
                raw = fh.read(np.dtype(itype).itemsize)
                if len(raw) < np.dtype(itype).itemsize:
                    return
                n = int(np.frombuffer(raw, end + itype)[0])
            width = _medit_entry_bytes(entry[2], dim, np.dtype(itype).itemsize, np.dtype(ftype).itemsize)
            if width is None:  # a template the reader cannot size either: it says why
                return
            if entry[0] == "GmfDimension":  # a 4-byte integer in every version, as the reader reads it
                raw = fh.read(4)
                if len(raw) < 4:
                    return
                dim = struct.unpack(end + "i", raw)[0]
                continue
            check_bounds(name, bounds, *((n, 0) if entry[0] == "GmfVertices" else (0, n)))
            check_holds(name, f"{entry[0][3:]} entries", n, width, size)
            fh.seek(n * width, os.SEEK_CUR)
