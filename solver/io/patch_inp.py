"""Abaqus ``.inp`` decks written back with new node coordinates and nothing else changed.

meshio rewrites a whole ``.inp`` file (its own formatting, only the keywords it
knows). A CAE deck carries much more: materials, sections, steps, loads,
comments. :func:`patch_inp` copies the original text byte for byte and only
replaces the three coordinates on each data line of the ``*NODE`` blocks, in the
order meshio numbers the points (the order of appearance).
"""

from __future__ import annotations

import re

import numpy as np

__all__ = ["patch_inp", "node_line_count"]

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
    r"""The deck ``data`` with the coordinates of its nodes replaced by ``V``.

    Parameters
    ----------
    data : bytes
        The original ``.inp`` file.
    V : (n, 3) float array
        New positions, one row per node data line in order of appearance.

    Returns
    -------
    bytes
        Identical to ``data`` except for the coordinate fields of the node lines
        whose node moved (written with 17 significant digits, so they read back
        exactly); the lines of unmoved nodes keep their text.

    Raises
    ------
    ValueError
        The deck's node lines do not match ``V`` in number, or a node line has
        fewer than three coordinates.

    Examples
    --------
    >>> deck = b"*Heading\n*NODE\n1, 0.0, 0.0, 0.0\n2, 1.0, 0.0, 0.0\n*ELEMENT, TYPE=T3D2\n1, 1, 2\n"
    >>> print(patch_inp(deck, np.array([[0, 0, 0], [2.5, 0, 0]])).decode())
    *Heading
    *NODE
    1, 0.0, 0.0, 0.0
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
        try:
            old = [float(f.replace(b"d", b"e").replace(b"D", b"e")) for f in fields[1:4]]
        except ValueError:
            old = None
        if old is not None and all(o == float(x) for o, x in zip(old, V[row], strict=True)):
            continue  # unmoved: the line keeps its text
        coords = [format(float(x), ".17g").encode() for x in V[row]]
        lead = [f[: len(f) - len(f.lstrip())] for f in fields[1:4]]  # keep each field's leading blanks
        fields[1:4] = [sp + c for sp, c in zip(lead, coords, strict=True)]
        lines[k] = b",".join(fields) + end
    return b"".join(lines)
