"""VTK XML unstructured grids written back with new ``<Points>`` values and nothing else changed.

VTK and meshio write the points array in one of five ways: ASCII text,
base64 ``binary`` text inside the ``<DataArray>``, or an offset into the
``<AppendedData>`` block (raw bytes or base64), each binary one plain or
compressed in blocks (zlib or LZMA) behind a header of block sizes.
:func:`patch_vtu` decodes the array, compares it with the new positions at
the array's precision, and writes back only what changed: the tokens of
changed ASCII numbers, the changed bytes of a plain binary array (the same
length, so nothing moves), or, in a compressed array, the blocks that hold a
changed value, compressed again at the level the file was written with; when
that changes the length of appended data, the ``offset`` of each later array
is updated. Every other byte (the ``<InformationKey>`` elements VTK writes
inside the points array, ranges, cells, point and cell data, field data,
comments) is kept, and a file whose points did not change comes back as it
was read, whatever its encoding.
"""

from __future__ import annotations

import base64
import lzma
import re
import zlib
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .number_tokens import changed, patch_numbers

__all__ = ["patch_vtu"]

_ATTR = re.compile(rb'([\w:]+)\s*=\s*"([^"]*)"')
_OFFSET = re.compile(rb'(\boffset\s*=\s*")(\d+)(" *)')
_COMPRESSORS = ("vtkZLibDataCompressor", "vtkLZMADataCompressor")


def _tag(data: bytes, name: bytes, start: int = 0) -> tuple[int, int, dict[bytes, bytes]] | None:
    """Start and end of the first ``<name ...>`` tag at or after ``start``, and its attributes."""
    m = re.compile(rb"<" + name + rb"\b").search(data, start)
    if m is None:
        return None
    end = data.find(b">", m.end())
    if end < 0:
        return None
    return m.start(), end + 1, dict(_ATTR.findall(data, m.end(), end))


@dataclass
class _Array:
    """One encoded binary array: where it lies, its header and its (compressed) content."""

    start: int
    end: int
    header: np.ndarray
    blocks: list[bytes]
    b64: bool
    together: bool = False  # base64: header and data encoded as one string

    def encode(self) -> bytes:
        """The array's bytes as the file holds them (base64 text or raw)."""
        head, body = self.header.tobytes(), b"".join(self.blocks)
        if not self.b64:
            return head + body
        if self.together:
            return base64.b64encode(head + body)
        return base64.b64encode(head) + base64.b64encode(body)


