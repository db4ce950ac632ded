"""Abaqus decks written from a mesh of another format: nodes, elements, node and element sets.

meshio's writer repeats an element set once per cell block, and its reader
keeps only the last repeat; :func:`write_abaqus` writes each set once, with
element numbers running over all blocks.
"""

from __future__ import annotations

import os

import meshio
import numpy as np

from .conversion import ABAQUS_TYPES
from .patch_inp import coordinate_text

__all__ = ["write_abaqus"]


def _id_lines(ids: np.ndarray, per_line: int = 16) -> str:
    rows = [", ".join(str(int(i)) for i in ids[k:k + per_line]) for k in range(0, len(ids), per_line)]
    return "\n".join(rows) + "\n" if rows else ""


def write_abaqus(path: str | os.PathLike[str], m: meshio.Mesh, heading: str = "written by tetmorph") -> None:
    """Write ``m`` as an Abaqus deck (coordinates exact within CalculiX's 20-character fields, 1-based numbers).

    Parameters
    ----------
    path : str or path
    m : meshio.Mesh
        Cell blocks of :data:`solver.io.conversion.ABAQUS_TYPES`; ``point_sets``
        become ``*NSET``, ``cell_sets`` (per block indices) ``*ELSET``.
    heading : str
    """
    P = np.asarray(m.points, dtype=np.float64)
    with open(path, "w", encoding="ascii") as fh:
        fh.write(f"*HEADING\n{heading}\n*NODE\n")
        for k, x in enumerate(P):
            fh.write(f"{k + 1}, " + ", ".join(coordinate_text(v).decode() for v in x) + "\n")
        start, first = 1, []
        for block in m.cells:
            first.append(start)
            fh.write(f"*ELEMENT, TYPE={ABAQUS_TYPES[block.type]}\n")
            for k, row in enumerate(np.asarray(block.data, np.int64) + 1):
                fh.write(f"{start + k}, " + ", ".join(str(int(i)) for i in row) + "\n")
            start += len(block.data)
        for name, ids in m.point_sets.items():
            fh.write(f"*NSET, NSET={name}\n" + _id_lines(np.asarray(ids, np.int64) + 1))
        for name, per in m.cell_sets.items():
            ids = np.concatenate([np.asarray(x, np.int64) + f for x, f in zip(per, first, strict=True)])
            fh.write(f"*ELSET, ELSET={name}\n" + _id_lines(ids))
