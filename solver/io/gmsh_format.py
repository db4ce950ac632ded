"""Gmsh meshes (``.msh``): the format's entry in the registry, its sniffer, size check and diagnosis.

meshio reads Gmsh 2.2 and 4.1 files, ASCII and binary (:func:`_gmsh22_cell_data`
corrects its 2.2 reader while a file is read); :func:`solver.io.patch_msh.patch_msh`
writes an ASCII file back with new ``$Nodes`` coordinates. Before reading, the
counts of ``$Nodes`` and ``$Elements`` (each 4.1 block's too, text or binary)
are held to the read bounds; a reader's failure is named as a section without
its ``$End`` line or a file without nodes or elements.
"""

from __future__ import annotations

import contextlib
import os
import re
import struct
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from ..errors import UnreadableFileError
from .diagnose import check_last_line
from .patch_msh import patch_msh
from .patchers import Patcher
from .read_bounds import ReadBounds, check_block, check_bounds, check_holds, check_node_tags
from .registry import FileFormat, register_format

__all__ = ["GMSH", "sniff", "check_sizes", "diagnose"]


def sniff(head: bytes, size: int | None = None) -> bool:
    r"""Whether a file's first bytes are a Gmsh mesh: ``$MeshFormat`` (or version 1's ``$NOD``) first.

    Examples
    --------
    >>> sniff(b"$MeshFormat\n4.1 0 8\n"), sniff(b"\n$NOD\n"), sniff(b"*NODE\n")
    (True, True, False)
    """
    text = head.lstrip()
    return text.startswith(b"$MeshFormat") or text.startswith(b"$NOD")


# ------------------------------------------------------------------ declared sizes


def check_sizes(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    """Refuse node and element counts (totals, each 4.1 block's, the largest node tag) over ``bounds``."""
    fmt = re.search(rb"\$MeshFormat[ \t]*\r?\n[ \t]*(\S+)[ \t]+1[ \t]+(\d+)[ \t]*\r?\n", head[:1 << 16])
    if fmt and fmt[1] != b"4.0" and fmt[1].split(b".")[0] == b"4":
        # binary, read as 4.1 (meshio reads "4", "4.1", "4.10", ... so): the sections' headers are
        # machine integers, not text; the integer 1 after the format line tells the byte order
        one = head[fmt.end():fmt.end() + 4]
        order = {struct.pack("<i", 1): "<", struct.pack(">i", 1): ">"}.get(one)
        return _binary41(path, name, head, int(fmt[2]), order, bounds) if order else None
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
        block = _largest_block(head, section, per) if b"$MeshFormat\n4" in head[:64] else 0
        if block > 0:
            check_block(name, section.decode(), block, max(total, 0), code, bound)
    if nodes <= bounds.points:  # else the count itself is named below
        check_node_tags(name, tag, bounds)
    check_bounds(name, bounds, nodes, elems)
    size = os.path.getsize(path)
    check_holds(name, "nodes", nodes, 2, size)  # at least a tag and a blank each (binary: more)
    check_holds(name, "elements", elems, 2, size)


def _largest_block(head: bytes, section: bytes, lines_per_item: int) -> int:
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


#: Nodes per element of the Gmsh element types a 4.1 file's blocks hold (first and second order).
_GMSH_NODES = {1: 2, 2: 3, 3: 4, 4: 4, 5: 8, 6: 6, 7: 5, 8: 3, 9: 6, 10: 9, 11: 10, 12: 27, 13: 18, 14: 14,
               15: 1, 16: 8, 17: 20, 18: 15, 19: 13}

_SECTION = {s: re.compile(rb"(?m)^[ \t]*\$" + s + rb"[ \t]*\r?\n") for s in (b"Nodes", b"Elements")}


def _binary41(path: str, name: str, head: bytes, size_t: int, end: str, bounds: ReadBounds) -> None:
    """The totals of a binary Gmsh 4.1 file's ``$Nodes`` and ``$Elements`` headers, and each block's count.

    Each section opens with four ``size_t`` (blocks, entries, smallest and largest tag). A node block
    is three ``int`` (dimension, entity, parametric) and a ``size_t`` count, then the tags and the
    coordinates; an element block three ``int`` (dimension, entity, type) and a count, then a tag and
    the nodes of each element. The walk seeks over the data, so the counts are known before the
    reader allocates anything; a block larger than its section is refused, as in a text file.
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


# ------------------------------------------------------------------ reading and its failures


@contextlib.contextmanager
def _gmsh22_cell_data(path: str, bounds: ReadBounds) -> Iterator[None]:
    """Split Gmsh 2.2 ``$ElementData`` per cell block right while a file is read.

    meshio 5.3's Gmsh 2.2 reader splits it at the lengths of its ``(type, cells)``
    tuples (2) instead of their cells, so a file with data and two cell types fails.
    """
    from meshio.gmsh import _gmsh22

    original = _gmsh22.cell_data_from_raw

    def split(cells: list[Any], raw: dict[str, np.ndarray]) -> dict[str, list[np.ndarray]]:
        sizes = [len(c[1]) if isinstance(c, tuple) else len(c) for c in cells]
        return {k: np.split(v, np.cumsum(sizes)[:-1]) for k, v in raw.items()}

    _gmsh22.cell_data_from_raw = split
    try:
        yield
    finally:
        _gmsh22.cell_data_from_raw = original


def diagnose(path: str, data: bytes, exc: BaseException) -> UnreadableFileError | None:
    """A section cut before its ``$End`` line (``truncated_file``), or no ``$Nodes`` / ``$Elements`` section."""
    name = os.path.basename(path)
    for sec in (b"Nodes", b"Elements"):
        if re.search(rb"^\$" + sec + rb"\s*$", data, re.M) and not re.search(rb"^\$End" + sec, data, re.M):
            return UnreadableFileError(
                f"{name!r} ends inside its ${sec.decode()} section (no $End{sec.decode()}): the file is "
                "truncated", code="truncated_file", file=name, section=sec.decode())
    for sec, code in ((b"Nodes", "no_nodes"), (b"Elements", "no_elements")):
        if not re.search(rb"^\$" + sec, data, re.M):
            return UnreadableFileError(f"{name!r} is a Gmsh file without a ${sec.decode()} section: it "
                                       f"defines no {sec.decode().lower()}", code=code, file=name)
    return None


#: The format's entry in :data:`solver.io.registry.FORMATS`.
GMSH = register_format(FileFormat(
    name="gmsh", title="Gmsh mesh (.msh)", extensions=(".msh",), aliases=("msh",),
    sniff=sniff, sniff_order=100, telling=True, signed=True,
    read=None, reading=_gmsh22_cell_data, check_sizes=check_sizes, check_complete=check_last_line,
    diagnose=diagnose, nodes_where="an empty $Nodes section",
    patcher=Patcher("gmsh", ("msh",), ("msh",), lambda raw, n: raw.lstrip().startswith(b"$MeshFormat"), patch_msh),
    writes=True,
    reads="Gmsh 2.2 and 4.1 files, ASCII or binary (meshio's reader), with tetrahedra (linear or quadratic), "
          "hexahedra, wedges, pyramids or triangles; physical groups as sets; an ASCII file written back in place "
          "(its $Nodes coordinates)",
    refuses="a section cut before its $End line (truncated_file), a file without $Nodes or $Elements (no_nodes, "
            "no_elements), counts over the read bounds; a binary file is not patched in place (a file_content "
            "loss: lossy=True rewrites it)"))
