"""Legacy VTK files (``.vtk``) written back with new ``POINTS`` values and nothing else changed.

A legacy file names its encoding on its third line and holds the points as
``POINTS n float|double`` followed by ``3n`` numbers: text separated by
blanks in an ASCII file (VTK writes nine to a line, meshio all of them on
one), big-endian binary values in a binary one. :func:`patch_vtk` replaces
the numbers of the coordinates that changed and keeps every other byte:
the header, the cells, point and cell data, the ``METADATA`` of version 5.1
files, the separators and the text of unchanged numbers.
"""

from __future__ import annotations

import re

import numpy as np

from .number_tokens import changed, patch_numbers

__all__ = ["patch_vtk", "vtk_point_count"]

_HEAD = re.compile(rb"#[ \t]*vtk DataFile Version[^\n]*\n[^\n]*\n[ \t]*(ASCII|BINARY)[ \t]*\r?\n", re.IGNORECASE)
_POINTS = re.compile(rb"(?m)^[ \t]*POINTS[ \t]+(\d+)[ \t]+(\w+)[ \t]*\r?\n")
#: The coordinate types written back, by the name the file gives them.
_TYPES = {b"float": "f4", b"double": "f8"}


def _points(data: bytes) -> tuple[bool, re.Match[bytes]] | None:
    """Whether the file is binary, and its ``POINTS`` line; None when it has none."""
    head = _HEAD.match(data)
    if head is None:
        return None
    m = _POINTS.search(data, head.end())
    if m is None:
        return None
    return head[1].upper() == b"BINARY", m


def vtk_point_count(data: bytes) -> int | None:
    r"""The count on a legacy VTK file's ``POINTS`` line, or None.

    Examples
    --------
    >>> vtk_point_count(b"# vtk DataFile Version 4.2\ntitle\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 float\n")
    3
    >>> vtk_point_count(b"<VTKFile>") is None
    True
    """
    found = _points(data)
    return None if found is None else int(found[1][1])


def patch_vtk(data: bytes, V: np.ndarray) -> bytes:
    r"""A legacy VTK file with its ``POINTS`` values replaced by ``V``.

    Parameters
    ----------
    data : bytes
        The file as read (ASCII or binary, version 4.2 or 5.1).
    V : (n, 3) float array
        New positions, in file order.

    Returns
    -------
    bytes
        The same file where only the numbers of changed coordinates differ:
        in ASCII, the tokens of those numbers are rewritten (the block's own
        scientific notation if it has one, else the shortest text that reads
        back) and every separator kept; in binary, the big-endian values are
        overwritten at their offsets. A ``float`` file holds float32: a moved
        coordinate is rounded to it. With ``V`` the positions read, the bytes
        are the file's.

    Raises
    ------
    ValueError
        The file has no ``POINTS`` section, another count of points than
        ``V``, coordinates of another type than ``float`` or ``double``, or
        fewer values than its count (each message says which).

    Examples
    --------
    >>> vtk = b"# vtk DataFile Version 4.2\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 2 double\n0 0 0 1 0 0\n"
    >>> patch_vtk(vtk, np.array([[0, 0, 0], [1.5, 0, 0]])).splitlines()[-1]
    b'0 0 0 1.5 0 0'
    """
    found = _points(data)
    if found is None:
        raise ValueError("it has no POINTS section after a '# vtk DataFile Version' header")
    binary, m = found
    n, kind = int(m[1]), m[2].lower()
    P = np.asarray(V, dtype=np.float64)
    if n != len(P):
        raise ValueError(f"its POINTS section holds {n} points, the mesh {len(P)}")
    dtype = _TYPES.get(kind)
    if dtype is None:
        raise ValueError(f"its POINTS are of type {kind.decode(errors='replace')!r}; coordinates are written back "
                         "in float or double files")
    if not binary:
        return patch_numbers(data, m.end(), 3 * n, P, dtype)
    at, size = m.end(), 3 * n * np.dtype(dtype).itemsize
    if len(data) < at + size:
        raise ValueError(f"its binary POINTS section is cut short ({len(data) - at} of {size} bytes)")
    old = np.frombuffer(data, ">" + dtype, 3 * n, at)
    new = P.ravel().astype(">" + dtype)
    moved = changed(old, new)
    if not moved.any():
        return data
    out = old.copy()
    out[moved] = new[moved]
    return data[:at] + out.tobytes() + data[at + size:]
