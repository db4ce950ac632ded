"""The compact binary body of a deform result (HTTP and WebSocket).

Layout, all little-endian::

    offset 0   4 bytes    magic b"TMF1"
    offset 4   uint32     H, length of the JSON header in bytes
    offset 8   H bytes    UTF-8 JSON header:
                            {"kind": "positions" | "displacements",
                             "dtype": "float32" | "float64",
                             "shape": [n, 3], "report": {...}, ...}
               padding    zero bytes up to the next multiple of 8
    offset D   n*3 values the array in C order (row i = vertex i, file order)

``D = 8 + H`` rounded up to a multiple of 8, so the array can be mapped
without copying: ``np.frombuffer(body, dtype, offset=D)``.

Examples
--------
>>> import numpy as np
>>> body = encode_frame(np.eye(3), {"report": {"inverted_elements": 0}})
>>> X, header = decode_frame(body)
>>> X.tolist() == np.eye(3).tolist(), header["report"]
(True, {'inverted_elements': 0})
"""

from __future__ import annotations

import json
import struct
from typing import Any

import numpy as np

__all__ = ["MAGIC", "MEDIA_TYPE", "encode_frame", "decode_frame", "FrameError", "encode_bundle",
           "decode_bundle"]

MAGIC = b"TMF1"
MEDIA_TYPE = "application/octet-stream"
_DTYPES = {"float32": "<f4", "float64": "<f8"}


class FrameError(ValueError):
    """A byte string is not a tetmorph binary frame."""


def encode_frame(X: np.ndarray, header: dict[str, Any], dtype: str = "float64",
                 kind: str = "positions") -> bytes:
    """Pack an (n, 3) array and a JSON header into one frame.

    Parameters
    ----------
    X : (n, 3) float array
    header : dict
        Extra header fields (the REPORT under ``"report"``).
    dtype : {"float32", "float64"}
    kind : {"positions", "displacements"}

    Returns
    -------
    bytes
    """
    if dtype not in _DTYPES:
        raise ValueError(f"dtype must be one of {sorted(_DTYPES)}, got {dtype!r}")
    arr = np.ascontiguousarray(X, dtype=_DTYPES[dtype])
    head = dict(header, kind=kind, dtype=dtype, shape=list(arr.shape))
    hb = json.dumps(head, separators=(",", ":")).encode()
    start = 8 + len(hb)
    pad = (-start) % 8
    return b"".join((MAGIC, struct.pack("<I", len(hb)), hb, b"\0" * pad, arr.tobytes()))


def decode_frame(body: bytes) -> tuple[np.ndarray, dict[str, Any]]:
    """Unpack a frame into the array and its header.

    Raises
    ------
    FrameError
        Wrong magic, truncated header or data.
    """
    if len(body) < 8 or body[:4] != MAGIC:
        raise FrameError("not a tetmorph frame (bad magic)")
    (h,) = struct.unpack("<I", body[4:8])
    if 8 + h > len(body):
        raise FrameError(f"header of {h} bytes does not fit in {len(body)} bytes")
    head = json.loads(body[8:8 + h].decode())
    start = 8 + h + ((-(8 + h)) % 8)
    dt = np.dtype(_DTYPES[head["dtype"]])
    shape = tuple(head["shape"])
    count = int(np.prod(shape))
    if start + count * dt.itemsize != len(body):
        raise FrameError(f"expected {count} values of {head['dtype']} after offset {start}, "
                         f"got {len(body) - start} bytes")
    return np.frombuffer(body, dt, count=count, offset=start).reshape(shape), head


BUNDLE_MAGIC = b"TMG1"
_BUNDLE_DTYPES = {"float32": "<f4", "float64": "<f8", "uint32": "<u4", "int32": "<i4", "uint8": "u1"}


def encode_bundle(arrays: dict[str, np.ndarray], header: dict[str, Any]) -> bytes:
    """Pack several named arrays and a JSON header (mesh geometry for the editor).

    Layout: ``b"TMG1"``, uint32 ``H``, ``H`` bytes of JSON header, zero padding to
    a multiple of 8, then each array in C order, each starting at a multiple of 8.
    The header's ``"arrays"`` lists ``{"name", "dtype", "shape", "offset"}`` with
    byte offsets from the start of the body, so a browser can view each one with
    ``new Float32Array(buffer, offset, length)`` without copying.

    Examples
    --------
    >>> body = encode_bundle({"V": np.zeros((2, 3), np.float32)}, {"n": 2})
    >>> arrays, head = decode_bundle(body)
    >>> arrays["V"].shape, head["n"]
    ((2, 3), 2)
    """
    entries, blobs = [], []
    for name, a in arrays.items():
        dt = next((k for k, v in _BUNDLE_DTYPES.items() if np.dtype(v) == np.dtype(a.dtype)), None)
        if dt is None:
            raise ValueError(f"array {name!r}: dtype {a.dtype} is not one of {sorted(_BUNDLE_DTYPES)}")
        entries.append({"name": name, "dtype": dt, "shape": list(a.shape)})
        blobs.append(np.ascontiguousarray(a, dtype=_BUNDLE_DTYPES[dt]).tobytes())
    # offsets depend on the header length, which depends on the offsets: iterate to a fixed point
    offsets = [0] * len(blobs)
    for _ in range(4):
        hb = json.dumps({**header, "arrays": [dict(e, offset=o) for e, o in zip(entries, offsets, strict=True)]},
                        separators=(",", ":")).encode()
        pos = 8 + len(hb) + ((-(8 + len(hb))) % 8)
        new = []
        for b in blobs:
            new.append(pos)
            pos += len(b) + ((-len(b)) % 8)
        if new == offsets:
            break
        offsets = new
    out = bytearray(BUNDLE_MAGIC + struct.pack("<I", len(hb)) + hb)
    for o, b in zip(offsets, blobs, strict=True):
        out += b"\0" * (o - len(out))
        out += b
    return bytes(out)


def decode_bundle(body: bytes) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Unpack :func:`encode_bundle` output into ``({name: array}, header)``."""
    if len(body) < 8 or body[:4] != BUNDLE_MAGIC:
        raise FrameError("not a tetmorph bundle (bad magic)")
    (h,) = struct.unpack("<I", body[4:8])
    head = json.loads(body[8:8 + h].decode())
    arrays = {}
    for e in head["arrays"]:
        dt = np.dtype(_BUNDLE_DTYPES[e["dtype"]])
        count = int(np.prod(e["shape"])) if e["shape"] else 0
        arrays[e["name"]] = np.frombuffer(body, dt, count, e["offset"]).reshape(e["shape"])
    return arrays, head
