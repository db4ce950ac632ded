"""Write an Abaqus deck or an ASCII Gmsh file back with new node coordinates and nothing else changed.

meshio rewrites a whole ``.inp`` file (its own formatting, only the keywords it
knows). A CAE deck carries much more: materials, sections, steps, loads,
comments. :func:`patch_inp` copies the original text byte for byte and only
replaces the three coordinates on each data line of the ``*NODE`` blocks, in the
order meshio numbers the points (the order of appearance).
"""

from __future__ import annotations

import re

import numpy as np

__all__ = ["patch_inp", "node_line_count", "patch_msh", "patch_vtu"]

_KEYWORD = re.compile(rb"^\s*\*")
_NODE = re.compile(rb"^\s*\*\s*node\s*(,|$)", re.IGNORECASE)


def _node_lines(lines: list[bytes]) -> list[int]:
    """Indices of the data lines inside ``*NODE`` blocks (comments ``**`` skipped)."""
    out, inside = [], False
    for k, line in enumerate(lines):
        if line.lstrip().startswith(b"**"):
            continue
        if _KEYWORD.match(line):
            inside = bool(_NODE.match(line.rstrip(b"\r\n")))
            continue
        if inside and line.strip():
            out.append(k)
    return out


def node_line_count(data: bytes) -> int:
    """Number of node data lines in a deck."""
    return len(_node_lines(data.splitlines(keepends=True)))


def patch_inp(data: bytes, V: np.ndarray) -> bytes:
    """The deck ``data`` with the coordinates of its nodes replaced by ``V``.

    Parameters
    ----------
    data : bytes
        The original ``.inp`` file.
    V : (n, 3) float array
        New positions, one row per node data line in order of appearance.

    Returns
    -------
    bytes
        Identical to ``data`` except for the coordinate fields of node lines
        (written with 17 significant digits, so they read back exactly).

    Raises
    ------
    ValueError
        The deck's node lines do not match ``V`` in number, or a node line has
        fewer than three coordinates.

    Examples
    --------
    >>> deck = b"*Heading\\n*NODE\\n1, 0.0, 0.0, 0.0\\n2, 1.0, 0.0, 0.0\\n*ELEMENT, TYPE=T3D2\\n1, 1, 2\\n"
    >>> print(patch_inp(deck, np.array([[0, 0, 0], [2.5, 0, 0]])).decode())
    *Heading
    *NODE
    1, 0, 0, 0
    2, 2.5, 0, 0
    *ELEMENT, TYPE=T3D2
    1, 1, 2
    <BLANKLINE>
    """
    lines = data.splitlines(keepends=True)
    idx = _node_lines(lines)
    if len(idx) != V.shape[0]:
        raise ValueError(f"the deck has {len(idx)} node lines, the positions {V.shape[0]} rows")
    for row, k in enumerate(idx):
        line = lines[k]
        body = line.rstrip(b"\r\n")
        end = line[len(body):]
        fields = body.split(b",")
        if len(fields) < 4:
            raise ValueError(f"line {k + 1}: a node line needs an id and three coordinates: {body[:80]!r}")
        coords = [format(float(x), ".17g").encode() for x in V[row]]
        lead = [f[: len(f) - len(f.lstrip())] for f in fields[1:4]]  # keep each field's leading blanks
        fields[1:4] = [sp + c for sp, c in zip(lead, coords, strict=True)]
        lines[k] = b",".join(fields) + end
    return b"".join(lines)


