"""Wavefront OBJ surfaces, written with their face groups and read where meshio cannot.

meshio's writer drops the groups, and its reader refuses texture coordinates or
normals given per face corner.
"""

from __future__ import annotations

import os

import meshio
import numpy as np

__all__ = ["write_obj", "read_obj"]


def write_obj(path: str | os.PathLike[str], m: meshio.Mesh) -> None:
    """Write the triangle and quad cells of ``m`` as an OBJ, a ``g`` line wherever the face group changes.

    Parameters
    ----------
    path : str or path
    m : meshio.Mesh
        Points and triangle / quad blocks; ``cell_data["obj:group_ids"]`` (per block) gives each face's
        group, written as ``g group_<id>`` lines, so that an OBJ reader numbers the groups in the same order.
        Coordinates are written with 17 significant digits (they read back exactly).
    """
    groups = m.cell_data.get("obj:group_ids")
    with open(path, "w", encoding="ascii") as fh:
        fh.write("# written by tetmorph\n")
        for x in np.asarray(m.points, dtype=np.float64):
            fh.write(f"v {x[0]:.17g} {x[1]:.17g} {x[2]:.17g}\n")
        current = None
        for b, block in enumerate(m.cells):
            ids = np.asarray(groups[b]).ravel() if groups is not None else None
            for k, face in enumerate(np.asarray(block.data, np.int64) + 1):
                if ids is not None and ids[k] != current:
                    current = ids[k]
                    fh.write(f"g group_{int(current)}\n")
                fh.write("f " + " ".join(str(int(i)) for i in face) + "\n")


def read_obj(path: str | os.PathLike[str]) -> meshio.Mesh:
    """Read an OBJ's vertices, faces and face groups, whatever its ``vt`` and ``vn`` count.

    meshio stores ``vt`` and ``vn`` as point data and refuses a file that has
    more of them than vertices (texture coordinates per face corner, as in
    ``spot.obj``). Here they are left out and named in ``info["dropped"]``
    (shown by ``tetmorph info``): a morph moves vertices, not texture space.

    Returns
    -------
    meshio.Mesh
        ``triangle`` and ``quad`` blocks in file order, ``cell_data["obj:group_ids"]``
        numbered by ``g`` line as meshio numbers them (-1 before the first).
    """
    points: list[list[float]] = []
    faces: list[tuple[list[int], int]] = []
    counts = {"vt": 0, "vn": 0}
    group = -1
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            parts = line.split()
            if not parts or parts[0].startswith("#"):
                continue
            if parts[0] == "v":
                points.append([float(x) for x in parts[1:4]])
            elif parts[0] in counts:
                counts[parts[0]] += 1
            elif parts[0] == "g":
                group += 1
            elif parts[0] == "f":
                idx = [int(c.split("/")[0]) for c in parts[1:]]
                faces.append(([i - 1 if i > 0 else len(points) + i for i in idx], group))
    blocks: dict[int, tuple[list[list[int]], list[int]]] = {}
    order: list[int] = []
    for f, g in faces:
        if len(f) not in (3, 4):
            raise ValueError(f"a face of {len(f)} vertices (triangles and quads only)")
        if len(f) not in blocks:
            blocks[len(f)] = ([], [])
            order.append(len(f))
        blocks[len(f)][0].append(f)
        blocks[len(f)][1].append(g)
    cells = [("triangle" if k == 3 else "quad", np.array(blocks[k][0], np.int64)) for k in order]
    dropped = [f"{counts[k]} {'texture coordinates' if k == 'vt' else 'normals'} ({k})" for k in counts if counts[k]]
    return meshio.Mesh(np.array(points, np.float64).reshape(-1, 3), cells,
                       cell_data={"obj:group_ids": [np.array(blocks[k][1], np.int64) for k in order]},
                       info={"dropped": dropped})
