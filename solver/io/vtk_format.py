"""Legacy VTK files (``.vtk``): the format's entry in the registry, its sniffer, size check and diagnosis.

meshio reads a legacy VTK unstructured grid, ASCII or binary, versions 4.2 and
5.1; :func:`solver.io.patch_vtk.patch_vtk` writes it back with new ``POINTS``
values. Every section meshio allocates from its count (``POINTS``, ``CELLS``,
``CELL_TYPES``, ``FIELD`` arrays) is held to the read bounds before reading.
"""

from __future__ import annotations

import os
import re

from ..errors import UnreadableFileError
from .diagnose import check_last_line
from .patch_vtk import patch_vtk, vtk_point_count
from .patchers import Patcher
from .read_bounds import ReadBounds, check_bounds, check_holds, declared_total
from .registry import FileFormat, register_format

__all__ = ["VTK", "sniff", "check_sizes", "diagnose"]


def sniff(head: bytes, size: int | None = None) -> bool:
    r"""Whether a file's first bytes are a legacy VTK file (its ``# vtk DataFile`` line first).

    Examples
    --------
    >>> sniff(b"# vtk DataFile Version 4.2\ncube\nASCII\n"), sniff(b"<VTKFile>")
    (True, False)
    """
    return head.lstrip().startswith(b"# vtk DataFile")


def check_sizes(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    """Refuse declared points and cells over ``bounds``, and sections a file of its size cannot hold."""
    cells = declared_total(rb"(?m)^\s*CELLS\s+(\d+)", head)
    if re.match(rb"#\s*vtk DataFile Version 5", head) and cells:  # 5.x: CELLS counts the offsets, one more
        cells -= len(re.findall(rb"(?m)^\s*CELLS\s+\d+", head))
    check_bounds(name, bounds, declared_total(rb"(?m)^\s*POINTS\s+(\d+)", head), cells)
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
        check_bounds(name, bounds, nbytes=8 * n)
        check_holds(name, f"numbers in {what}", n, least, size)


def diagnose(path: str, data: bytes, exc: BaseException) -> UnreadableFileError | None:
    """A file that ends before its ``CELL_TYPES`` section: ``truncated_file``, naming the counts announced."""
    counts = b", ".join(k + b" " + v for k, v in re.findall(rb"^\s*(POINTS|CELLS)\s+(\d+)", data, re.M))
    if b"CELL_TYPES" not in data:  # every unstructured grid has it, after its CELLS
        name = os.path.basename(path)
        return UnreadableFileError(
            f"{name!r} ends before its CELL_TYPES section ({counts.decode() or 'no POINTS'} announced): "
            "the file is truncated", code="truncated_file", file=name)
    return None


#: The format's entry in :data:`solver.io.registry.FORMATS`.
VTK = register_format(FileFormat(
    name="vtk", title="legacy VTK file (.vtk)", extensions=(".vtk",),
    sniff=sniff, sniff_order=400, telling=True, signed=True,
    read=None, check_sizes=check_sizes, check_complete=check_last_line, diagnose=diagnose,
    patcher=Patcher("vtk", (), ("vtk",), lambda raw, n: vtk_point_count(raw) == n, patch_vtk),
    writes=True,
    reads="legacy VTK unstructured grids (meshio's reader), ASCII or binary, versions 4.2 and 5.1, with "
          "tetrahedra (linear or quadratic), hexahedra, wedges, pyramids or triangles; 0/1 set:NAME arrays as "
          "sets; the POINTS values written back in place",
    refuses="a file that ends before its CELL_TYPES section or in the middle of a line (truncated_file), "
            "sections over the read bounds or longer than the file could hold; POINTS of another type than "
            "float or double are not patched in place (a file_content loss)"))