def patch_msh(data: bytes, V: np.ndarray) -> bytes | None:
    """An ASCII Gmsh 2.2 or 4.1 file with the coordinates of its ``$Nodes`` replaced by ``V``.

    Everything else (elements, physical names, entities, formatting of other
    lines) is copied byte for byte. Nodes are numbered in order of appearance,
    as meshio reads them. Returns ``None`` for files it cannot patch (binary
    Gmsh files, node counts that differ from ``V``); the caller then writes
    through meshio.

    Examples
    --------
    >>> msh = (b"$MeshFormat\\n4.1 0 8\\n$EndMeshFormat\\n$Nodes\\n1 2 1 2\\n3 1 0 2\\n1\\n2\\n"
    ...        b"0 0 0\\n1 0 0\\n$EndNodes\\n")
    >>> patch_msh(msh, np.array([[0, 0, 0], [2, 0, 0.5]])).decode().splitlines()[9]
    '2 0 0.5'
    """
    lines = data.splitlines(keepends=True)
    try:
        k = next(i for i, ln in enumerate(lines) if ln.strip() == b"$MeshFormat")
        version, filetype = lines[k + 1].split()[:2]
        start = next(i for i, ln in enumerate(lines) if ln.strip() == b"$Nodes")
    except (StopIteration, ValueError):
        return None
    if filetype != b"0":
        return None  # binary
    fmt = lambda row: b" ".join(format(float(x), ".17g").encode() for x in row)  # noqa: E731
    out_rows = iter(V)
    count = 0

    def put(i: int, keep_tail: int = 0) -> None:
        nonlocal count
        line = lines[i]
        body = line.rstrip(b"\r\n")
        parts = body.split()
        lines[i] = (b" ".join(parts[:keep_tail]) + (b" " if keep_tail else b"") + fmt(next(out_rows))
                    + (b" " + b" ".join(parts[keep_tail + 3:]) if len(parts) > keep_tail + 3 else b"")
                    + line[len(body):])
        count += 1

    try:
        if version.startswith(b"2"):
            n = int(lines[start + 1])
            for i in range(start + 2, start + 2 + n):
                put(i, keep_tail=1)  # "tag x y z"
        elif version.startswith(b"4"):
            blocks = int(lines[start + 1].split()[0])
            i = start + 2
            for _ in range(blocks):
                head = lines[i].split()
                parametric, nb = int(head[2]), int(head[3])
                i += 1 + nb  # the block's node tags
                for j in range(i, i + nb):
                    if parametric:
                        return None
                    put(j)  # "x y z"
                i += nb
        else:
            return None
    except (StopIteration, ValueError, IndexError):
        return None
    if count != V.shape[0]:
        return None
    return b"".join(lines)


_POINTS = re.compile(rb"(<Points[^>]*>\s*<DataArray\b[^>]*>)(.*?)(</DataArray>)", re.DOTALL)
_ATTR = re.compile(rb'(\w+)\s*=\s*"([^"]*)"')


def patch_vtu(data: bytes, V: np.ndarray) -> bytes | None:
    """A VTK XML unstructured grid with its ``<Points>`` array re-encoded from ``V``.

    Everything outside that one array (cells, point and cell data, field data,
    comments) is copied byte for byte; the array keeps its type (Float32 or
    Float64) and encoding (ascii, or base64 binary with or without zlib
    compression, UInt32 or UInt64 headers). Returns ``None`` for what it does
    not handle (appended data, other compressors); the caller writes through
    meshio then.
    """
    import base64
    import zlib

    m = _POINTS.search(data)
    if m is None:
        return None
    head = data[: data.find(b">", data.find(b"<VTKFile")) + 1]
    file_attrs = dict(_ATTR.findall(head))
    attrs = dict(_ATTR.findall(m.group(1)))
    if attrs.get(b"NumberOfComponents", b"3") != b"3" or file_attrs.get(b"byte_order", b"LittleEndian") != b"LittleEndian":
        return None
    dtype = {b"Float32": "<f4", b"Float64": "<f8"}.get(attrs.get(b"type"))
    if dtype is None:
        return None
    arr = np.ascontiguousarray(V, dtype=dtype)
    fmt = attrs.get(b"format", b"ascii")
    body = m.group(2)
    lead = body[: len(body) - len(body.lstrip())]
    trail = body[len(body.rstrip()):]
    if fmt == b"ascii":
        text = b" ".join(repr(float(x)).encode() for x in arr.ravel())
    elif fmt == b"binary":
        hdr = {b"UInt32": "<u4", b"UInt64": "<u8"}.get(file_attrs.get(b"header_type", b"UInt32"))
        comp = file_attrs.get(b"compressor")
        raw = arr.tobytes()
        if hdr is None:
            return None
        if comp is None:
            text = base64.b64encode(np.array([len(raw)], hdr).tobytes() + raw)
        elif comp == b"vtkZLibDataCompressor":
            bs = 32768
            blocks = [raw[i:i + bs] for i in range(0, len(raw), bs)] or [b""]
            packed = [zlib.compress(b) for b in blocks]
            last = len(blocks[-1]) if len(blocks[-1]) < bs else 0
            header = np.array([len(blocks), bs, last, *map(len, packed)], hdr).tobytes()
            text = base64.b64encode(header) + base64.b64encode(b"".join(packed))
        else:
            return None
    else:
        return None
    return data[: m.start(2)] + lead + text + trail + data[m.end(2):]
