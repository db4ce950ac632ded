"""LS-DYNA keyword decks (``.k``, ``.key``, ``.dyn``): read, and written back in place.

What is read: ``*NODE`` cards in each of LS-DYNA's input formats: small (``I8, 3E16``), I10
(``I10, 3E16``: ``*KEYWORD I10=Y`` or a ``%`` after the keyword), long (every
field 20 wide: ``*KEYWORD LONG=Y`` or a ``+`` after the keyword, ``-`` going
back to small), and free format (comma-separated fields, line by line).
``*KEYWORD LONG=S`` is LS-DYNA's "read small keyword input" and reads as small.
``$`` lines are comments; keyword names may be written in any case. Reading
stops at ``*END`` (the end of the file it is in).

``*ELEMENT_SOLID`` (also ``_ORTHO``, ``_DOF`` and ``_TET4TOTET10``) in the
one-card form (``EID PID N1 ... N8``) and the two-card form (``EID PID`` on
the first card, ``N1 ... N8`` or ``N1 ... N10`` on the second). A solid's
repeated nodes say its shape, as LS-DYNA writes it:

========================================  ======================================
nodes on the card                          read as
========================================  ======================================
``N1 N2 N3 N4`` (``N5 .. N8`` blank)       ``tetra`` ``N1 N2 N3 N4``
``N1 N2 N3 N4 N4 N4 N4 N4``                ``tetra`` ``N1 N2 N3 N4``
``N1 N2 N3 N3 N5 N5 N5 N5``                ``tetra`` ``N1 N2 N3 N5``
``N1 N2 N3 N4 N5 N5 N5 N5``                ``pyramid`` ``N1 .. N5``
``N1 N2 N3 N4 N5 N5 N6 N6``                ``wedge`` ``N1 N2 N5 N4 N3 N6``
``N1 N2 N3 N3 N5 N6 N7 N7``                ``wedge`` ``N1 N2 N3 N5 N6 N7``
eight different nodes                      ``hexahedron``
``N1 .. N10`` on a second card             ``tetra10``, LS-DYNA's node order being
                                           meshio's (corners, then the mid-side
                                           nodes of edges 1-2, 2-3, 3-1, 1-4,
                                           2-4, 3-4)
========================================  ======================================

``*ELEMENT_SOLID_TET4TOTET10`` holds 4-node tetrahedra that LS-DYNA turns into
10-node ones when it starts (the mid-side nodes are not in the deck): they are
read as ``tetra``, whose corners are what the deck holds and what moves.

Node ids and element ids stay as given: the :class:`meshio.Mesh` carries
``points_id`` (the node ids, one per point) and ``cells_id`` / ``cells_part``
(per cell block, the element ids and part ids).

Sets. Each part (``PID`` of the solids) is an element set ``PART_<pid>``;
``*SET_NODE`` / ``*SET_NODE_LIST`` (``_TITLE``, ``_COLLECT``),
``*SET_NODE_LIST_GENERATE`` (``_INCREMENT``) and ``*SET_NODE_ADD`` are node
sets ``SET_NODE_<sid>``; ``*SET_PART`` / ``*SET_PART_LIST`` (``_GENERATE``)
are element sets ``SET_PART_<sid>`` (the elements of the listed parts). Sets
are named by their ids, which are unique and what the deck's own cards
refer to; the ``*PART`` headings and ``_TITLE`` cards are kept in the mesh's
``set_titles`` (``{"PART_3": "bracket"}``).

``*INCLUDE`` is followed, in reading order and up to :data:`MAX_INCLUDE_DEPTH`
files deep, for file names relative to the deck's folder (and, failing that,
to the including file's folder) that stay inside the deck's folder; an
absolute name or one that climbs out with ``..`` is refused
(``include_outside``), a missing file is ``include_missing``, and a file
included twice, an include cycle or a chain too deep ``bad_include``.
Points are numbered in reading order: the node cards of an included file
come where its ``*INCLUDE`` is. ``*INCLUDE_PATH`` is ignored.

What is refused: tetmorph deforms volume meshes. A deck with shells, beams, thick shells,
discrete, seatbelt, SPH or higher-order solid elements is refused with
:class:`~solver.errors.UnsupportedElementError`, naming each kind in words
with its count ("1,024 shell elements (*ELEMENT_SHELL) and 12 beam elements
(*ELEMENT_BEAM)"), also when it holds solids: moving the solids' nodes under
shells glued to them would leave the shells' other nodes behind. Point
masses and inertias (``*ELEMENT_MASS``, ``*ELEMENT_INERTIA``) and plot
elements (``*ELEMENT_PLOTEL``) sit on nodes and are kept as they are.
Positions the deck moves itself (``*NODE_TRANSFORM``, ``*INCLUDE_TRANSFORM``)
and the other ``*INCLUDE_`` forms are refused. Every defect of the text (a
field that is not a number, a card cut short, a node defined twice, an
element naming an undefined node) is an
:class:`~solver.errors.UnreadableFileError` naming the file, the line and
the ids.

Written back: :func:`patch` and :func:`patch_tree` copy the deck (and its included files)
byte for byte and rewrite only the X, Y, Z fields of the node cards whose
node moved, each in its own columns (16 wide in small and I10 format, 20 in
long format; in free format the comma-separated field, its blanks kept):
the shortest text that reads back exactly where it fits, else the most
significant digits that do (:func:`field_text`). A zero move gives back
every file byte for byte.

Where it is: :mod:`solver.io.lsdyna_cards` (keyword lines, the include walk),
:mod:`solver.io.lsdyna_fields` (card formats, ``*NODE`` cards),
:mod:`solver.io.lsdyna_elements` (``*ELEMENT_SOLID`` forms and shapes, the
elements refused), :mod:`solver.io.lsdyna_deck` (:func:`read_deck`) and
:mod:`solver.io.lsdyna_patch` (:func:`patch`, :func:`patch_tree`); this
module registers the format, sniffs it and reads a deck as a mesh.
"""

