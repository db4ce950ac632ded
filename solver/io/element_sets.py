"""The deck's own element ids, and an element set written in the deck's own syntax.

The deck readers keep each element's number from the file (``cells_id`` of the
meshio mesh, per cell block: Abaqus/CalculiX, Nastran, Ansys CDB, LS-DYNA);
:func:`deck_element_ids` lines them up with tetmorph's element numbering (tets
in file order, then hexahedra, wedges and pyramids; quadratic tets in file
order). :func:`element_set` writes a list of them as a set the deck's solver
reads, for an ``*INCLUDE`` or to paste:

=========== =======================================================
format      set
=========== =======================================================
abaqus      ``*ELSET, ELSET=NAME``, 16 ids a line
nastran     ``SET1`` bulk data card, small field, continued with ``+``
ansys-cdb   ``CMBLOCK,NAME,ELEM,count`` with format ``(8i10)``
lsdyna      ``*SET_SOLID_TITLE``: the name, the set id, 8 ids a card
=========== =======================================================
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SolverError

if TYPE_CHECKING:
    from ..mesh import Mesh

__all__ = ["deck_element_ids", "deck_node_ids", "element_set", "SET_FORMATS"]

#: Formats an element set can be written for.
SET_FORMATS = ("abaqus", "nastran", "ansys-cdb", "lsdyna")


def deck_element_ids(mesh: Mesh) -> np.ndarray:
    """The file's id of every volume element, in element order.

    Parameters
    ----------
    mesh : Mesh

    Returns
    -------
    (M,) int64 array
        The deck's element numbers; for a file without them (Gmsh, VTK, Medit, ...)
        or a mesh built from arrays, the 1-based position ``1..M``.
    """
    M = mesh.elements
    src = mesh.source
    labels = getattr(src, "cells_id", None)
    if src is None or labels is None or len(labels) != len(src.cells):
        return np.arange(1, M + 1, dtype=np.int64)
    types = ["tetra10"] if mesh.T10 is not None else [k for k, _ in mesh.blocks]
    parts = [np.asarray(labels[b], np.int64).reshape(-1) for t in types
             for b, c in enumerate(src.cells) if c.type == t]
    ids = np.concatenate(parts) if parts else np.zeros(0, np.int64)
    if ids.shape != (M,):  # the blocks do not line up with the elements: positions, never wrong ids
        return np.arange(1, M + 1, dtype=np.int64)
    return ids


def deck_node_ids(mesh: Mesh) -> np.ndarray | None:
    """The file's number of every vertex, in vertex order, where the file numbers its nodes.

    Parameters
    ----------
    mesh : Mesh

    Returns
    -------
    (n,) int64 array or None
        The deck's node numbers (``points_id`` of an Abaqus, Nastran, Ansys CDB or
        LS-DYNA read); None for a file without them or a mesh built from arrays.
    """
    ids = getattr(mesh.source, "points_id", None)
    if ids is None:
        return None
    ids = np.asarray(ids, np.int64).reshape(-1)
    return ids if ids.shape == (mesh.n,) else None


def _rows(ids: list[int], per: int, fmt: str, sep: str) -> str:
    return "".join(sep.join(fmt.format(i) for i in ids[k:k + per]) + "\n" for k in range(0, len(ids), per))


def _nastran(name: str, ids: list[int], set_id: int) -> str:
    head = [f"{set_id:<8d}"] + [f"{i:<8d}" for i in ids[:7]]
    out = f"$ {name}\nSET1    " + "".join(head).rstrip() + "\n"
    for k in range(7, len(ids), 8):
        out += "+       " + "".join(f"{i:<8d}" for i in ids[k:k + 8]).rstrip() + "\n"
    return out


def element_set(file_format: str | None, name: str, ids: np.ndarray, set_id: int = 1,
                assembly: bool = False) -> str:
    """An element set of the deck's ids in the syntax of ``file_format``.

    Parameters
    ----------
    file_format : str or None
        One of :data:`SET_FORMATS` (:attr:`solver.mesh.Mesh.file_format`).
    name : str
        The set's name (Nastran: a comment line above the card).
    ids : (k,) int array
        Deck element ids (:func:`deck_element_ids`).
    set_id : int
        Nastran ``SET1`` and LS-DYNA ``*SET_SOLID`` need a number: choose one the deck does not use.
    assembly : bool
        The mesh came from an Abaqus/CAE assembly deck, whose element numbers repeat across
        instances: refused.

    Returns
    -------
    str

    Raises
    ------
    SolverError
        ``element_sets_unsupported`` (details ``format``, ``formats``) for another format, or an
        assembly deck.

    Examples
    --------
    >>> print(element_set("abaqus", "BAD", np.array([137, 2001])), end="")
    *ELSET, ELSET=BAD
    137, 2001
    >>> print(element_set("ansys-cdb", "BAD", np.array([5])), end="")
    CMBLOCK,BAD,ELEM,       1
    (8i10)
             5
    """
    ids_list = [int(i) for i in np.asarray(ids).reshape(-1)]
    if file_format not in SET_FORMATS or assembly:
        why = ("an Abaqus/CAE assembly deck numbers elements per instance: write the flat deck first "
               "(tetmorph morph --flatten)" if assembly else
               f"a {file_format or 'mesh built from arrays'} file has no element sets")
        raise SolverError(f"cannot write an element set: {why}; element sets are written for "
                          f"{', '.join(SET_FORMATS)} decks (the failing ids are in the CSV)",
                          code="element_sets_unsupported", format=file_format, formats=list(SET_FORMATS))
    if file_format == "abaqus":
        return f"*ELSET, ELSET={name}\n" + _rows(ids_list, 16, "{}", ", ")
    if file_format == "nastran":
        return _nastran(name, ids_list, set_id)
    if file_format == "ansys-cdb":
        return f"CMBLOCK,{name},ELEM,{len(ids_list):8d}\n(8i10)\n" + _rows(ids_list, 8, "{:10d}", "")
    return f"*SET_SOLID_TITLE\n{name}\n{set_id:10d}\n" + _rows(ids_list, 8, "{:10d}", "")
