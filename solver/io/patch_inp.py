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

__all__ = ["patch_inp", "node_line_count", "node_labels", "node_block_sets", "coordinate_text", "FIELD_WIDTH"]

#: Widest coordinate field written: CalculiX reads at most 20 characters per field of a data line
#: (a longer one is a fatal "*ERROR reading *NODE").
FIELD_WIDTH = 20

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


_NSET_PARAM = re.compile(rb",\s*nset\s*=\s*([^,\s]+)", re.IGNORECASE)


def node_block_sets(data: bytes) -> dict[str, np.ndarray]:
    r"""Node sets named on ``*NODE, NSET=NAME`` lines: the points of each such block.

    Points are numbered as meshio numbers them (node data lines in order of
    appearance); a name on several blocks gets all of their points.

    Examples
    --------
    >>> deck = b"*NODE, NSET=A\n1, 0, 0, 0\n2, 1, 0, 0\n*NODE\n3, 0, 1, 0\n*NODE,nset=B\n4, 0, 0, 1\n"
    >>> {k: v.tolist() for k, v in node_block_sets(deck).items()}
    {'A': [0, 1], 'B': [3]}
    """
    out: dict[str, list[int]] = {}
    name: str | None = None
    inside = False
    row = 0
    for line in data.splitlines():
        if line.lstrip().startswith(b"**"):
            continue
        if _KEYWORD.match(line):
            inside = bool(_NODE.match(line))
            m = _NSET_PARAM.search(line) if inside else None
            name = m.group(1).decode("ascii", "replace") if m else None
            continue
        if inside and line.strip():
            if name is not None:
                out.setdefault(name, []).append(row)
            row += 1
    return {k: np.asarray(v, np.int64) for k, v in out.items()}


def node_labels(data: bytes) -> np.ndarray:
    r"""The deck's own node numbers, one per point in the order meshio numbers the points.

    Examples
    --------
    >>> node_labels(b"*NODE\n101, 0, 0, 0\n** a comment\n7, 1, 0, 0\n*ELEMENT, TYPE=C3D4\n1, 101, 7, 9, 8\n").tolist()
    [101, 7]
    """
    lines = data.splitlines(keepends=True)
    return np.asarray([int(lines[k].split(b",", 1)[0]) for k in _node_lines(lines)], np.int64)


def node_line_count(data: bytes) -> int:
    """Number of node data lines in a deck."""
    return len(_node_lines(data.splitlines(keepends=True)))


def coordinate_text(x: float) -> bytes:
    """A coordinate as at most :data:`FIELD_WIDTH` characters: the shortest text that reads back exactly, if it fits.

    Where it does not, the same digits in scientific form with a one-digit
    exponent (``3.041346788211739e-4``); where even that is too long (a
    negative value with 17 digits and an exponent), the most significant
    digits that fit: 14 or more, a relative rounding below 1e-13.

    Examples
    --------
    >>> coordinate_text(0.1), coordinate_text(-1.2381831191533588e-16)
    (b'0.1', b'-1.2381831191534e-16')
    """
    x = float(x)
    text = repr(x)
    if len(text) > FIELD_WIDTH:  # the same digits with a one-digit exponent: 3.041346788211739e-4
        text = np.format_float_scientific(x, unique=True, exp_digits=1)
    digits = 16
    while len(text) > FIELD_WIDTH:
        text = np.format_float_scientific(x, precision=digits, unique=False, exp_digits=1)
        digits -= 1
    return text.encode()


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
        Identical to ``data`` except for the coordinates that changed
        (:func:`coordinate_text`: exact where 20 characters hold the value, as
        CalculiX needs); unchanged coordinates, and the lines of unmoved nodes,
        keep their text.

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
    2, 2.5, 0.0, 0.0
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
        same = [o == float(x) for o, x in zip(old, V[row], strict=True)] if old is not None else [False] * 3
        if all(same):
            continue  # unmoved: the line keeps its text
        for j, x in enumerate(V[row]):
            if not same[j]:
                f = fields[1 + j]
                fields[1 + j] = f[: len(f) - len(f.lstrip())] + coordinate_text(x)  # its leading blanks kept
        lines[k] = b",".join(fields) + end
    return b"".join(lines)