from __future__ import annotations

import os
import re

import meshio
import numpy as np

from ..errors import UnreadableFileError, UnsupportedElementError
from .lsdyna_cards import MAX_INCLUDE_DEPTH, includes
from .lsdyna_deck import KeywordDeck, read_deck
from .lsdyna_elements import _words
from .lsdyna_patch import field_text, node_line_count, patch, patch_tree
from .patchers import Patcher
from .read_bounds import ReadBounds, check_read_sizes
from .registry import FileFormat, register_format

__all__ = ["KeywordDeck", "read_deck", "read", "sniff", "includes", "patch", "patch_tree", "node_line_count",
           "field_text", "MAX_INCLUDE_DEPTH", "LSDYNA"]


def read(path: str | os.PathLike[str], bounds: ReadBounds | None = None) -> meshio.Mesh:
    """Read a deck as a :class:`meshio.Mesh` of its solids, refusing the elements tetmorph does not deform.

    Parameters
    ----------
    path : str or path
    bounds : ReadBounds, optional

    Returns
    -------
    meshio.Mesh
        ``points`` (n, 3) in reading order (row k: the k-th node card), cells by meshio type, ``point_sets``
        (``SET_NODE_<sid>``), ``cell_sets`` (``PART_<pid>``, ``SET_PART_<sid>``), and the attributes
        ``points_id`` (n,), ``cells_id`` and ``cells_part`` (per cell block), ``set_titles``.

    Raises
    ------
    UnreadableFileError
        As :func:`read_deck`; ``no_nodes`` for a deck without node cards.
    UnsupportedElementError
        Shells, beams, discrete, SPH, thick shells, higher-order solids: each kind named with its count.
    """
    path = os.fspath(path)
    name = os.path.basename(path)
    bounds = bounds or ReadBounds()
    deck = read_deck(path, bounds)
    if deck.unsupported:
        solid = sum(len(c[0]) for c in deck.cells.values())
        raise UnsupportedElementError(
            f"{name!r} holds {_words(deck.unsupported)}"
            + (f" (beside {solid:,} solid elements)" if solid else " (and no solid elements)") +
            ": tetmorph deforms volume meshes (tetrahedra, hexahedra, wedges, pyramids) and refuses other elements "
            "rather than leave them behind. Morph a deck (or an include) that holds the solid parts alone.",
            types=dict(deck.unsupported))
    if not len(deck.node_ids):
        raise UnreadableFileError(f"{name!r} defines no nodes (no *NODE cards): there is no mesh in it",
                                  code="no_nodes", file=name)
    check_read_sizes(name, len(deck.points), sum(len(c[0]) for c in deck.cells.values()), bounds)
    kinds = list(deck.cells)
    cells = [meshio.CellBlock(k, deck.cells[k][2]) for k in kinds]
    cell_sets: dict[str, list[np.ndarray]] = {}
    pids = [deck.cells[k][1] for k in kinds]
    for b, p in enumerate(pids):  # the elements of each part, block by block, in reading order
        order = np.argsort(p, kind="stable")
        parts, first = np.unique(p[order], return_index=True)
        for pid, rows in zip(parts.tolist(), np.split(order, first[1:]), strict=True):
            per = cell_sets.setdefault(f"PART_{pid}", [np.zeros(0, np.int64) for _ in kinds])
            per[b] = rows.astype(np.int64)
    for set_name, listed in deck.part_sets.items():
        cell_sets[set_name] = [np.flatnonzero(np.isin(p, listed)) for p in pids]
    m = meshio.Mesh(deck.points, cells, point_sets=dict(deck.point_sets), cell_sets=cell_sets)
    m.points_id = deck.node_ids
    m.cells_id = [deck.cells[k][0] for k in kinds]
    m.cells_part = pids
    m.set_titles = dict(deck.titles)
    return m


