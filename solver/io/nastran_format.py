"""Nastran bulk data (``.bdf``, ``.nas``, ``.fem``): the format's entry in the registry, its reader and diagnosis.

:func:`solver.io.nastran.read_nastran` reads a deck with meshio's reader (bulk
data alone included); GRID cards given in local coordinate systems (CP) are
then placed in the basic system (:mod:`solver.io.nastran_coords`).
:func:`solver.io.patch_bdf.patch_bdf` writes the deck back with new GRID
coordinates in each card's own field format. A reader's failure is named as
a deck without ``BEGIN BULK``, a deck cut inside a card, or the element card
that names a grid no GRID card defines.
"""

from __future__ import annotations

import os
import re
import warnings
from typing import Any

import meshio
import numpy as np

from ..errors import MAX_IDS, UnreadableFileError
from .diagnose import check_last_line, undefined_node_error
from .guarded import stop_at_end
from .nastran import NASTRAN_TYPES, grid_cards, read_nastran
from .nastran_coords import GridPositions
from .patch_bdf import grid_count, patch_bdf
from .patchers import Patcher
from .registry import FileFormat, register_format

__all__ = ["NASTRAN", "sniff", "read", "diagnose", "undefined_bdf_node"]

_CARDS = re.compile(rb"^(BEGIN\s+BULK|GRID[*,\s]|CTETRA|CHEXA|SOL\s|CEND)", re.IGNORECASE | re.MULTILINE)


def sniff(head: bytes, size: int | None = None) -> bool:
    r"""Whether a file's first bytes hold a Nastran card at a line start (``BEGIN BULK``, ``GRID``, ``CTETRA``...).

    Examples
    --------
    >>> sniff(b"SOL 101\nCEND\nBEGIN BULK\n"), sniff(b"$ grids\nGRID,1,,0.,0.,0.\n"), sniff(b"*NODE\n")
    (True, True, False)
    """
    return _CARDS.search(head) is not None


# ------------------------------------------------------------------ reading


def read(path: str, bounds: Any) -> meshio.Mesh:
    """A deck through :func:`read_nastran`, its GRID cards placed in the basic system.

    Raises
    ------
    UnreadableFileError
        ``truncated_file`` for a reader that keeps reading at the end of a cut
        deck; a coordinate system that cannot be placed, naming the GRID cards
        given in it (``undefined_coordinate_system``...).
    """
    with warnings.catch_warnings(), stop_at_end("nastran"):
        warnings.simplefilter("ignore")
        m = read_nastran(path)
    _basic_coordinates(m, path, os.path.basename(path))
    return m


def _basic_coordinates(m: meshio.Mesh, path: str, name: str) -> None:
    """Place GRID cards given in local coordinate systems (CP field) in the basic system, in ``m``.

    meshio reads each GRID's fields as written; :class:`~solver.io.nastran_coords.GridPositions`
    turns those of a CORD2R, CORD2C or CORD2S system into basic positions. A system that cannot be
    placed (undefined, a loop of RIDs, a CORD1x card, points in a line) is refused, naming the GRID.
    """
    cp = m.point_data.pop("nastran:ref", None)  # meshio's name for the CP field (it leaves blank fields out)
    if cp is None or not np.any(np.asarray(cp) != 0):
        return
    with open(path, "rb") as fh:
        lines = fh.read().splitlines(keepends=True)
    try:
        cards = grid_cards(lines)
    except ValueError as e:
        raise UnreadableFileError(f"{name!r}: {e}", code="unreadable_file", file=name) from None
    try:
        grids = GridPositions.of(lines, cards)
    except UnreadableFileError as e:  # named here with the file, and every GRID given in the same system
        cid = e.details.get("chain", [e.details.get("system")])[0]
        ids = [c.id for c in cards if c.cp == cid]
        more = f"; {len(ids)} GRID cards are given in system {cid}" if len(ids) > 1 else ""
        raise UnreadableFileError(f"{name!r}: {e.message}{more}", code=e.code, file=name, grids=ids[:MAX_IDS],
                                  count=len(ids), **e.details) from None
    if len(cards) != len(m.points):
        raise UnreadableFileError(f"{name!r}: {len(cards)} GRID cards where meshio read {len(m.points)} nodes; "
                                  "their positions in local coordinate systems cannot be placed",
                                  code="unreadable_file", file=name)
    points = np.array(m.points, dtype=np.float64)
    local = grids.cp != 0
    points[local] = grids.basic[local]
    m.points = points


