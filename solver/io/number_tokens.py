"""Numbers in a text file, replaced where they changed and nowhere else.

The in-place writers of text formats (legacy VTK, Medit, ASCII VTU arrays)
hold a block of whitespace-separated numbers: :func:`token_spans` finds them
without splitting the file into lines, :func:`read_numbers` reads them,
:func:`changed` tells which differ from the new values at the file's
precision, and :func:`splice` writes new text for those tokens only, every
separator and every other token kept byte for byte.
"""

from __future__ import annotations

import re
import warnings

import numpy as np

__all__ = ["token_spans", "read_numbers", "changed", "number_style", "number_text", "splice", "patch_numbers"]

#: Each byte as a one-byte string (the separators between numbers, looked up at once).
_BYTES = np.array([bytes([b]) for b in range(256)], dtype=object)
_SCIENTIFIC = re.compile(rb"[-+]?\d\.(\d+)([eE])[-+](\d+)\Z")


def token_spans(data: bytes, start: int, count: int | None = None, end: int | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    r"""Start and end offsets of the whitespace-separated tokens of ``data[start:end]``.

    Parameters
    ----------
    data : bytes
    start : int
    count : int, optional
        Only the first ``count`` tokens; a ValueError if there are fewer.
    end : int, optional
        Where the text stops; defaults to the end of ``data``.

    Returns
    -------
    starts, ends : int64 arrays
        Offsets into ``data``: token ``k`` is ``data[starts[k]:ends[k]]``.

    Examples
    --------
    >>> s, e = token_spans(b"POINTS\n1 2.5\t-3 \n4", 7)
    >>> s.tolist(), e.tolist()
    ([7, 9, 13, 17], [8, 12, 15, 18])
    """
    stop = len(data) if end is None else end
    window = stop - start
    if count is not None:  # enough for ``count`` tokens as wide as the first ones, and a margin
        sample = data[start:min(stop, start + 4096)]
        width = len(sample) / max(1, len(sample.split()))
        window = min(window, max(4096, int(1.25 * width * count) + 64))
    while True:
        hi = start + window
        blank = np.ones(window + 2, dtype=bool)  # a blank on either side: every token has both edges
        np.less_equal(np.frombuffer(data, np.uint8, window, start), 32, out=blank[1:-1])
        edges = np.flatnonzero(blank[1:] != blank[:-1])
        starts, ends = edges[0::2], edges[1::2]
        if hi < stop and not blank[-2]:  # the last token may go on past the window
            starts, ends = starts[:-1], ends[:-1]
        if count is None or len(starts) >= count or hi >= stop:
            break
        window = min(stop - start, 2 * window)
    if count is not None:
        if len(starts) < count:
            raise ValueError(f"{len(starts)} numbers where {count} are expected")
        starts, ends = starts[:count], ends[:count]
    return starts + start, ends + start


def read_numbers(data: bytes, starts: np.ndarray, ends: np.ndarray, dtype: str | np.dtype) -> np.ndarray:
    """The tokens as numbers of ``dtype`` (parsed as float64, then rounded, as numpy reads text).

    Raises
    ------
    ValueError
        A token is not a number.
    """
    if not len(starts):
        return np.zeros(0, dtype)
    text = data[starts[0]:ends[-1]]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:  # numpy's text parser, as meshio reads these files
            values = np.fromstring(text, dtype=np.float64, sep=" ")
        except (ValueError, DeprecationWarning):
            values = np.zeros(0)
    if values.size != len(starts):  # a token that is not a number, or blanks numpy does not skip: name it
        words = text.split()
        if len(words) != len(starts):
            raise ValueError("the numbers are separated by other characters than blanks")
        try:
            values = np.array(words, dtype=np.float64)
        except ValueError as e:
            raise ValueError(f"a coordinate is not a number ({e})") from None
    return values.astype(dtype)


def changed(old: np.ndarray, new: np.ndarray) -> np.ndarray:
    """Where ``new`` differs from ``old`` (NaN equal to NaN, -0.0 to 0.0).

    Examples
    --------
    >>> changed(np.array([0.0, np.nan, 1.0]), np.array([-0.0, np.nan, 2.0])).tolist()
    [False, False, True]
    """
    return ~((old == new) | (np.isnan(old) & np.isnan(new)))


def number_style(data: bytes, starts: np.ndarray, ends: np.ndarray, sample: int = 64
                 ) -> tuple[int, bytes, int] | None:
    """The notation of a block written in one scientific format (``%.16e``).

    Returns
    -------
    (fraction digits, exponent letter, exponent digits) or None
        None when the first ``sample`` tokens do not all share one scientific
        notation (shortest round-trip text is written then).

    Examples
    --------
    >>> text = b"1.5000000000000000e+00 -2.0000000000000000e-01"
    >>> number_style(text, *token_spans(text, 0))
    (16, b'e', 2)
    >>> number_style(b"1.5 2", *token_spans(b"1.5 2", 0)) is None
    True
    """
    styles = set()
    for a, b in zip(starts[:sample].tolist(), ends[:sample].tolist(), strict=True):
        m = _SCIENTIFIC.match(data, a, b)
        if m is None:
            return None
        styles.add((len(m[1]), m[2], len(m[3])))
    return styles.pop() if len(styles) == 1 else None


def _shortest(v: np.ndarray, single: bool) -> list[bytes]:
    """The shortest text that reads back as each value (at float32 when ``single``)."""
    if not single:
        return " ".join(map(repr, v.tolist())).encode().split()
    out = np.empty(v.size, dtype=object)
    todo = np.arange(v.size)
    for digits in (6, 7, 8, 9):  # %.9g reads back every float32
        texts = ((b"%." + str(digits).encode() + b"g ") * todo.size % tuple(v[todo].tolist())).split()
        ok = np.array(texts, dtype=np.float64).astype(np.float32) == v[todo].astype(np.float32)
        if digits == 9:
            ok[:] = True
        picked = np.flatnonzero(ok)
        out[todo[picked]] = [texts[i] for i in picked.tolist()]
        todo = todo[~ok]
        if not todo.size:
            break
    return list(out)


def _significant(text: bytes) -> int:
    """Significant digits of a number's shortest text (``b"1500.0"``: 2, ``b"1.25e-07"``: 3)."""
    mantissa = text.lower().split(b"e")[0].lstrip(b"+-").replace(b".", b"")
    return len(mantissa.strip(b"0")) or 1


def _exponent_width(text: bytes, width: int) -> bytes:
    """``text`` with its exponent padded to ``width`` digits (``1.5e+00`` -> ``1.5e+000``)."""
    k = max(text.rfind(b"e"), text.rfind(b"E")) + 2
    return text[:k] + text[k:].rjust(width, b"0")


def number_text(values: np.ndarray, dtype: str | np.dtype, style: tuple[int, bytes, int] | None = None
                ) -> list[bytes]:
    """Text for ``values`` that reads back exactly at ``dtype``'s precision.

    In the block's scientific ``style`` (its fraction digits, more where a
    value needs them to read back, its exponent letter and width), else the
    shortest text that reads back.

    Examples
    --------
    >>> number_text(np.array([0.1, 1e-20, 2.0]), "f8")
    [b'0.1', b'1e-20', b'2.0']
    >>> number_text(np.array([0.1]), "f4"), number_text(np.array([0.25, 0.1 + 0.2]), "f8", (4, b"E", 3))
    ([b'0.1'], [b'2.5000E-001', b'3.0000000000000004E-001'])
    """
    v = np.asarray(values, dtype=np.float64)
    if not v.size:
        return []
    single = np.dtype(dtype) == np.float32
    if style is None:
        return _shortest(v, single)
    digits, letter, width = style
    spec = b"%.*E " if letter == b"E" else b"%.*e "
    if digits >= (8 if single else 16):  # as many digits as any value needs
        texts = (spec.replace(b"*", str(digits).encode()) * v.size % tuple(v.tolist())).split()
    else:
        places = np.maximum(digits, np.array([_significant(t) for t in _shortest(v, single)]) - 1)
        args = np.empty(2 * v.size, dtype=object)
        args[0::2], args[1::2] = places.tolist(), v.tolist()
        texts = (spec * v.size % tuple(args.tolist())).split()
    return [_exponent_width(t, width) for t in texts] if width > 2 else texts


def splice(data: bytes, starts: np.ndarray, ends: np.ndarray, which: np.ndarray, texts: list[bytes]) -> bytes:
    r"""``data`` with the tokens ``which`` replaced by ``texts``, everything between them kept.

    Examples
    --------
    >>> s, e = token_spans(b"1 2\t3\n", 0)
    >>> splice(b"1 2\t3\n", s, e, np.array([1]), [b"7.5"])
    b'1 7.5\t3\n'
    """
    which = np.asarray(which, dtype=np.int64)
    if not which.size:
        return data
    if which.size * 4 < starts.size:  # a few: cut around each one
        s, e = starts[which].tolist(), ends[which].tolist()
        gaps = [data[a:b] for a, b in zip([0, *e], [*s, len(data)], strict=True)]
        pieces: list[bytes] = [b""] * (2 * len(gaps) - 1)
        pieces[0::2] = gaps
        pieces[1::2] = texts
        return b"".join(pieces)
    lo, hi = int(starts[0]), int(ends[-1])
    tokens = np.array(data[lo:hi].split(), dtype=object)
    if tokens.size != starts.size:
        raise ValueError("the numbers are separated by other characters than blanks")
    tokens[which] = texts
    gap_lo, gap_hi = ends[:-1], starts[1:]
    blanks = np.empty(gap_lo.size, dtype=object)
    one = gap_hi - gap_lo == 1  # most separators are one byte: looked up, not cut
    blanks[one] = _BYTES[np.frombuffer(data, np.uint8)[gap_lo[one]]]
    wide = np.flatnonzero(~one)
    blanks[wide] = [data[a:b] for a, b in zip(gap_lo[wide].tolist(), gap_hi[wide].tolist(), strict=True)]
    joined = np.empty(2 * tokens.size - 1, dtype=object)
    joined[0::2], joined[1::2] = tokens, blanks
    return data[:lo] + b"".join(joined.tolist()) + data[hi:]


def _leading_numbers(data: bytes, start: int, end: int | None, count: int) -> np.ndarray | None:
    """The first ``count`` numbers of ``data[start:end]`` as numpy (and meshio) read text; None if fewer."""
    words = data[start:end].split(None, count)[:count]  # the next keyword, after them, is not read
    if len(words) < count:
        return None
    try:
        return np.array(words).astype(np.float64) if count else np.zeros(0)
    except ValueError:  # a word among them that is no number: fewer numbers than ``count``
        return None


def patch_numbers(data: bytes, start: int, count: int, new: np.ndarray, dtype: str | np.dtype,
                  at: np.ndarray | None = None, end: int | None = None) -> bytes:
    r"""``data`` with the first ``count`` numbers from ``start`` replaced by ``new`` where they differ at ``dtype``.

    The tokens of unchanged numbers keep their text; changed ones are written
    in the block's notation (:func:`number_style`, :func:`number_text`).
    When nothing changed, ``data`` itself comes back, its tokens not even
    located.

    Parameters
    ----------
    data : bytes
    start : int
        Where the block of numbers starts (after its keyword line).
    count : int
        The numbers in the block.
    new : float array
        The new numbers, one per token of ``at``.
    dtype : str or dtype
        The precision the file's numbers are read at (float32 or float64).
    at : int array, optional
        The tokens that ``new`` replaces (Medit: the coordinates, not the
        references between them); all of them by default.
    end : int, optional
        Where the block must end: ``count`` numbers and nothing else lie in
        ``data[start:end]`` (a VTU array's text).

    Raises
    ------
    ValueError
        Fewer numbers than ``count`` (or, with ``end``, more), or a token that
        is not a number.

    Examples
    --------
    >>> text = b"POINTS 2 double\n0 0 0\n1 0 0\nCELLS"
    >>> patch_numbers(text, 16, 6, np.array([0, 0, 0, 1, 0.5, 0]), "f8")
    b'POINTS 2 double\n0 0 0\n1 0.5 0\nCELLS'
    """
    at = np.arange(count) if at is None else np.asarray(at, dtype=np.int64)
    target = np.asarray(new, dtype=np.float64).ravel().astype(dtype)
    if target.shape != at.shape:
        raise ValueError(f"{target.size} numbers for {at.size} places")
    quick = _leading_numbers(data, start, end, count)
    if quick is not None and not changed(quick.astype(dtype)[at], target).any():
        return data
    starts, ends = token_spans(data, start, count=count, end=end)
    if end is not None and data[ends[-1]:end].strip():
        raise ValueError(f"more than the {count} numbers expected")
    old = read_numbers(data, starts, ends, dtype)[at]
    moved = np.flatnonzero(changed(old, target))
    if not moved.size:
        return data
    texts = number_text(target[moved], dtype, number_style(data, starts[at], ends[at]))
    return splice(data, starts, ends, at[moved], texts)
