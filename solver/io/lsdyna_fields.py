"""LS-DYNA keyword decks: data cards read as fields, in each input format, and the ``*NODE`` cards.

Fixed-column cards are 8 wide for integers and 16 for reals (small format),
10 and 16 (I10), or 20 and 20 (long); free-format cards separate their fields
by commas. A block's cards are read as a fixed-width table of bytes
(:func:`_card_lines`, :func:`_table`) whose plain fields are converted all at
once (:func:`_fast_ints`, :func:`_fast_reals`); cards with other text (free
format, Fortran numbers such as ``1.5-3``) are read one by one
(:func:`_int`, :func:`_real`), and the first that cannot be read is named
(:func:`_bad_field`). :func:`_node_cards` reads a ``*NODE`` block: ids,
positions and where each card is.
"""

from __future__ import annotations

import math
import re

import numpy as np

from ..errors import UnreadableFileError
from .lsdyna_cards import _Block, _in, _where

#: Field widths per input format: (8-wide integer fields, 16-wide real fields, 10-wide fields).
_WIDTHS = {"small": (8, 16, 10), "i10": (10, 16, 10), "long": (20, 20, 20)}
_COMPACT_EXPONENT = re.compile(rb"^([+-]?(?:\d+\.?\d*|\.\d+))([+-]\d+)$")
_CHUNK = 65536  # card lines turned into a fixed-width table at a time


# ----------------------------------------------------------------------------------------------------------------
# card lines as fixed-width tables


