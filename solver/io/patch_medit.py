"""Medit meshes (``.mesh`` text, ``.meshb`` binary) written back with new ``Vertices`` coordinates.

An ASCII Medit file holds its points after the ``Vertices`` keyword and their
count, as ``x y z ref`` (``x y ref`` in two dimensions); version 1 files
hold single precision (meshio reads them as float32), versions 2 and up
double. :func:`patch_medit` rewrites the numbers of the coordinates that
changed and keeps every other byte: the references, the separators, the
number layout of unchanged values, the elements, comments and keywords
meshio skips. A binary ``.meshb`` (the Gamma Mesh Format, versions 1 to 4,
either byte order) holds the vertices as fixed-size records after the
``Vertices`` keyword: their coordinates are overwritten in place.
:func:`medit_keywords` walks a binary file's keywords as meshio reads them.
"""

from __future__ import annotations

import io
import re
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np

from .number_tokens import changed, patch_numbers

__all__ = ["patch_medit", "medit_point_count", "medit_keywords", "MeditKeyword"]

_VERSION = re.compile(rb"(?m)^[ \t]*MeshVersionFormatted[ \t]+(\d+)")
_DIMENSION = re.compile(rb"(?m)^[ \t]*Dimension[ \t]*(?:\r?\n[ \t]*)?(\d+)")
_VERTICES = re.compile(rb"(?m)^[ \t]*Vertices[ \t]*\r?\n[ \t]*(\d+)[ \t]*\r?\n")
#: Binary keyword codes of the Gamma Mesh Format.
_DIMENSION_CODE, _VERTICES_CODE, _END_CODE = 3, 4, 54


def _binary(data: bytes) -> bool:
    """Whether the bytes are a binary Medit file (its first integer is 1, in either byte order)."""
    return data[:4] in (b"\x01\x00\x00\x00", b"\x00\x00\x00\x01")


@dataclass(frozen=True)
class MeditKeyword:
    """One keyword of a binary Medit file.

    Attributes
    ----------
    name : str
        The Gamma Mesh Format name (``"GmfVertices"``, ``"GmfTetrahedraP2"``).
    count : int
        Its number of entries (1 for keywords without a count); for
        ``GmfDimension``, the dimension.
    at : int
        Offset of its first entry in the file.
    width : int or None
        Bytes per entry; None where the entry template has no fixed size.
    """

    name: str
    count: int
    at: int
    width: int | None


def _layout(version: int) -> tuple[str, str, str]:
    """Integer, real and position types of a binary Medit version."""
    return {1: ("i4", "f4", "i4"), 2: ("i4", "f8", "i4"), 3: ("i4", "f8", "i8")}.get(version, ("i8", "f8", "i8"))


def _entry_width(template: str, dim: int, isize: int, fsize: int) -> int | None:
    """Bytes of one entry from a Gamma Mesh Format template (``"dri"``: ``dim`` reals and an integer)."""
    width, repeat = 0, 1
    for ch in template:
        if ch == "d":
            repeat = dim
            continue
        if ch not in "ir":
            return None
        width += repeat * (isize if ch == "i" else fsize)
        repeat = 1
    return width


def medit_keywords(fh: BinaryIO) -> Iterator[tuple[MeditKeyword, str, int]]:
    """The keywords of a binary Medit file, in order, as meshio reads them.

    Entries are skipped by their size (the keyword's template); the walk
    stops at ``GmfEnd``, at the end of the file, or at a keyword it cannot
    size (meshio stops there too and says why).

    Parameters
    ----------
    fh : binary file
        Positioned at the start of the file.

    Yields
    ------
    keyword : MeditKeyword
    byte_order : str
        ``"<"`` or ``">"``.
    version : int
        1 to 4.
    """
    from meshio.medit._medit_internal import medit_codes  # code -> (name, count kind, entry template)

    head = fh.read(8)
    if len(head) < 8 or not _binary(head):
        return
    end = "<" if head[:4] == b"\x01\x00\x00\x00" else ">"
    version = struct.unpack(end + "i", head[4:])[0]
    if not 1 <= version <= 4:
        return
    itype, ftype, ptype = (np.dtype(end + t) for t in _layout(version))
    dim = 3
    at = 8
    while True:
        raw = fh.read(4)
        if len(raw) < 4:
            return
        code = struct.unpack(end + "i", raw)[0]
        entry = medit_codes.get(code)
        if entry is None or entry[0] == "GmfEnd":
            return
        at += 4
        if entry[0] == "GmfReserved":
            continue
        fh.seek(ptype.itemsize, io.SEEK_CUR)
        at += ptype.itemsize
        count = 1
        if entry[1] == "i":
            raw = fh.read(itype.itemsize)
            if len(raw) < itype.itemsize:
                return
            count = int(np.frombuffer(raw, itype)[0])
            at += itype.itemsize
        if entry[0] == "GmfDimension":  # a 4-byte integer in every version
            raw = fh.read(4)
            if len(raw) < 4:
                return
            dim = struct.unpack(end + "i", raw)[0]
            yield MeditKeyword(entry[0], dim, at, 4), end, version
            at += 4
            continue
        width = _entry_width(entry[2], dim, itype.itemsize, ftype.itemsize)
        yield MeditKeyword(entry[0], count, at, width), end, version
        if width is None or count < 0:
            return
        at += count * width
        fh.seek(at)