# ------------------------------------------------------------------ failures


def undefined_bdf_node(data: bytes) -> tuple[int, int, int, str, int] | None:
    r"""The first element card of a Nastran deck that names a grid no GRID card defines.

    Only single-line element cards are checked field by field (the first line of
    a continued card gives its first six grids).

    Returns
    -------
    (element, grid, line, card, count) or None

    Examples
    --------
    >>> undefined_bdf_node(b"BEGIN BULK\nGRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nCTETRA,7,1,1,2,3,4\nENDDATA\n")
    (7, 3, 4, 'CTETRA', 1)
    """
    lines = data.splitlines(keepends=True)
    try:
        grids = {c.id for c in grid_cards(lines)}
    except ValueError:
        return None
    cards = {c for c, _ in NASTRAN_TYPES.values()}
    bad = []
    for k, raw in enumerate(lines):
        line = raw.rstrip(b"\r\n").decode("ascii", "replace")
        fields = line.split(",") if "," in line else [line[i:i + 8] for i in range(0, min(len(line), 72), 8)]
        card = fields[0].strip().rstrip("*") if fields else ""
        if card not in cards:
            continue
        try:
            eid = int(fields[1])
            ids = [int(f) for f in fields[3:9] if f.strip() and f.strip()[0] not in "+*"]
        except (ValueError, IndexError):
            continue
        missing = [g for g in ids if g not in grids]
        if missing:
            bad.append((eid, missing[0], k + 1, card))
    if not bad:
        return None
    return (*bad[0], len(bad))


def diagnose(path: str, data: bytes, exc: BaseException) -> UnreadableFileError | None:
    """An element naming an undefined grid, a deck without ``BEGIN BULK``, or one cut inside a card."""
    name = os.path.basename(path)
    if isinstance(exc, KeyError):
        found = undefined_bdf_node(data)
        if found is not None:
            return undefined_node_error(name, *found)
    if "BEGIN BULK" in str(exc):
        return UnreadableFileError(f"{name!r} has no BEGIN BULK line: a Nastran deck's GRID and element "
                                   "cards follow it", code="no_nodes", file=name)
    if "Premature EOF" in str(exc):
        return UnreadableFileError(f"{name!r} ends inside a card, before ENDDATA: the file is truncated",
                                   code="truncated_file", file=name)
    return None


#: The format's entry in :data:`solver.io.registry.FORMATS`.
NASTRAN = register_format(FileFormat(
    name="nastran", title="Nastran bulk data deck (.bdf/.nas)", extensions=(".bdf", ".nas", ".fem"),
    aliases=("bdf", "nas"), sniff=sniff, sniff_order=1000, telling=True,
    read=read, check_complete=check_last_line, diagnose=diagnose, nodes_where="no GRID cards after BEGIN BULK",
    patcher=Patcher("nastran", ("bdf", "nas"), ("bdf", "nas", "fem"), lambda raw, n: grid_count(raw) == n,
                    patch_bdf),
    writes=True,
    reads="GRID cards in small, large and free field, in the basic system or a CORD2R, CORD2C or CORD2S system; "
          "CTETRA (4, 10 nodes), CHEXA, CPENTA and CPYRAM elements (meshio's reader); bulk data alone "
          "(OptiStruct .fem); property ids as material regions; the GRID coordinates written back in place "
          "in each card's field format",
    refuses="a deck without BEGIN BULK (no_nodes) or cut inside a card (truncated_file), an element naming an "
            "undefined grid (undefined_node), a coordinate system that cannot be placed "
            "(undefined_coordinate_system, cyclic_coordinate_system, unsupported_coordinate_system, "
            "invalid_coordinate_system)"))
