"""Nastran decks written back with new GRID coordinates and nothing else changed.

Executive control (``SOL``), case control (``CEND``, subcases), materials,
properties, loads, constraints and parameters are copied byte for byte. Each
GRID card whose node moved gets its X1, X2, X3 fields rewritten in the card's
own field format: 8 columns (small field), 16 columns (large field ``GRID*``)
or free field, with the field's own justification; fields whose value did not
change, and so every card of an unmoved node, keep their text.
"""

from __future__ import annotations

import numpy as np

from .nastran import grid_cards, nastran_float, nastran_real

__all__ = ["patch_bdf", "grid_count"]


def grid_count(data: bytes) -> int:
    """Number of GRID cards in a deck's bulk data (-1 when they cannot be parsed)."""
    try:
        return len(grid_cards(data.splitlines(keepends=True)))
    except ValueError:
        return -1


def patch_bdf(data: bytes, V: np.ndarray) -> bytes:
    r"""The deck ``data`` with its GRID coordinates replaced by ``V``.

    Parameters
    ----------
    data : bytes
        The original deck.
    V : (n, 3) float array
        New positions, one row per GRID card in order of appearance.

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        The deck's GRID cards do not match ``V`` in number, or a card cannot be parsed.

    Examples
    --------
    >>> deck = (b"SOL 101\nCEND\nBEGIN BULK\nGRID    1               0.      0.      0.\n"
    ...         b"GRID    2               1.      0.      0.\nENDDATA\n")
    >>> out = patch_bdf(deck, np.array([[0.0, 0, 0], [1.0, -3.55e-15, 0.25]])).decode().splitlines()
    >>> out[3], out[4]  # node 1 unmoved; node 2: X1 unchanged, X2 and X3 rewritten, left-justified
    ('GRID    1               0.      0.      0.', 'GRID    2               1.      -3.55-15.25     ')
    """
    lines = data.splitlines(keepends=True)
    cards = grid_cards(lines)
    if len(cards) != V.shape[0]:
        raise ValueError(f"the deck has {len(cards)} GRID cards, the positions {V.shape[0]} rows")
    for card, x in zip(cards, np.asarray(V, dtype=np.float64), strict=True):
        # right to left, so that free-field spans on one line stay valid
        for k, a, b in sorted(card.spans, key=lambda t: (t[0], -t[1])):
            v = float(x[card.spans.index((k, a, b))])
            line = lines[k]
            body = line.rstrip(b"\r\n")
            end = line[len(body):]
            old = body[a:b]
            if nastran_float(old) == v:
                continue  # unchanged coordinate: its field keeps its text
            if card.style == "free":
                text = nastran_real(v, None).encode()
            else:
                w = b - a
                left = old[:1] not in (b"", b" ")  # keep the field's justification
                s = nastran_real(v, w)
                text = (s.ljust(w) if left else s.rjust(w)).encode()
                body = body.ljust(b)  # a short line: its blank fields are there
            lines[k] = body[:a] + text + body[b:] + end
    return b"".join(lines)
