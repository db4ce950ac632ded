"""Medit meshes (``.mesh``, ``.meshb``): the format's entry in the registry, its sniffer, size check and diagnosis.

meshio reads a Medit file's linear elements; :func:`solver.io.patch_medit.patch_medit`
writes the file back with new ``Vertices`` coordinates. Before reading, every
counted keyword is held to the read bounds (a binary file is walked keyword
by keyword, skipping the data by its size), and quadratic or higher-order
elements (``TetrahedraP2``...), which meshio's text reader stops at and its
binary reader skips, are refused naming each kind and count.
"""

from __future__ import annotations

import io
import os
import re
import struct

import numpy as np

from ..errors import UnreadableFileError, UnsupportedElementError
from .diagnose import check_last_line
from .element_words import element_words
from .patch_medit import _entry_width, medit_keywords, medit_point_count, patch_medit
from .patchers import Patcher
from .read_bounds import ReadBounds, check_bounds, check_holds
from .registry import FileFormat, register_format

__all__ = ["MEDIT", "sniff", "check_sizes", "diagnose", "check_complete", "medit_high_order"]

#: The first integer of a binary Medit file, 1, in either byte order.
_BINARY = (b"\x01\x00\x00\x00", b"\x00\x00\x00\x01")


def sniff(head: bytes, size: int | None = None) -> bool:
    r"""Whether a file's first bytes are a Medit mesh: a ``MeshVersionFormatted`` line, or a binary file's code 1.

    A binary file is told by its first integer only where its size is known (more than its 8-byte header).

    Examples
    --------
    >>> sniff(b"MeshVersionFormatted 2\nDimension 3\n"), sniff(b"\x01\x00\x00\x00\x02\x00\x00\x00", 200)
    (True, True)
    >>> sniff(b"\x01\x00\x00\x00\x02\x00\x00\x00")
    False
    """
    if re.search(rb"^\s*MeshVersionFormatted", head, re.MULTILINE):
        return True
    return head[:4] in _BINARY and size is not None and size > 8


# ------------------------------------------------------------------ declared sizes

#: Medit keywords meshio reads as points; every other counted keyword is checked as elements.
_MEDIT_POINTS = {"Vertices", "Corners", "RequiredVertices", "Normals", "NormalAtVertices", "Tangents",
                 "TangentAtVertices", "VertexOnGeometricVertex", "VertexOnGeometricEdge"}