# ----------------------------------------------------------------------------------------------------------------
# format detection


_LS_ONLY = re.compile(rb"^\*(?:(?:element|section|mat|set|part|control|database|boundary|define|contact|constrained|"
                      rb"eos|hourglass|include|load|initial|node)_[a-z]|part[ \t]*\r?$|include[ \t]*\r?$|"
                      rb"end[ \t]*\r?$|node[ \t]*[+%-])", re.IGNORECASE | re.MULTILINE)
_ABAQUS_ONLY = re.compile(rb"^\*\s*(?:heading\b|element\s*,|node\s*,|nset\b|elset\b|step\b|material\s*,|"
                          rb"solid\s+section\b|instance\b|assembly\b)", re.IGNORECASE | re.MULTILINE)
_NODE_THEN_CARD = re.compile(rb"^\*node[ \t]*\r?\n(?:\$[^\n]*\n)*([^\n]*)", re.IGNORECASE | re.MULTILINE)


def sniff(head: bytes, size: int | None = None) -> bool:
    r"""Whether the first bytes of a file are an LS-DYNA keyword deck (never an Abaqus deck).

    A ``*KEYWORD`` line says so; otherwise a keyword only LS-DYNA has (``*ELEMENT_SOLID``, ``*SET_NODE_LIST``,
    ``*PART`` alone on its line, ``*END``, ...) or a ``*NODE`` whose first card has fixed columns (Abaqus
    separates fields by commas), unless the head has Abaqus' own keywords (``*HEADING``, ``*ELEMENT, TYPE=``).

    Examples
    --------
    >>> sniff(b"*KEYWORD\n*NODE\n"), sniff(b"$ model\n*NODE\n       1             0.0             0.0\n")
    (True, True)
    >>> sniff(b"*Heading\n*Node\n1, 0., 0., 0.\n*Element, type=C3D4\n1, 1, 2, 3, 4\n")
    False
    """
    head = head[:8192]
    if re.search(rb"^\*keyword\b", head, re.IGNORECASE | re.MULTILINE):
        return True
    if _ABAQUS_ONLY.search(head):
        return False
    if _LS_ONLY.search(head):
        return True
    m = _NODE_THEN_CARD.search(head)
    return bool(m and b"," not in m.group(1) and re.match(rb"^\s*\d+\s", m.group(1)))


def _accepts(data: bytes, n: int) -> bool:
    return node_line_count(data) == n


#: The format's entry in :data:`solver.io.registry.FORMATS`.
LSDYNA = register_format(FileFormat(
    name="lsdyna", title="LS-DYNA keyword deck (.k)", extensions=(".k", ".key", ".dyn"),
    aliases=("k", "keyword", "ls-dyna"), sniff=sniff, telling=True, read=read,
    patcher=Patcher("lsdyna", ("k", "keyword", "ls-dyna"), ("k", "key", "dyn"), _accepts, patch,
                    includes=includes, patch_tree=patch_tree),
    writes=False,
    reads="*NODE (small, I10, long and free format), *ELEMENT_SOLID tetrahedra (degenerate 8-node, 4-node, two-card, "
          "10-node, TET4TOTET10), hexahedra, wedges, pyramids; parts and *SET_NODE / *SET_PART as sets; *INCLUDE "
          "inside the deck's folder",
    refuses="shell, beam, thick shell, discrete, SPH and higher-order solid elements (counted by keyword), "
            "*INCLUDE outside the deck's folder, *NODE_TRANSFORM and *INCLUDE_TRANSFORM",
))
