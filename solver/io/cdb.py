"""Ansys MAPDL archive files (``.cdb``): nodes, solid elements and components, written back in place.

``CDWRITE`` writes a model as blocks of fixed-width rows; a Fortran format line
after each block's header gives the column widths (MAPDL Command Reference,
``NBLOCK``, ``EBLOCK``, ``CMBLOCK``, ``ET``)::

    ET,       3,187                      -- element type 3 is SOLID187
    NBLOCK,6,SOLID,      1041,      1041 -- up to 6 reals; highest node number, node count
    (3i8,6e20.13)                        -- 3 integers of 8 columns, then reals of 20
           1       0       0 1.0000000000000E+00-5.0000000000000E-01
    N,R5.3,LOC,       -1,                -- (or -1) ends the block
    EBLOCK,19,SOLID,      3913,      3913
    (19i8)                               -- 11 attribute fields, then 8 node numbers
           1       3       1       1       0       0      14       0       4       0       1     676 ...
          -1
    CMBLOCK,FIXED,NODE,       2          -- a node component of 2 fields
    (8i10)
             1       -40                 -- -40 after 1: nodes 1 to 40

What is read:

- every ``NBLOCK``: the node number (first integer field) and the first three
  reals (x, y, z; reals a line leaves out are 0, as MAPDL writes them); the
  points are in the order of the node lines;
- every ``EBLOCK`` in the ``SOLID`` layout: material, type, ..., the node count
  (field 9), the element number (field 11) and the nodes, continued on the
  next line past the eighth. ``ET`` lines (and ``ETBLOCK``) tell each type's
  element: 4- and 10-node tetrahedra (SOLID285; SOLID187, SOLID92, ...) with
  their mid-side nodes all given or all left out; 8-node bricks (SOLID185,
  SOLID45, ...) as hexahedra or in their degenerate wedge (K=L, O=P), pyramid
  (M=N=O=P) and tetrahedron (K=L, M=N=O=P) forms; 20-node bricks (SOLID186,
  SOLID95, ...) in the same forms, the tetrahedron with its mid-side nodes Q,
  R, T, Y, Z, A giving a ten-node tetrahedron, and any form whose mid-side
  nodes are all left out as the linear element;
- ``CMBLOCK`` node and element components as point and cell sets, under their
  own (upper-case) names.

The meshio mesh keeps the file's numbers: ``points_id`` (the node number of
each point) and ``cells_id`` (the element numbers of each cell block).
Everything else (materials, sections, loads, solution settings) is left alone,
and kept byte for byte when the mesh is written back: :func:`patch_cdb` changes
the coordinate fields of the moved nodes' lines only, in the block's own field
widths, with the precision of its format (13 decimals for ``e20.13``).

Shells, beams, links, contact and other non-solid elements, quadratic
hexahedra, wedges and pyramids, and ``EBLOCK`` in the non-``SOLID`` layout are
refused with :class:`~solver.errors.UnsupportedElementError`, naming each kind
with its count.

The blocks are read in :mod:`solver.io.cdb_blocks` (their fixed-width fields in
:mod:`solver.io.cdb_fields`), the element types turned into cells or refused
in :mod:`solver.io.cdb_elements`, and the deck is written back by
:mod:`solver.io.cdb_patch`; here are the reader, which makes the mesh of the
cells and components, and the format's entry in :mod:`solver.io.registry`.
"""

from __future__ import annotations

import os

import meshio
import numpy as np

from .cdb_blocks import _Deck, _parse
from .cdb_elements import _cells, _refuse
from .cdb_fields import _count, _error, fortran_e, fortran_real
from .cdb_patch import node_line_count, patch_cdb
from .patchers import Patcher
from .read_bounds import ReadBounds, check_read_sizes
from .registry import FileFormat, keyword_sniffer, register_format

__all__ = ["read_cdb", "patch_cdb", "node_line_count", "fortran_real", "fortran_e", "CDB"]