def _card_lines(block: _Block) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Start and end offsets (end before ``\r\n``) and line numbers of a block's data cards.

    Comment (``$``) and blank lines are skipped. Vectorized: a Python object only for lines that end in a blank.
    """
    n = block.end - block.start
    empty = np.zeros(0, np.int64)
    if n <= 0:
        return empty, empty, empty
    arr = np.frombuffer(block.data, np.uint8, count=n, offset=block.start)
    nl = np.flatnonzero(arr == 10)
    starts = np.concatenate(([0], nl + 1)).astype(np.int64)
    ends = np.concatenate((nl, [n])).astype(np.int64)
    if starts[-1] == n:  # nothing after the last line end
        starts, ends = starts[:-1], ends[:-1]
    if not len(starts):
        return empty, empty, empty
    numbers = block.line + 1 + np.arange(len(starts), dtype=np.int64)
    ends = ends - ((ends > starts) & (arr[np.maximum(ends - 1, 0)] == 13))
    tail = arr[np.maximum(ends - 1, 0)]
    keep = (ends > starts) & (arr[starts] != ord("$"))
    maybe_blank = np.flatnonzero(keep & ((tail == 32) | (tail == 9)))  # ends in a blank: look at the whole line
    for k in maybe_blank.tolist():
        keep[k] = bool(block.data[block.start + starts[k]:block.start + ends[k]].strip())
    return starts[keep] + block.start, ends[keep] + block.start, numbers[keep]


def _table(data: bytes, starts: np.ndarray, ends: np.ndarray, width: int) -> np.ndarray:
    """(k, width) uint8: the first ``width`` columns of each line, blank-padded (a view where lines are alike)."""
    arr = np.frombuffer(data, np.uint8)
    k = len(starts)
    if k > 1:
        step = int(starts[1] - starts[0])
        if (step > width and int(starts[0]) + step * k <= len(arr) and (np.diff(starts) == step).all()
                and int((ends - starts).min()) >= width):
            return arr[int(starts[0]):int(starts[0]) + step * k].reshape(k, step)[:, :width]
    out = np.full((k, width), 32, np.uint8)
    cols = np.arange(width, dtype=np.int64)
    for a in range(0, k, _CHUNK):
        s, e = starts[a:a + _CHUNK, None], ends[a:a + _CHUNK, None]
        idx = s + cols
        out[a:a + _CHUNK] = np.where(idx < e, arr[np.minimum(idx, len(arr) - 1)], 32)
    return out


def _fields(table: np.ndarray, col: int, width: int, count: int) -> np.ndarray:
    """(k, count) fixed-width text fields (``S<width>``) from ``col``; a blank field reads as ``0``."""
    sub = np.array(table[:, col:col + width * count]).reshape(len(table), count, width)
    blank = (sub == 32).all(axis=2)
    sub[blank, width - 1] = ord("0")
    return sub.view(f"S{width}").reshape(len(table), count)


def _fast_ints(table: np.ndarray, col: int, width: int, count: int,
               out: np.ndarray | None = None) -> np.ndarray | None:
    """Integer fields (blank: 0), or None where one is not a plain integer (the slow path then names it).

    Right-aligned fields of digits are read digit by digit (one matrix product per chunk); others, signed
    ones included, through numpy's text conversion. ``out``, (k, count) int64, receives them if given.
    """
    if out is None:
        out = np.empty((len(table), count), np.int64)
    rows = max(1, _CHUNK * 8 // max(count, 1))
    weights = 10.0 ** np.arange(width - 1, -1, -1)
    for a in range(0, len(table), rows):
        c = table[a:a + rows, col:col + width * count].reshape(-1, count, width)
        d = c - np.uint8(48)
        digit = d < 10  # uint8 arithmetic wraps below "0"
        if (width > 15 or not (digit | (c == 32)).all()
                or (digit[..., :-1] > digit[..., 1:]).any()):  # a blank after a digit: not right-aligned digits
            try:
                out[a:a + rows] = _fields(table[a:a + rows], col, width, count).astype(np.int64)
            except (ValueError, OverflowError):
                return None
            continue
        if width == 8:
            out[a:a + rows] = _eight_digits(np.where(digit, c, np.uint8(48)))
        else:
            d[~digit] = 0
            out[a:a + rows] = (d.astype(np.float64) @ weights).astype(np.int64)
    return out


def _eight_digits(c: np.ndarray) -> np.ndarray:
    """(..., 8) uint8 ASCII digits (most significant first) as int64, eight at a time in one 64-bit word.

    Examples
    --------
    >>> _eight_digits(np.frombuffer(b"0000012399999999", np.uint8).reshape(2, 8)).tolist()
    [123, 99999999]
    """
    x = np.ascontiguousarray(c, dtype=np.uint8).view("<u8")[..., 0] - np.uint64(0x3030303030303030)
    x = ((x * np.uint64(10)) + (x >> np.uint64(8))) & np.uint64(0x00FF00FF00FF00FF)
    x = ((x * np.uint64(100)) + (x >> np.uint64(16))) & np.uint64(0x0000FFFF0000FFFF)
    x = ((x * np.uint64(10000)) + (x >> np.uint64(32))) & np.uint64(0x00000000FFFFFFFF)
    return x.astype(np.int64)


def _fast_reals(table: np.ndarray, col: int, width: int, count: int) -> np.ndarray | None:
    """Real fields, or None where one is not a plain finite number (Fortran ``1.5-3`` or ``1D0``: the slow path)."""
    try:
        out = _fields(table, col, width, count).astype(np.float64)
    except (ValueError, OverflowError):
        return None
    return out if np.isfinite(out).all() else None


def _plain(block: _Block, table: np.ndarray) -> bool:
    """Whether a block's cards hold only what fixed-format numbers are made of (no tabs, commas, ``_``, ``&``)."""
    body = block.data
    if all(body.find(ch, block.start, block.end) < 0 for ch in (b"\t", b",", b"_", b"&")):
        return True
    allowed = np.zeros(256, bool)
    allowed[[ord(c) for c in " 0123456789+-.eEdD"]] = True
    return bool(allowed[table].all())


def _int(text: bytes) -> int:
    """An integer field (blank: 0)."""
    t = text.strip()
    if not t:
        return 0
    if not t.lstrip(b"+-").isdigit() or len(t) > 19:
        raise ValueError(t)
    return int(t)


def _real(text: bytes) -> float:
    """A real field as LS-DYNA reads it: blank is 0, ``1.5D0`` and Fortran's ``1.5-3`` (1.5e-3) allowed.

    Examples
    --------
    >>> _real(b"  -2.5E+00"), _real(b" 1.5-3"), _real(b"1.0D2"), _real(b"    ")
    (-2.5, 0.0015, 100.0, 0.0)
    """
    t = text.strip()
    if not t:
        return 0.0
    if b"_" in t or not re.fullmatch(rb"[0-9+\-.eEdD]+", t):
        raise ValueError(t)
    t = t.replace(b"d", b"e").replace(b"D", b"e")
    m = _COMPACT_EXPONENT.match(t)
    if m:
        t = m.group(1) + b"e" + m.group(2)
    v = float(t)
    if not math.isfinite(v):
        raise ValueError(t)
    return v