def medit_point_count(data: bytes) -> int | None:
    r"""The number of vertices a Medit file (text or binary) declares, or None.

    Examples
    --------
    >>> medit_point_count(b"MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 1\n")
    4
    """
    if _binary(data):
        for kw, _, _ in medit_keywords(io.BytesIO(data)):
            if kw.name == "GmfVertices":
                return kw.count
        return None
    m = _VERTICES.search(data)
    return None if m is None else int(m[1])


def patch_medit(data: bytes, V: np.ndarray) -> bytes:
    r"""A Medit file with the coordinates of its ``Vertices`` replaced by ``V``.

    Parameters
    ----------
    data : bytes
        The file as read: ASCII ``.mesh`` or binary ``.meshb``.
    V : (n, 3) float array
        New positions, in file order. A two-dimensional file keeps its two
        coordinates (the third must stay 0).

    Returns
    -------
    bytes
        The same file where only the numbers of changed coordinates differ.
        ASCII: their tokens are rewritten (in the block's own scientific
        notation, such as meshio's ``%.16e``, else the shortest text that
        reads back) and the references, separators and other values kept;
        version 1 files hold single precision, so a moved coordinate is
        rounded to float32. Binary: the coordinates are overwritten in their
        records. With ``V`` the positions read, the bytes are the file's.

    Raises
    ------
    ValueError
        No ``MeshVersionFormatted``, ``Dimension`` or ``Vertices``, another
        count of vertices than ``V``, a value that is not a number, or
        positions off the plane of a two-dimensional file.

    Examples
    --------
    >>> mesh = b"MeshVersionFormatted 2\nDimension 3\nVertices\n2\n0 0 0 1\n1 0 0 2\nEnd\n"
    >>> patch_medit(mesh, np.array([[0, 0, 0], [1, 0.25, 0]])).splitlines()[5]
    b'1 0.25 0 2'
    """
    P = np.asarray(V, dtype=np.float64)
    if _binary(data):
        return _patch_binary(data, P)
    version, dim, vertices = _VERSION.search(data), _DIMENSION.search(data), _VERTICES.search(data)
    if version is None or dim is None or vertices is None:
        missing = [k for k, m in (("MeshVersionFormatted", version), ("Dimension", dim), ("Vertices", vertices))
                   if m is None]
        raise ValueError(f"it has no {' or '.join(missing)} keyword followed by its value")
    n, d = int(vertices[1]), int(dim[1])
    coords = _coordinates(P, n, d)
    dtype = "f4" if int(version[1]) <= 1 else "f8"
    at = np.arange(n * (d + 1)).reshape(n, d + 1)[:, :d].ravel()  # the coordinates, not the references
    return patch_numbers(data, vertices.end(), n * (d + 1), coords, dtype, at=at)


def _coordinates(P: np.ndarray, n: int, d: int) -> np.ndarray:
    """The ``d`` coordinates a Medit file holds per vertex."""
    if n != len(P):
        raise ValueError(f"its Vertices section holds {n} vertices, the mesh {len(P)}")
    if d not in (2, 3):
        raise ValueError(f"its dimension is {d}; Medit meshes are 2- or 3-dimensional")
    if d == 2 and P.shape[1] > 2 and np.any(P[:, 2:] != 0):
        raise ValueError("the file is two-dimensional and positions move out of its plane (z != 0)")
    return P[:, :d]


def _patch_binary(data: bytes, P: np.ndarray) -> bytes:
    """The coordinates of a ``.meshb``'s vertex records overwritten in place."""
    d, found = 3, None
    for entry in medit_keywords(io.BytesIO(data)):
        if entry[0].name == "GmfDimension":
            d = entry[0].count
        elif entry[0].name == "GmfVertices":
            found = entry
            break
    if found is None:
        raise ValueError("its keywords hold no Vertices before GmfEnd")
    kw, end, version = found
    itype, ftype, _ = _layout(version)
    coords = _coordinates(P, kw.count, d)
    record = np.dtype([("x", end + ftype, (d,)), ("ref", end + itype)])
    if len(data) < kw.at + kw.count * record.itemsize:
        raise ValueError("its Vertices records are cut short")
    old = np.frombuffer(data, record, kw.count, kw.at)
    new = coords.astype(end + ftype)
    moved = changed(old["x"], new)
    if not moved.any():
        return data
    out = old.copy()
    out["x"][moved] = new[moved]
    return data[:kw.at] + out.tobytes() + data[kw.at + kw.count * record.itemsize:]
