"""LS-DYNA keyword decks written back in place: only the coordinate fields of moved nodes change.

:func:`patch` and :func:`patch_tree` copy the deck (and its included files)
byte for byte and rewrite the X, Y, Z fields of the node cards whose node
moved, each in its own columns (16 wide in small and I10 format, 20 in long
format; in free format the comma-separated field, its blanks kept), as the
text :func:`field_text` gives. :func:`node_line_count` counts a deck's node
cards.
"""

from __future__ import annotations

import math

import numpy as np

from .lsdyna_cards import _Loader, _TreeLoader, _walk
from .lsdyna_fields import _WIDTHS, _free, _node_cards


def _compact(text: str) -> str:
    """A number's text with its exponent's leading zeros dropped (its sign kept): ``1e-05`` -> ``1e-5``.

    Examples
    --------
    >>> _compact("1e-05"), _compact("2.5e+16"), _compact("3.0e+00"), _compact("0.25")
    ('1e-5', '2.5e+16', '3.0e+0', '0.25')
    """
    if "e" not in text:
        return text
    mantissa, exponent = text.split("e")
    sign = "-" if exponent.startswith("-") else "+"
    return f"{mantissa}e{sign}{exponent.lstrip('+-').lstrip('0') or '0'}"


def field_text(x: float, width: int) -> bytes:
    """A coordinate as at most ``width`` characters: the shortest text that reads back exactly, if it fits.

    Where it does not, the text of at most ``width`` characters (positional, or scientific with a short
    exponent) nearest to ``x``: the most significant digits that fit.

    Parameters
    ----------
    x : float
    width : int
        The field's width (16 in small and I10 format, 20 in long format).

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        ``x`` is not finite.

    Examples
    --------
    >>> field_text(0.1, 16), field_text(1e-05, 16), field_text(-1.2381831191533588e-16, 16)
    (b'0.1', b'1e-5', b'-1.238183119e-16')
    >>> field_text(123.45678901234568, 16), field_text(-1.2381831191533588e-16, 20)
    (b'123.456789012346', b'-1.2381831191534e-16')
    """
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"coordinate {x} is not a finite number")
    text = _compact(repr(x))
    if len(text) <= width:
        return text.encode()
    best: tuple[float, int, str] | None = None
    candidates = []
    for digits in range(17, -1, -1):
        s = _compact(f"{x:.{digits}e}")
        if len(s) <= width:
            candidates.append(s)
            break
    whole = f"{x:.0f}"
    if len(whole) <= width:
        decimals = max(width - len(whole) - 1, 0)
        while decimals >= 0:
            s = f"{x:.{decimals}f}"
            if len(s) <= width:
                candidates.append(s)
                break
            decimals -= 1
    for s in candidates:
        key = (abs(float(s) - x), len(s), s)
        if best is None or key < best:
            best = key
    if best is None:
        raise ValueError(f"coordinate {x!r} does not fit {width} characters")
    return best[2].encode()


def _node_line(text: bytes, old: np.ndarray, new: np.ndarray, fmt: str) -> bytes:
    """A node card (without its line end) with the coordinates that changed rewritten in their own fields."""
    wi, wr, _ = _WIDTHS[fmt]
    if b"," in text:
        fields = _free(text)
        fields += [b""] * (4 - len(fields)) if len(fields) < 4 else []
        for j in range(3):
            if old[j] != new[j]:
                f = fields[1 + j]
                core = f.strip()
                lead = f[: len(f) - len(f.lstrip())] if core else f
                trail = f[len(f.rstrip()):] if core else b""
                fields[1 + j] = lead + field_text(new[j], wr) + trail
        return b",".join(fields)
    line = bytearray(text)
    for j in range(3):
        if old[j] != new[j]:
            a = wi + j * wr
            if len(line) < a + wr:
                line.extend(b" " * (a + wr - len(line)))
            line[a:a + wr] = field_text(new[j], wr).rjust(wr)
    return bytes(line)


def _patched(data: bytes, loader: _Loader, V: np.ndarray) -> dict[str, bytes]:
    """The deck (key ``""``) and its included files, with the node cards of moved nodes rewritten."""
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] < 3:
        raise ValueError(f"positions of shape {V.shape}, where (n, 3) is needed")
    files: dict[str, bytes] = {"": data}
    edits: dict[str, list[tuple[int, int, bytes]]] = {}
    row = 0
    for block in _walk(data, loader):
        files.setdefault(block.file, block.data)
        if block.name != "NODE":
            continue
        _, old, starts, ends, _ = _node_cards(block, "the deck")
        k = len(old)
        if row + k > len(V):
            raise ValueError(f"the deck has more node cards than the {len(V)} positions given")
        new = V[row:row + k, :3]
        moved = np.flatnonzero((old != new).any(axis=1))
        for r in moved.tolist():
            s, e = int(starts[r]), int(ends[r])
            edits.setdefault(block.file, []).append((s, e, _node_line(block.data[s:e], old[r], new[r], block.fmt)))
        row += k
    if row != len(V):
        raise ValueError(f"the deck has {row} node cards, the positions {len(V)} rows")
    out = {}
    for file, body in files.items():
        pieces, last = [], 0
        for s, e, text in edits.get(file, []):
            pieces += [body[last:s], text]
            last = e
        out[file] = b"".join(pieces) + body[last:] if pieces else body
    return out


def patch(data: bytes, V: np.ndarray) -> bytes:
    r"""The deck ``data`` with the coordinates of its nodes replaced by ``V`` (a deck without ``*INCLUDE``).

    Parameters
    ----------
    data : bytes
        The original deck.
    V : (n, 3) float array
        New positions, one row per node card in reading order.

    Returns
    -------
    bytes
        ``data`` with the X, Y, Z fields of moved nodes rewritten (:func:`field_text`); every other byte kept.

    Raises
    ------
    ValueError
        The node cards do not match ``V`` in number, or the deck includes files (:func:`patch_tree`).

    Examples
    --------
    >>> deck = b"*KEYWORD\n*NODE\n       1             0.0             0.0             0.0\n*END\n"
    >>> print(patch(deck, np.array([[0.5, 0, 0]])).decode())
    *KEYWORD
    *NODE
           1             0.5             0.0             0.0
    *END
    <BLANKLINE>
    """
    return _patched(data, _Loader("the deck"), V)[""]


def patch_tree(data: bytes, included: dict[str, bytes], V: np.ndarray) -> dict[str, bytes]:
    """The deck and the files it includes with the coordinates of their nodes replaced by ``V``.

    Parameters
    ----------
    data : bytes
        The deck.
    included : dict of str to bytes
        Its included files by path relative to the deck's folder (:func:`includes`).
    V : (n, 3) float array
        New positions, one row per node card in reading order (the deck's and the includes').

    Returns
    -------
    dict of str to bytes
        ``""``: the deck; each included file by its relative path.

    Raises
    ------
    ValueError
        The node cards do not match ``V``, or an included file is missing from ``included``.
    """
    out = _patched(data, _TreeLoader(included), V)
    for rel, body in included.items():
        out.setdefault(rel, body)
    return out


def node_line_count(data: bytes) -> int:
    """Number of node cards in a deck (-1 when it cannot be read alone: it includes files, or a card is bad)."""
    try:
        return sum(len(_node_cards(b, "the deck")[0]) for b in _walk(data, _Loader("the deck")) if b.name == "NODE")
    except ValueError:
        return -1