def check_sizes(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    """Refuse a keyword's count over ``bounds``, or more entries than the file could hold."""
    size = os.path.getsize(path)
    if head[:4] in (struct.pack("<i", 1), struct.pack(">i", 1)):
        return _binary_sizes(path, name, size, bounds)
    with open(path, "rb") as fh:
        data = fh.read()
    # meshio reads the count on the line after the keyword, and skips that many lines or numbers
    for m in re.finditer(rb"(?m)^[ \t]*([A-Za-z]+)[ \t]*\r?\n[ \t]*(\d+)[ \t]*$", data):
        word, n = m[1].decode(), int(m[2])
        if word in ("Dimension", "MeshVersionFormatted"):
            continue
        check_bounds(name, bounds, *((n, 0) if word in _MEDIT_POINTS else (0, n)))
        check_holds(name, f"{word} entries", n, 2, size)


def _entry_bytes(template: str, dim: int, isize: int, fsize: int) -> int | None:
    """Bytes of one entry of a binary Medit keyword from its template (None: not a sizable template).

    ``i`` is an integer, ``r`` a real, and ``d`` makes the next letter count ``dim`` times
    (``"dri"``: a vertex, ``dim`` reals and a reference).

    Examples
    --------
    >>> _entry_bytes("dri", 3, 4, 8), _entry_bytes("iiiii", 3, 4, 8), _entry_bytes("hr", 3, 4, 8)
    (28, 20, None)
    """
    return _entry_width(template, dim, isize, fsize) or None


def _binary_sizes(path: str, name: str, size: int, bounds: ReadBounds) -> None:
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
            width = _entry_bytes(entry[2], dim, np.dtype(itype).itemsize, np.dtype(ftype).itemsize)
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


# ------------------------------------------------------------------ quadratic and higher-order elements

#: Medit element keywords without their order, and meshio's name of the linear type.
_MEDIT_SHAPES = {"Edges": "line", "Triangles": "triangle", "Quadrilaterals": "quad", "Tetrahedra": "tetra",
                 "Prisms": "wedge", "Pyramids": "pyramid", "Hexahedra": "hexahedron"}
_MEDIT_HIGH = re.compile(rb"(?m)^[ \t]*(" + "|".join(_MEDIT_SHAPES).encode()
                         + rb")([PQ])([2-9])[ \t]*(?:\r?\n[ \t]*)?(\d+)?")
_MEDIT_NAME = re.compile(r"(?:Gmf)?(" + "|".join(_MEDIT_SHAPES) + r")([PQ])([2-9])\Z")


def _nodes(shape: str, p: int) -> int:
    """Nodes of a Lagrange element of order ``p``."""
    return {"line": p + 1, "triangle": (p + 1) * (p + 2) // 2, "quad": (p + 1) ** 2,
            "tetra": (p + 1) * (p + 2) * (p + 3) // 6, "hexahedron": (p + 1) ** 3,
            "wedge": (p + 1) ** 2 * (p + 2) // 2, "pyramid": (p + 1) * (p + 2) * (2 * p + 3) // 6}[shape]


def medit_high_order(data: bytes) -> dict[str, int]:
    r"""The quadratic and higher-order element keywords of a Medit file (text or binary), with their counts.

    meshio reads Medit's linear elements only: its text reader stops at a
    keyword such as ``TetrahedraP2`` without a word, its binary reader skips
    the keyword's elements.

    Examples
    --------
    >>> medit_high_order(b"MeshVersionFormatted 2\nDimension 3\nVertices\n0\nTetrahedraP2\n12\nTrianglesP2 3\nEnd\n")
    {'TetrahedraP2': 12, 'TrianglesP2': 3}
    """
    found: dict[str, int] = {}
    if data[:4] in _BINARY:
        for kw, _, _ in medit_keywords(io.BytesIO(data)):
            if _MEDIT_NAME.match(kw.name):
                found[kw.name[3:]] = found.get(kw.name[3:], 0) + kw.count
        return found
    for m in _MEDIT_HIGH.finditer(data):
        key = (m[1] + m[2] + m[3]).decode()
        found[key] = found.get(key, 0) + int(m[4] or 0)
    return found


def _high_order_error(name: str, found: dict[str, int]) -> UnsupportedElementError:
    """The refusal of a Medit file's quadratic or higher-order elements, named with their counts."""
    types: dict[str, int] = {}
    labels: dict[str, str] = {}
    for key, count in found.items():
        m = _MEDIT_NAME.match(key)
        assert m is not None
        shape = _MEDIT_SHAPES[m[1]]
        kind = f"{shape}{_nodes(shape, int(m[3]))}"
        types[kind], labels[kind] = types.get(kind, 0) + count, key
    order = "quadratic" if all(k[-1] == "2" for k in found) else "quadratic or higher-order"
    return UnsupportedElementError(
        f"{name!r} holds {element_words(types, labels)}; tetmorph does not read {order} Medit elements, only "
        "linear ones (Edges, Triangles, Quadrilaterals, Tetrahedra, Prisms, Pyramids, Hexahedra). Quadratic "
        "tetrahedra are read from Gmsh (.msh), VTU or Abaqus (.inp) files.",
        file=name, keywords=dict(found), types=types)


# ------------------------------------------------------------------ before and after reading


def check_complete(path: str, data: bytes | None = None) -> None:
    """Refuse a binary file's higher-order elements (meshio would skip them), a text file cut in a line.

    Raises
    ------
    UnsupportedElementError
        A ``.meshb`` with quadratic or higher-order elements.
    UnreadableFileError
        ``truncated_file`` (:func:`solver.io.diagnose.check_last_line`).
    """
    if path.endswith("b"):  # binary: meshio skips elements it does not know
        with open(path, "rb") as fh:
            high = medit_high_order(fh.read())
        if high:
            raise _high_order_error(os.path.basename(path), high)
        return
    check_last_line(path, data)


def diagnose(path: str, data: bytes, exc: BaseException) -> UnreadableFileError | UnsupportedElementError | None:
    """Higher-order elements the reader stopped at, or a text file without its closing ``End``."""
    name = os.path.basename(path)
    high = medit_high_order(data)
    if high:
        return _high_order_error(name, high)
    if not re.search(rb"^\s*End\b", data[-4096:], re.M) and data.lstrip()[:1] != b"\x01":
        return UnreadableFileError(f"{name!r} ends before Medit's closing 'End' keyword: the file is "
                                   "truncated", code="truncated_file", file=name)
    return None


#: The format's entry in :data:`solver.io.registry.FORMATS`.
MEDIT = register_format(FileFormat(
    name="medit", title="Medit mesh (.mesh)", extensions=(".mesh", ".meshb"),
    sniff=sniff, sniff_order=600,
    read=None, check_sizes=check_sizes, check_complete=check_complete, diagnose=diagnose,
    nodes_where="no Vertices",
    patcher=Patcher("medit", (), ("mesh", "meshb"), lambda raw, n: medit_point_count(raw) == n, patch_medit),
    writes=True,
    reads="Medit text (.mesh) and binary (.meshb) files (meshio's reader), versions 1 to 4, with linear "
          "tetrahedra, hexahedra, prisms, pyramids or triangles; element references as material regions; the "
          "Vertices coordinates written back in place",
    refuses="quadratic and higher-order elements such as TetrahedraP2 (unsupported_element, each kind counted), "
            "a text file without its closing End or cut in a line (truncated_file), counts over the read bounds"))