def _b64(data: bytes, at: int, nbytes: int) -> tuple[bytes, int]:
    """``nbytes`` decoded from the base64 string at ``at`` (encoded alone), and where it ends."""
    chars = 4 * -(-nbytes // 3)
    try:
        out = base64.b64decode(data[at:at + chars], validate=True)
    except ValueError:
        raise ValueError("its points array is not valid base64") from None
    if len(out) != nbytes:
        raise ValueError("its points array is shorter than its header says")
    return out, at + chars


def _first_word(data: bytes, at: int, word: np.dtype) -> int:
    """The first header integer of the base64 array at ``at`` (encoded alone or with what follows)."""
    chars = 4 * -(-word.itemsize // 3)
    try:
        first = base64.b64decode(data[at:at + chars], validate=True)[:word.itemsize]
    except ValueError:
        raise ValueError("its points array is not valid base64") from None
    if len(first) < word.itemsize:
        raise ValueError("its points array is cut short")
    return int(np.frombuffer(first, word)[0])


def _read_array(data: bytes, at: int, b64: bool, word: np.dtype, compressed: bool) -> _Array:
    """The binary array encoded at ``data[at:]`` (``word``: the header's integer type)."""
    w = word.itemsize
    if not compressed:
        if not b64:
            if len(data) < at + w:
                raise ValueError("its appended points data is cut short")
            size = int(np.frombuffer(data, word, 1, at)[0])
            if len(data) < at + w + size:
                raise ValueError("its appended points data is cut short")
            return _Array(at, at + w + size, np.frombuffer(data, word, 1, at).copy(),
                          [data[at + w:at + w + size]], False)
        size = _first_word(data, at, word)
        together = data[at + 4 * -(-w // 3) - 1:at + 4 * -(-w // 3)] != b"="
        if together:
            both, end = _b64(data, at, w + size)
            return _Array(at, end, np.frombuffer(both[:w], word).copy(), [both[w:]], True, True)
        head, mid = _b64(data, at, w)
        body, end = _b64(data, mid, size)
        return _Array(at, end, np.frombuffer(head, word).copy(), [body], True)
    if b64:
        nb = _first_word(data, at, word)
        head, mid = _b64(data, at, (3 + nb) * w)
    else:
        if len(data) < at + w:
            raise ValueError("its appended points data is cut short")
        nb = int(np.frombuffer(data, word, 1, at)[0])
        head, mid = data[at:at + (3 + nb) * w], at + (3 + nb) * w
    header = np.frombuffer(head, word).copy()
    if header.size != 3 + nb:
        raise ValueError("its compressed points header is cut short")
    sizes = header[3:].astype(np.int64)
    if b64:
        body, end = _b64(data, mid, int(sizes.sum()))
    else:
        body, end = data[mid:mid + int(sizes.sum())], mid + int(sizes.sum())
        if len(body) != int(sizes.sum()):
            raise ValueError("its appended points data is cut short")
    cuts = np.r_[0, np.cumsum(sizes)].tolist()
    return _Array(at, end, header, [body[a:b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)], b64)


def _decompress(compressor: str, block: bytes) -> bytes:
    """One block of a compressed array, decompressed."""
    try:
        return zlib.decompress(block) if compressor == "vtkZLibDataCompressor" else lzma.decompress(block)
    except (zlib.error, lzma.LZMAError) as e:
        raise ValueError(f"its compressed points data does not decompress ({e})") from None


def _compressor(compressor: str, sample: bytes, plain: bytes) -> Callable[[bytes], bytes]:
    """A function that compresses as the file's writer did: ``plain`` (the first block) gives ``sample``.

    The level is found by compressing the first block again (VTK writes
    level 5, zlib and meshio 6); where none gives the same bytes, the level
    the zlib header announces, or LZMA's default, with the file's check.
    """
    if compressor == "vtkZLibDataCompressor":
        for level in (5, 6, 1, 2, 3, 4, 7, 8, 9, 0):
            if zlib.compress(plain, level) == sample:
                break
        else:
            level = {0: 1, 1: 5, 2: 6, 3: 9}[sample[1] >> 6] if len(sample) > 1 else 6
        return lambda block: zlib.compress(block, level)
    check = sample[7] & 0x0F if len(sample) > 7 else lzma.CHECK_CRC64  # the xz stream header's check
    for preset in (6, 5, 0, 1, 2, 3, 4, 7, 8, 9):
        if lzma.compress(plain, preset=preset, check=check) == sample:
            break
    else:
        preset = 6
    return lambda block: lzma.compress(block, preset=preset, check=check)


def patch_vtu(data: bytes, V: np.ndarray) -> bytes:
    """A VTK XML unstructured grid with its ``<Points>`` array replaced by ``V``.

    Parameters
    ----------
    data : bytes
        The file as read (one piece; ASCII, binary or appended points; plain,
        zlib or LZMA; UInt32 or UInt64 headers; either byte order).
    V : (n, 3) float array
        New positions, in file order.

    Returns
    -------
    bytes
        The same file where only the points array differs, and in it only
        what the changed values need (see the module's description); a
        Float32 array holds float32, so a moved coordinate is rounded to it.
        With ``V`` the positions read, the bytes are the file's.

    Raises
    ------
    ValueError
        What makes the array impossible to write back, named: no ``<Points>``,
        several pieces, another count of points than ``V``, a type other than
        Float32 or Float64, an unknown format or compressor (LZ4), a damaged
        array.
    """
    P = np.asarray(V, dtype=np.float64)
    root = _tag(data, b"VTKFile")
    points = _tag(data, b"Points")
    if root is None or points is None:
        raise ValueError("it has no <Points> element")
    xml_end = data.find(b"<AppendedData")
    if data.find(b"<Points", points[1], xml_end if xml_end >= 0 else len(data)) >= 0:
        raise ValueError("it holds several pieces, each with its own <Points>")
    array = _tag(data, b"DataArray", points[1])
    close = data.find(b"</Points", points[1])
    if array is None or 0 <= close < array[0]:
        raise ValueError("its <Points> element holds no <DataArray>")
    file_attrs, attrs = root[2], array[2]
    order = "<" if file_attrs.get(b"byte_order", b"LittleEndian") == b"LittleEndian" else ">"
    kind = attrs.get(b"type", b"").decode(errors="replace")
    if kind not in ("Float32", "Float64"):
        raise ValueError(f"its points are of type {kind!r}; coordinates are written back as Float32 or Float64")
    if attrs.get(b"NumberOfComponents", b"1") != b"3":
        raise ValueError("its points array does not have 3 components")
    dtype = np.dtype(order + ("f4" if kind == "Float32" else "f8"))
    fmt = attrs.get(b"format", b"ascii")
    body = array[1]  # where the array's text starts
    if fmt == b"ascii":
        stop = data.find(b"<", body)
        return patch_numbers(data, body, P.size, P, dtype.newbyteorder("="), end=stop if stop >= 0 else len(data))
    word = np.dtype(order + {b"UInt32": "u4", b"UInt64": "u8"}.get(file_attrs.get(b"header_type", b"UInt32"), "?"))
    compressor = file_attrs.get(b"compressor", b"").decode(errors="replace") or None
    if compressor is not None and compressor not in _COMPRESSORS:
        raise ValueError(f"its arrays are compressed with {compressor}, which tetmorph does not decode")
    if fmt == b"binary":
        at = body + len(data[body:]) - len(data[body:].lstrip())
        found = _read_array(data, at, True, word, compressor is not None)
        appended = None
    elif fmt == b"appended":
        appended = _tag(data, b"AppendedData")
        if appended is None or b"offset" not in attrs:
            raise ValueError("its points array is appended but the file has no <AppendedData> or no offset")
        underscore = data.find(b"_", appended[1])
        raw = appended[2].get(b"encoding", b"raw") == b"raw"
        found = _read_array(data, underscore + 1 + int(attrs[b"offset"]), not raw, word, compressor is not None)
    else:
        raise ValueError(f"its points array has format {fmt.decode(errors='replace')!r}")
    return _write_array(data, found, P, dtype, compressor, appended, attrs)


def _write_array(data: bytes, found: _Array, P: np.ndarray, dtype: np.dtype, compressor: str | None,
                 appended: tuple[int, int, dict[bytes, bytes]] | None, attrs: dict[bytes, bytes]) -> bytes:
    """The file with the binary points array ``found`` holding ``P`` where its values changed."""
    plain = [_decompress(compressor, b) for b in found.blocks] if compressor else found.blocks
    values = b"".join(plain)
    nbytes = P.size * dtype.itemsize
    if len(values) < nbytes:
        raise ValueError(f"its points array holds {len(values) // dtype.itemsize} numbers, the mesh {P.size} "
                         "coordinates")
    old = np.frombuffer(values, dtype, P.size)
    new = P.ravel().astype(dtype)
    moved = changed(old, new)
    if not moved.any():
        return data
    out = old.copy()
    out[moved] = new[moved]
    fresh = out.tobytes() + values[nbytes:]
    if compressor is None:
        found.blocks = [fresh]
    else:
        size = int(found.header[1]) or len(fresh)
        compress = _compressor(compressor, found.blocks[0], plain[0])
        for k in range(len(plain)):
            part = fresh[k * size:(k + 1) * size]
            if part != plain[k]:  # blocks without a changed value keep their compressed bytes
                found.blocks[k] = compress(part)
        found.header[3:] = [len(b) for b in found.blocks]
    text = found.encode()
    patched = data[:found.start] + text + data[found.end:]
    shift = len(text) - (found.end - found.start)
    if not shift or appended is None:
        return patched
    return _shift_offsets(patched, appended[0], int(attrs[b"offset"]), shift)


def _shift_offsets(data: bytes, stop: int, after: int, shift: int) -> bytes:
    """Appended arrays past offset ``after`` moved by ``shift`` bytes: their ``offset`` attributes updated.

    The attributes lie before ``stop`` (the ``<AppendedData>`` tag); VTK pads
    them with blanks, which absorb the change of width where they can.
    """

    def move(m: re.Match[bytes]) -> bytes:
        offset = int(m[2])
        if offset <= after:
            return m[0]
        digits = str(offset + shift).encode()
        wider = len(digits) - len(m[2])
        pad = m[3][1:]
        pad = pad[:max(0, len(pad) - wider)] if wider > 0 else pad + b" " * -wider
        return m[1] + digits + b'"' + pad

    head = re.sub(rb"<DataArray\b[^>]*>", lambda t: _OFFSET.sub(move, t[0]), data[:stop])
    return head + data[stop:]