def _free(text: bytes) -> list[bytes]:
    """The fields of a free-format (comma-separated) card."""
    return text.split(b",")


def _bad_field(name: str, block: _Block, line: int, text: bytes, what: str) -> UnreadableFileError:
    shown = text[:100].decode("ascii", "replace")
    hint = " (a *PARAMETER reference: tetmorph reads numbers as written)" if b"&" in text else ""
    if b"\t" in text and b"," not in text:
        hint = " (a tab in a fixed-column card: LS-DYNA reads cards by their columns)"
    code = "bad_node_line" if block.name == "NODE" else "bad_set" if block.name.startswith("SET_") else \
        "bad_element_line"
    return UnreadableFileError(
        f"{name!r}, {_where(block.file, line)} (*{block.name}): {what} cannot be read from {shown!r}{hint}",
        code=code, file=name, line=line, keyword=f"*{block.name}", **_in(block.file))


# ----------------------------------------------------------------------------------------------------------------
# nodes


def _node_cards(block: _Block, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A ``*NODE`` block: ids (k,), positions (k, 3), line starts, line ends and line numbers of its cards."""
    wi, wr, _ = _WIDTHS[block.fmt]
    starts, ends, numbers = _card_lines(block)
    if not len(starts):
        return np.zeros(0, np.int64), np.zeros((0, 3)), starts, ends, numbers
    _check_truncated(block, name, starts, ends, numbers)
    table = _table(block.data, starts, ends, wi + 3 * wr)
    ids = xyz = None
    if _plain(block, table):
        ids = _fast_ints(table, 0, wi, 1)
        xyz = _fast_reals(table, wi, wr, 3)
    if ids is None or xyz is None:
        ids, xyz = _slow_nodes(block, name, starts, ends, numbers)
    ids = ids.reshape(-1)
    bad = np.flatnonzero(ids <= 0)
    if bad.size:
        line = int(numbers[bad[0]])
        raise UnreadableFileError(f"{name!r}, {_where(block.file, line)} (*NODE): node id {int(ids[bad[0]])}; node "
                                  "ids are positive", code="bad_node_line", file=name, line=line,
                                  **_in(block.file))
    return ids, xyz, starts, ends, numbers


def _slow_nodes(block: _Block, name: str, starts: np.ndarray, ends: np.ndarray,
                numbers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Node cards read one by one (free format, Fortran numbers), naming the first one that cannot be read."""
    wi, wr, _ = _WIDTHS[block.fmt]
    ids = np.empty(len(starts), np.int64)
    xyz = np.empty((len(starts), 3))
    for k, (s, e) in enumerate(zip(starts.tolist(), ends.tolist(), strict=True)):
        text = block.data[s:e]
        try:
            if b"," in text:
                f = _free(text) + [b""] * 3
                ids[k], xyz[k] = _int(f[0]), [_real(f[1]), _real(f[2]), _real(f[3])]
            else:
                if b"\t" in text:
                    raise ValueError(text)
                ids[k] = _int(text[:wi])
                xyz[k] = [_real(text[wi + j * wr: wi + (j + 1) * wr]) for j in range(3)]
        except ValueError:
            raise _bad_field(name, block, int(numbers[k]), text, "a node id and three coordinates") from None
    return ids, xyz


def _check_truncated(block: _Block, name: str, starts: np.ndarray, ends: np.ndarray, numbers: np.ndarray) -> None:
    """Refuse a file whose last card, without a line end, is shorter than the card before it: a file cut short.

    Fixed-column cards are compared by their length, free-format ones by their number of fields.
    """
    data = block.data
    if block.end != len(data) or data.endswith((b"\n", b"\r")) or len(starts) < 2 or ends[-1] != len(data):
        return
    last, before = data[starts[-1]:ends[-1]].rstrip(), data[starts[-2]:ends[-2]].rstrip()
    if b"," in last or b"," in before:
        short, what = last.count(b",") < before.count(b","), "fields"
        sizes = (last.count(b",") + 1, before.count(b",") + 1)
    else:
        short, what = len(last) < len(before), "characters"
        sizes = (len(last), len(before))
    if short:
        line = int(numbers[-1])
        raise UnreadableFileError(
            f"{name!r} ends in the middle of a card ({_where(block.file, line)}, *{block.name}: {sizes[0]} {what} "
            f"where the card before has {sizes[1]}, and no line end): the file is truncated",
            code="truncated_file", file=name, line=line, **_in(block.file))
