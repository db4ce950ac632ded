"""Ansys MAPDL archives (``.cdb``) written back in place: new node coordinates, every other byte kept.

:func:`patch_cdb` rewrites the x, y, z fields of the lines of the moved nodes
only, each in its ``NBLOCK``'s own field widths and with the precision of its
format (13 decimals for ``e20.13``); node numbers, the other integer fields,
the reals past z and every line outside the node blocks keep their text.
:func:`node_line_count` is how many node lines a deck has, which tells
whether a mesh's points are the deck's nodes.
"""

from __future__ import annotations

import numpy as np

from .cdb_blocks import _node_format, _node_rows, _NodeFormat, _scan
from .cdb_fields import fortran_e


def node_line_count(raw: bytes) -> int:
    r"""Number of node lines in the ``NBLOCK``\ s of a deck (-1 when its blocks cannot be read).

    Examples
    --------
    >>> node_line_count(b"NBLOCK,6,SOLID,2,2\n(3i8,6e20.13)\n       1       0       0\n"
    ...                 b"       2       0       0 1.0000000000000E+00\nN,R5.3,LOC,       -1,\n")
    2
    """
    try:
        blocks, _ = _scan(raw, "deck")
    except ValueError:  # UnreadableFileError included
        return -1
    return sum(raw.count(b"\n", b.start, b.end) for b in blocks if b.key == "NBLOCK")


def patch_cdb(raw: bytes, V: np.ndarray) -> bytes | None:
    """The deck ``raw`` with the coordinates of its node lines set to ``V``, every other byte kept.

    Each moved node's three coordinate fields are written in its ``NBLOCK``'s own format
    (:func:`fortran_e`: ``e20.13`` as `` 1.0000000000000E+00``), so with that format's precision;
    its node number, other integer fields and the reals past z keep their text. A node whose
    parsed coordinates equal its row of ``V`` keeps its line; a line that left out trailing zero
    coordinates gets them where they are no longer zero.

    Parameters
    ----------
    raw : bytes
        The deck as read.
    V : (n, 3) float array
        New positions, row k for the k-th node line of the deck.

    Returns
    -------
    bytes or None
        None when the deck has no ``NBLOCK``.

    Raises
    ------
    ValueError
        ``V`` does not have a row per node line, a value does not fit its field, or the deck
        cannot be read (:class:`~solver.errors.UnreadableFileError` is a ValueError).
    """
    V = np.asarray(V, dtype=np.float64)
    blocks = [b for b in _scan(raw, "deck")[0] if b.key == "NBLOCK"]
    if not blocks:
        return None
    count = sum(raw.count(b"\n", b.start, b.end) for b in blocks)
    if V.ndim != 2 or V.shape != (count, 3):
        raise ValueError(f"the deck has {count} node lines; the positions have shape {V.shape}")
    out: list[bytes] = []
    prev = k = 0
    for b in blocks:
        rows = b.rows(raw)
        f = _node_format("deck", b)
        _, P, written = _node_rows("deck", b, rows, f)
        W = V[k:k + len(rows)]
        k += len(rows)
        moved = np.flatnonzero((W != P).any(axis=1))
        texts = [_e_column(W[moved, j], f) for j in range(3)]
        for i, (r, keep) in enumerate(zip(moved.tolist(), _kept(W[moved], written[moved]).tolist(), strict=True)):
            rows[r] = _node_line(rows[r], "".join([texts[0][i], texts[1][i], texts[2][i]][:keep]), keep, f)
        out += [raw[prev:b.start], b"\n".join(rows), b"\n"]
        prev = b.end
    out.append(raw[prev:])
    return b"".join(out)


def _e_column(x: np.ndarray, f: _NodeFormat) -> list[str]:
    """:func:`fortran_e` of each of ``x`` (n,) in the reals of format ``f``.

    Python's ``%E`` writes what Fortran does where the exponent has two digits; three-digit
    exponents get their ``0`` put in. Values outside 1e-99 .. 1e99, and formats too narrow for
    a sign, go through :func:`fortran_e` one by one.

    Examples
    --------
    >>> _e_column(np.array([1.0, -2.5e-12]), _NodeFormat(3, 9, 6, 21, 13, 3))
    [' 1.0000000000000E+000', '-2.5000000000000E-012']
    >>> _e_column(np.array([-2.5e-120]), _NodeFormat(3, 8, 6, 20, 13, None))
    ['-2.5000000000000-120']
    """
    digits = 2 if f.e is None else f.e
    a = np.abs(x)
    plain = np.isfinite(x).all() and ((a == 0) | ((a >= 1e-99) & (a < 1e99))).all() and f.w >= f.d + 5 + digits
    if not plain or digits not in (2, 3):
        return [fortran_e(v, f.w, f.d, f.e) for v in x.tolist()]
    if digits == 2:
        return list(map(f"%{f.w}.{f.d}E".__mod__, x.tolist()))
    text = "\n".join(map(f"%{f.w - 1}.{f.d}E".__mod__, x.tolist()))
    return text.replace("E+", "E+0").replace("E-", "E-0").split("\n") if len(x) else []


def _kept(X: np.ndarray, written: np.ndarray) -> np.ndarray:
    """How many coordinate fields to write on each moved node's line.

    All three where the line had them (or more reals), else as many as it had or as its last
    non-zero coordinate needs.

    Examples
    --------
    >>> _kept(np.array([[1.0, 0, 0], [1.0, 2.0, 0], [0, 0, 0], [0, 0, 5.0]]), np.array([1, 0, 6, 1])).tolist()
    [1, 2, 3, 3]
    """
    nonzero = X != 0
    last = np.where(nonzero.any(axis=1), 3 - np.argmax(nonzero[:, ::-1], axis=1), 0)
    return np.where(written >= 3, 3, np.maximum(written, last))


def _node_line(row: bytes, reals: str, keep: int, f: _NodeFormat) -> bytes:
    """A node row with its first ``keep`` reals replaced by ``reals``: the integer fields and the reals past z kept."""
    cr = row.endswith(b"\r")
    body = row[:-1] if cr else row
    head = body[:f.ints * f.iw].ljust(f.ints * f.iw)
    tail = body[f.ints * f.iw + 3 * f.w:] if keep == 3 else b""
    return head + reals.encode("ascii") + tail + (b"\r" if cr else b"")
