"""TetGen ``.node`` files written back with new coordinates and nothing else changed.

Only the three coordinate tokens of each node line are replaced, and only on
the lines whose node moved; node numbers (0- or 1-based), attributes, boundary
markers, comments and spacing stay as they were. The ``.ele`` file is copied
unchanged by :func:`solver.io.write.write_mesh` (the patcher's companion).
"""

from __future__ import annotations

import re

import numpy as np

from .tetgen import data_lines

__all__ = ["patch_node", "node_count"]

_TOKEN = re.compile(rb"\S+")


def node_count(data: bytes) -> int:
    r"""The point count in a ``.node`` header (-1 when there is none).

    Examples
    --------
    >>> node_count(b"# beam\n2 3 0 0\n1 0 0 0\n2 1 0 0\n"), node_count(b"")
    (2, -1)
    """
    rows = data_lines(data)
    try:
        return int(rows[0][1][0]) if rows else -1
    except ValueError:
        return -1


def patch_node(data: bytes, V: np.ndarray) -> bytes | None:
    r"""The ``.node`` file ``data`` with its node coordinates replaced by ``V``.

    Parameters
    ----------
    data : bytes
        The original ``.node`` file.
    V : (n, 3) float array
        New positions, one row per node line in file order.

    Returns
    -------
    bytes or None
        ``data`` with the coordinate tokens of moved nodes rewritten (17
        significant digits); ``None`` when the file's node lines do not match ``V``.

    Examples
    --------
    >>> node = b"2 3 0 1\n1  0.0 0.0 0.0  7  # a\n2  1.0 0.0 0.0  0\n"
    >>> print(patch_node(node, np.array([[0.0, 0, 0], [1.5, 0, 0]])).decode(), end="")
    2 3 0 1
    1  0.0 0.0 0.0  7  # a
    2  1.5 0 0  0
    """
    lines = data.splitlines(keepends=True)
    rows = data_lines(data)
    if len(rows) < V.shape[0] + 1 or node_count(data) != V.shape[0]:
        return None
    for r, (k, _tokens) in enumerate(rows[1:1 + V.shape[0]]):
        line = lines[k]
        cut = line.find(b"#")
        body = line if cut < 0 else line[:cut]
        spans = [m.span() for m in _TOKEN.finditer(body)][1:4]
        if len(spans) < 3:
            return None
        try:
            old = [float(body[a:b]) for a, b in spans]
        except ValueError:
            return None
        new = V[r]
        if all(o == float(x) for o, x in zip(old, new, strict=True)):
            continue  # unmoved: keep the original text
        out, last = [], 0
        for (a, b), x in zip(spans, new, strict=True):
            out += [line[last:a], format(float(x), ".17g").encode()]
            last = b
        lines[k] = b"".join(out) + line[last:]
    return b"".join(lines)
