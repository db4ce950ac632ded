"""Nastran decks written back with new GRID coordinates and nothing else changed.

Executive control (``SOL``), case control (``CEND``, subcases), materials,
properties, loads, constraints and parameters are copied byte for byte. Each
GRID card whose node moved gets its X1, X2, X3 fields rewritten in the card's
own field format: 8 columns (small field), 16 columns (large field ``GRID*``)
or free field, with the field's own justification; fields whose value did not
change (or whose new value the field writes as the old one), and so every card
of an unmoved node, keep their text.

A GRID card given in a local coordinate system (CP field naming a ``CORD2R``,
``CORD2C`` or ``CORD2S`` card, :mod:`solver.io.nastran_coords`) is written back
in that system: the node's new basic position is turned into the system's
coordinates (r, theta, z; r, theta, phi), which go into the card's own fields.
CP and CD stay as written, and an unmoved node, one whose new position is the
one read from its fields, keeps its card's text.

An 8-column field holds about seven significant digits (a rounding of up to
5e-5 on a 100 mm part). With ``large=True``, a small-field card of a moved
node whose new coordinates do not all fit its 8 columns exactly is written as
a two-line large-field ``GRID*`` card instead (16 columns, about 15 digits);
the rest of the deck, and every other card, is unchanged.
"""

from __future__ import annotations

import numpy as np

from .nastran import GridCard, grid_cards, nastran_float, nastran_real
from .nastran_coords import GridPositions

__all__ = ["patch_bdf", "grid_count"]


def grid_count(data: bytes) -> int:
    """Number of GRID cards in a deck's bulk data (-1 when they cannot be parsed)."""
    try:
        return len(grid_cards(data.splitlines(keepends=True)))
    except ValueError:
        return -1


def patch_bdf(data: bytes, V: np.ndarray, large: bool = False) -> bytes:
    r"""The deck ``data`` with its GRID coordinates replaced by ``V``.

    Parameters
    ----------
    data : bytes
        The original deck.
    V : (n, 3) float array
        New positions in the basic system, one row per GRID card in order of
        appearance.
    large : bool
        Write a small-field card whose new coordinates do not fit its 8-column
        fields exactly as a large-field ``GRID*`` card (two lines, 16-column
        fields; ID, CP, CD, PS and SEID carried over). Cards whose values fit,
        cards of unmoved nodes, and cards with a continuation mark in field 10
        stay as they are.

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        The deck's GRID cards do not match ``V`` in number, or a card cannot be parsed
        (:class:`~solver.errors.UnreadableFileError` for a CP system that cannot be placed).

    Examples
    --------
    >>> deck = (b"SOL 101\nCEND\nBEGIN BULK\nGRID    1               0.      0.      0.\n"
    ...         b"GRID    2               1.      0.      0.\nENDDATA\n")
    >>> out = patch_bdf(deck, np.array([[0.0, 0, 0], [1.0, -3.55e-15, 0.25]])).decode().splitlines()
    >>> out[3], out[4]  # node 1 unmoved; node 2: X1 unchanged, X2 and X3 rewritten, left-justified
    ('GRID    1               0.      0.      0.', 'GRID    2               1.      -3.55-15.25     ')
    >>> big = patch_bdf(deck, np.array([[0.0, 0, 0], [1.0, 1 / 3, 0.25]]), large=True).decode().splitlines()
    >>> big[4], big[5]  # 1/3 does not fit 8 columns: node 2 becomes a GRID* card
    ('GRID*   2                                             1..333333333333333', '*                    .25')
    """
    lines = data.splitlines(keepends=True)
    cards = grid_cards(lines)
    if len(cards) != V.shape[0]:
        raise ValueError(f"the deck has {len(cards)} GRID cards, the positions {V.shape[0]} rows")
    X = _field_values(lines, cards, np.asarray(V, dtype=np.float64))
    for card, x in zip(cards, X, strict=True):
        if large and card.style == "small" and not _continued(lines[card.spans[0][0]]) and \
                _needs_large(lines, card, x):
            k = card.spans[0][0]
            lines[k] = _large_card(lines[k], x)
            continue
        # right to left, so that free-field spans on one line stay valid
        for k, a, b in sorted(card.spans, key=lambda t: (t[0], -t[1])):
            v = float(x[card.spans.index((k, a, b))])
            line = lines[k]
            body = line.rstrip(b"\r\n")
            end = line[len(body):]
            old = body[a:b]
            if nastran_float(old) == v:
                continue  # unchanged coordinate: its field keeps its text
            s = nastran_real(v, None if card.style == "free" else b - a)
            if nastran_float(s) == nastran_float(old):
                continue  # a change the field cannot hold (a round trip through a local system): its text kept
            if card.style == "free":
                text = s.encode()
            else:
                w = b - a
                left = old[:1] not in (b"", b" ")  # keep the field's justification
                text = (s.ljust(w) if left else s.rjust(w)).encode()
                body = body.ljust(b)  # a short line: its blank fields are there
            lines[k] = body[:a] + text + body[b:] + end
    return b"".join(lines)


def _field_values(lines: list[bytes], cards: list[GridCard], V: np.ndarray) -> np.ndarray:
    """The X1, X2, X3 each card is to hold for the basic positions ``V``: in its own CP system.

    A card in a local system whose node did not move gets the values it holds;
    a moved one, its new position in its system, azimuths kept within 180
    degrees of the values written.
    """
    cp = np.array([c.cp for c in cards], dtype=np.int64)
    if not cp.any():
        return V
    grids = GridPositions.of(lines, cards)  # as the deck was read: an unmoved node is found by its position
    X = V.copy()
    local = cp != 0
    moved = local & (V != grids.basic).any(axis=1)
    X[local & ~moved] = grids.local[local & ~moved]
    for c in np.unique(cp[moved]):
        rows = np.flatnonzero(moved & (cp == c))
        X[rows] = grids.systems[int(c)].from_basic(V[rows], near=grids.local[rows])
    return X


def _continued(line: bytes) -> bool:
    """Whether a small-field line has a field 10 (a continuation mark), which a GRID* card could not keep."""
    return bool(line.rstrip(b"\r\n")[72:].strip())


def _needs_large(lines: list[bytes], card: GridCard, x: np.ndarray) -> bool:
    """Whether a small-field card's new coordinates ``x`` lose digits in its 8-column fields."""
    for (k, a, b), v in zip(card.spans, x, strict=True):
        v = float(v)
        if nastran_float(lines[k].rstrip(b"\r\n")[a:b]) != v and nastran_float(nastran_real(v, 8)) != v:
            return True
    return False


def _large_card(line: bytes, x: np.ndarray) -> bytes:
    """A small-field GRID line as a large-field GRID* card at ``x`` (two lines, the line's own end).

    Field 10 of the first line and field 1 of the continuation are left blank
    but for the ``*``: the continuation follows its parent directly.
    """
    body = line.rstrip(b"\r\n")
    end = line[len(body):] or b"\n"
    text = body.decode("ascii").ljust(72)
    gid, cp, cd, ps, seid = (text[a:a + 8].strip() for a in (8, 16, 48, 56, 64))
    X = [nastran_real(float(v), 16) for v in x]
    first = f"GRID*   {gid:<16}{cp:<16}{X[0]:>16}{X[1]:>16}"
    second = f"*       {X[2]:>16}{cd:<16}{ps:<16}{seid:<16}".rstrip()
    return first.encode() + end + second.encode() + end
