"""VTK XML unstructured grids (``.vtu``): the format's entry in the registry, its sniffer, size check and diagnosis.

meshio reads a VTU file; :func:`solver.io.patch_vtu.patch_vtu` writes it back
with new ``<Points>`` values. A compressed file's arrays can inflate far
beyond its size: before reading, the ``NumberOfPoints`` and ``NumberOfCells``
of its pieces and the sizes its zlib/LZMA block headers declare are held to
the read bounds, and while meshio reads, :func:`expansion_budget` stops the
decompression at the same byte bound, for headers that lie.
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

from ..errors import UnreadableFileError
from .patch_vtu import patch_vtu
from .patchers import Patcher
from .read_bounds import ReadBounds, check_bounds, check_holds, declared_total
from .registry import FileFormat, register_format

__all__ = ["VTU", "sniff", "check_sizes", "diagnose", "expansion_budget"]


def sniff(head: bytes, size: int | None = None) -> bool:
    r"""Whether a file's first bytes are a VTK XML file of an unstructured grid.

    Examples
    --------
    >>> sniff(b'<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid">'), sniff(b'<VTKFile type="PolyData">')
    (True, False)
    """
    return b"<VTKFile" in head[:1024] and b"UnstructuredGrid" in head[:2048]


# ------------------------------------------------------------------ declared sizes


def check_sizes(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    """Refuse the pieces' points and cells, and the bytes compressed arrays expand to, over ``bounds``."""
    check_bounds(name, bounds, declared_total(rb'NumberOfPoints\s*=\s*"(\d+)"', head),
                 declared_total(rb'NumberOfCells\s*=\s*"(\d+)"', head))
    m = re.search(rb'compressor\s*=\s*"(vtkZLibDataCompressor|vtkLZMADataCompressor)"', head)
    if m is None:
        return  # uncompressed data is no larger than the file
    check_bounds(name, bounds, nbytes=_expanded(path, name, head))


def _expanded(path: str, name: str, head: bytes) -> int:
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
    check_holds(name, "compressed blocks", nblocks, item, size)
    if nblocks == 0:
        return 0
    return (nblocks - 1) * block + (last or block)


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

    Block headers are checked before reading (:func:`check_sizes`); this bounds
    what the blocks really expand to when the headers lie.

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


# ------------------------------------------------------------------ failures


def diagnose(path: str, data: bytes, exc: BaseException) -> UnreadableFileError | None:
    """A file without its closing ``</VTKFile>`` tag: ``truncated_file``."""
    if b"</VTKFile>" not in data[-4096:]:
        name = os.path.basename(path)
        return UnreadableFileError(f"{name!r} ends before its closing </VTKFile> tag: the file is truncated",
                                   code="truncated_file", file=name)
    return None


#: The format's entry in :data:`solver.io.registry.FORMATS`.
VTU = register_format(FileFormat(
    name="vtu", title="VTK XML unstructured grid (.vtu)", extensions=(".vtu",),
    sniff=sniff, sniff_order=200, telling=True, signed=True,
    read=None, reading=expansion_budget, check_sizes=check_sizes, diagnose=diagnose,
    patcher=Patcher("vtu", (), ("vtu",), lambda raw, n: b"<VTKFile" in raw[:400], patch_vtu),
    writes=True,
    reads="VTK XML unstructured grids (meshio's reader), ASCII, binary or appended, plain or compressed (zlib, LZMA), "
          "with tetrahedra (linear or quadratic), hexahedra, wedges, pyramids or triangles; 0/1 set:NAME arrays as "
          "sets; the points written back in place in their own encoding",
    refuses="a file without its closing VTKFile tag (truncated_file), declared counts or compressed data over the "
            "read bounds (too_many_points, too_many_cells, too_many_bytes); points stored as integers are not "
            "patched in place (a file_content loss)"))
