"""ASCII Gmsh 2.2 / 4.1 files written back with new ``$Nodes`` coordinates and nothing else changed."""

from __future__ import annotations

import numpy as np

__all__ = ["patch_msh"]


def patch_msh(data: bytes, V: np.ndarray) -> bytes | None:
    r"""An ASCII Gmsh 2.2 or 4.1 file with the coordinates of its ``$Nodes`` replaced by ``V``.

    Everything else (elements, physical names, entities, formatting of other
    lines, the lines of unmoved nodes) is copied byte for byte. Nodes are numbered in order of appearance,
    as meshio reads them. Returns ``None`` for files it cannot patch (binary
    Gmsh files, node counts that differ from ``V``); the caller then writes
    through meshio.

    Examples
    --------
    >>> msh = (b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 2 1 2\n3 1 0 2\n1\n2\n"
    ...        b"0 0 0\n1 0 0\n$EndNodes\n")
    >>> patch_msh(msh, np.array([[0, 0, 0], [2, 0, 0.5]])).decode().splitlines()[9]
    '2 0 0.5'
    """
    lines = data.splitlines(keepends=True)
    try:
        k = next(i for i, ln in enumerate(lines) if ln.strip() == b"$MeshFormat")
        version, filetype = lines[k + 1].split()[:2]
        start = next(i for i, ln in enumerate(lines) if ln.strip() == b"$Nodes")
    except (StopIteration, ValueError):
        return None
    if filetype != b"0":
        return None  # binary
    fmt = lambda row: b" ".join(format(float(x), ".17g").encode() for x in row)  # noqa: E731
    out_rows = iter(V)
    count = 0

    def put(i: int, keep_tail: int = 0) -> None:
        nonlocal count
        line = lines[i]
        body = line.rstrip(b"\r\n")
        parts = body.split()
        new = V[count] if count < V.shape[0] else None
        if new is not None and len(parts) >= keep_tail + 3 and all(
                float(o) == float(x) for o, x in zip(parts[keep_tail:keep_tail + 3], new, strict=True)):
            next(out_rows)
            count += 1
            return  # unmoved: the line keeps its text
        lines[i] = (b" ".join(parts[:keep_tail]) + (b" " if keep_tail else b"") + fmt(next(out_rows))
                    + (b" " + b" ".join(parts[keep_tail + 3:]) if len(parts) > keep_tail + 3 else b"")
                    + line[len(body):])
        count += 1

    try:
        if version.startswith(b"2"):
            n = int(lines[start + 1])
            for i in range(start + 2, start + 2 + n):
                put(i, keep_tail=1)  # "tag x y z"
        elif version.startswith(b"4"):
            blocks = int(lines[start + 1].split()[0])
            i = start + 2
            for _ in range(blocks):
                head = lines[i].split()
                parametric, nb = int(head[2]), int(head[3])
                i += 1 + nb  # the block's node tags
                for j in range(i, i + nb):
                    if parametric:
                        return None
                    put(j)  # "x y z"
                i += nb
        else:
            return None
    except (StopIteration, ValueError, IndexError):
        return None
    if count != V.shape[0]:
        return None
    return b"".join(lines)