class _Lookup:
    """Positions of ids (node or element numbers) in the array they were read in."""

    def __init__(self, ids: np.ndarray) -> None:
        self.order = np.argsort(ids, kind="stable")
        self.sorted = ids[self.order]

    def duplicate(self) -> int | None:
        """The position of the second occurrence of the first id given twice, or None."""
        same = np.flatnonzero(self.sorted[1:] == self.sorted[:-1])
        return int(self.order[same[0] + 1]) if same.size else None

    def find(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions of ``x`` (any shape) and whether each is there."""
        if not self.sorted.size:
            return np.zeros(x.shape, np.int64), np.zeros(x.shape, bool)
        pos = np.minimum(np.searchsorted(self.sorted, x), self.sorted.size - 1)
        return self.order[pos], self.sorted[pos] == x


# ------------------------------------------------------------------ reading

def read_cdb(path: str | os.PathLike[str], bounds: ReadBounds | None = None) -> meshio.Mesh:
    """Read an Ansys MAPDL archive (``.cdb``) into a :class:`meshio.Mesh`.

    Parameters
    ----------
    path : str or path
    bounds : ReadBounds, optional
        Most nodes and elements; ``NBLOCK`` and ``EBLOCK`` counts are checked before their rows are read.

    Returns
    -------
    meshio.Mesh
        Points (n, 3) in the order of the node lines; cell blocks ``tetra``, ``tetra10``,
        ``hexahedron``, ``wedge``, ``pyramid`` (meshio's node order), each in file order;
        node components as ``point_sets`` (0-based point indices), element components as
        ``cell_sets`` (indices per cell block). ``points_id`` (n,) holds the node numbers,
        ``cells_id`` the element numbers of each block.

    Raises
    ------
    UnreadableFileError
        A block cut short (``truncated_file``), a row that does not fit its format, a count that
        does not match the rows, a node or element number given twice, an element naming an
        undefined node or type, a component naming an undefined node or element; each names the
        line. ``too_many_points`` / ``too_many_cells`` over ``bounds``.
    UnsupportedElementError
        Non-solid elements, quadratic hexahedra, wedges and pyramids, or an ``EBLOCK`` without the
        ``SOLID`` key: each kind named with its count and element type.
    """
    path = os.fspath(path)
    name = os.path.basename(path)
    bounds = bounds or ReadBounds()
    with open(path, "rb") as fh:
        raw = fh.read()
    deck = _parse(raw, name, bounds)
    if not deck.node_ids.size:
        raise _error(name, None, "holds no node lines (no NBLOCK rows): there is no mesh in it", code="no_nodes")
    if not len(deck.fields):
        raise _error(name, None, f"holds {deck.node_ids.size} nodes but no elements (no EBLOCK rows)",
                     code="no_elements")
    check_read_sizes(name, deck.node_ids.size, len(deck.fields), bounds)
    nodes = _Lookup(deck.node_ids)
    _check_unique(name, "node", deck.node_ids, deck.node_lines, nodes, code="duplicate_node_number")
    _check_unique(name, "element", deck.fields[:, 10], deck.elem_lines, _Lookup(deck.fields[:, 10]),
                  code="unreadable_file")
    cells, refused = _cells(name, deck.fields, deck.nodes, deck.elem_lines, deck.types)
    if refused:
        raise _refuse(name, refused)
    return _mesh(name, deck, nodes, cells)


def _check_unique(name: str, what: str, ids: np.ndarray, lines: np.ndarray, lookup: _Lookup, code: str) -> None:
    """Refuse a node or element number defined twice, naming both lines."""
    dup = lookup.duplicate()
    if dup is not None:
        number = int(ids[dup])
        first = int(lines[np.flatnonzero(ids == number)[0]])
        raise _error(name, int(lines[dup]), f"{what} {number} is defined twice (first on line {first})",
                     code=code, **{what: number})


def _mesh(name: str, deck: _Deck, nodes: _Lookup, cells: dict[str, tuple[np.ndarray, np.ndarray]]) -> meshio.Mesh:
    """The meshio mesh of the cells, with the components as sets and the file's numbers kept."""
    blocks = [(kind, _connectivity(name, deck, nodes, rows, conn)) for kind, (rows, conn) in cells.items()]
    ids = [deck.fields[rows, 10] for rows, _ in cells.values()]
    point_sets, cell_sets = _sets(name, deck, nodes, ids)
    m = meshio.Mesh(deck.xyz, blocks, point_sets=point_sets, cell_sets=cell_sets)
    m.points_id = deck.node_ids
    m.cells_id = ids
    return m


def _connectivity(name: str, deck: _Deck, nodes: _Lookup, rows: np.ndarray, conn: np.ndarray) -> np.ndarray:
    """Point indices (k, c) of the node numbers ``conn`` of elements ``rows``: every node defined, none twice."""
    idx, found = nodes.find(conn)
    if not found.all():
        r, c = (int(x) for x in np.argwhere(~found)[0])
        eid = int(deck.fields[rows[r], 10])
        n = int((~found).any(axis=1).sum())
        raise _error(name, int(deck.elem_lines[rows[r]]), f"element {eid} refers to node {int(conn[r, c])}, which "
                     f"no NBLOCK defines ({_count(n, 'element')} with undefined nodes)", code="undefined_node",
                     element=eid, node=int(conn[r, c]))
    S = np.sort(idx, axis=1)
    repeats = np.flatnonzero((S[:, 1:] == S[:, :-1]).any(axis=1))
    if repeats.size:
        r = int(repeats[0])
        eid = int(deck.fields[rows[r], 10])
        listed = deck.nodes[rows[r]]
        raise _error(name, int(deck.elem_lines[rows[r]]), f"element {eid} repeats nodes {listed[listed != 0].tolist()} "
                     "in a way that is no hexahedron, wedge, pyramid or tetrahedron form", code="bad_connectivity",
                     element=eid)
    return idx


def _sets(name: str, deck: _Deck, nodes: _Lookup, ids: list[np.ndarray]
          ) -> tuple[dict[str, np.ndarray], dict[str, list[np.ndarray]]]:
    """Node components as point sets (point indices), element components as cell sets (indices per block)."""
    elements = _Lookup(np.concatenate(ids))
    offsets = np.cumsum([0] + [len(i) for i in ids])
    point_sets: dict[str, np.ndarray] = {}
    cell_sets: dict[str, list[np.ndarray]] = {}
    for label, entity, members, line in deck.components:
        pos, found = (nodes if entity == "NODE" else elements).find(members)
        if not found.all():
            what = "node" if entity == "NODE" else "element"
            raise _error(name, line, f"component {label!r} names {what} {int(members[~found][0])}, which the file does "
                         f"not define ({int((~found).sum())} undefined)",
                         code="undefined_node" if entity == "NODE" else "unreadable_file")
        pos = np.unique(pos)
        if entity == "NODE":
            point_sets[label] = pos
        else:
            cell_sets[label] = [pos[(pos >= lo) & (pos < hi)] - lo for lo, hi in zip(offsets[:-1], offsets[1:],
                                                                                   strict=True)]
    return point_sets, cell_sets


# ------------------------------------------------------------------ registration


#: The format's entry in :mod:`solver.io.registry`.
CDB = register_format(FileFormat(
    name="ansys-cdb", title="Ansys MAPDL archive (.cdb)", extensions=(".cdb",), aliases=("cdb", "mapdl"),
    sniff=keyword_sniffer(rb"^[ \t]*(?:NBLOCK|EBLOCK|CMBLOCK|ETBLOCK)[ \t]*,|^/(?:PREP7|COM|TITLE|BATCH|NOPR)\b"
                          rb"|^[ \t]*ET[ \t]*,[ \t]*\d+[ \t]*,"),
    telling=True, read=read_cdb,
    patcher=Patcher("ansys-cdb", ("cdb", "mapdl"), ("cdb",), lambda raw, n: node_line_count(raw) == n, patch_cdb),
    writes=False,
    reads="NBLOCK nodes; SOLID EBLOCK tets (4, 10 nodes), 8-node bricks and their wedge, pyramid and tet forms, "
          "20-node bricks in tet form; CMBLOCK components as sets; written back in place in each block's format",
    refuses="shells, beams, links, contact and other non-solid elements, quadratic hexahedra, wedges and pyramids, "
            "EBLOCKs without the SOLID key: UnsupportedElementError naming each kind and count"))
