"""VTK XML unstructured grids written back with a re-encoded ``<Points>`` array and nothing else changed."""

from __future__ import annotations

import re

import numpy as np

__all__ = ["patch_vtu"]

_POINTS = re.compile(rb"(<Points[^>]*>\s*<DataArray\b[^>]*>)(.*?)(</DataArray>)", re.DOTALL)
_ATTR = re.compile(rb'(\w+)\s*=\s*"([^"]*)"')


def patch_vtu(data: bytes, V: np.ndarray) -> bytes | None:
    """A VTK XML unstructured grid with its ``<Points>`` array re-encoded from ``V``.

    Everything outside that one array (cells, point and cell data, field data,
    comments) is copied byte for byte, and in ASCII arrays so are the values of
    unmoved points; the array keeps its type (Float32 or
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
    little = file_attrs.get(b"byte_order", b"LittleEndian") == b"LittleEndian"
    if attrs.get(b"NumberOfComponents", b"3") != b"3" or not little:
        return None
    dtype = {b"Float32": "<f4", b"Float64": "<f8"}.get(attrs.get(b"type", b""))
    if dtype is None:
        return None
    arr = np.ascontiguousarray(V, dtype=dtype)
    fmt = attrs.get(b"format", b"ascii")
    body = m.group(2)
    lead = body[: len(body) - len(body.lstrip())]
    trail = body[len(body.rstrip()):]
    if fmt == b"ascii":
        spans = [t.span() for t in re.finditer(rb"\S+", body)]
        if len(spans) != arr.size:
            return None
        old = np.array([float(body[a:b]) for a, b in spans], dtype=dtype).reshape(arr.shape)
        parts, last = [], 0
        for row in np.flatnonzero((old != arr).any(1)):  # unmoved points keep their text
            for j in range(3):
                a, b = spans[3 * row + j]
                parts += [body[last:a], repr(float(arr[row, j])).encode()]
                last = b
        return data[: m.start(2)] + b"".join(parts) + body[last:] + data[m.end(2):]
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
