"""The bounds a mesh file is read under, and the typed refusals that name them.

:class:`ReadBounds` holds the most nodes, elements and expanded bytes a file may
declare or hold, with the settings that set each; the functions here refuse a
count over its bound (``too_many_points``, ``too_many_cells``, ``too_many_bytes``)
or a count the file could not hold (``truncated_file``). The size checks of the
format modules (:attr:`solver.io.registry.FileFormat.check_sizes`) and of
:mod:`solver.io.bounds` call them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..errors import UnreadableFileError
from ..limits import MAX_CELLS, MAX_EXPANDED_BYTES, MAX_POINTS

__all__ = ["ReadBounds", "check_block", "check_bounds", "check_holds", "check_node_tags", "check_read_sizes",
           "too_many", "declared_total"]


@dataclass(frozen=True)
class ReadBounds:
    """The most a mesh file may declare or expand to, and the names of the settings that hold each bound.

    Attributes
    ----------
    points, cells : int
        Most nodes and elements.
    expanded_bytes : int
        Most bytes a file's data arrays may take once read, in all: compressed arrays (VTU blocks, HDF5
        datasets) by what they expand to, uncompressed tables (legacy VTK, TetGen) by their declared counts.
    points_setting, cells_setting, bytes_setting : str
        Where each bound is set, named in the errors.
    """

    points: int = MAX_POINTS
    cells: int = MAX_CELLS
    expanded_bytes: int = MAX_EXPANDED_BYTES
    points_setting: str = "MAX_POINTS (solver/limits.py)"
    cells_setting: str = "MAX_CELLS (solver/limits.py)"
    bytes_setting: str = "MAX_EXPANDED_BYTES (solver/limits.py)"


def declared_total(pattern: bytes, head: bytes) -> int:
    r"""The sum of the counts the regular expression ``pattern`` (one group: the digits) finds in ``head``.

    Examples
    --------
    >>> declared_total(rb'NumberOfPoints="(\d+)"', b'<Piece NumberOfPoints="4"/><Piece NumberOfPoints="5"/>')
    9
    """
    return sum(int(x) for x in re.findall(pattern, head))


def too_many(name: str, what: str, declared: int, bounds: ReadBounds, *, held: bool = False) -> UnreadableFileError:
    """``too_many_points`` / ``too_many_cells`` / ``too_many_bytes`` for ``declared`` of ``what``.

    ``held``: the count is of a mesh already read, not of a file's declaration.
    """
    bound, setting, code, unit = {
        "points": (bounds.points, bounds.points_setting, "too_many_points", "nodes"),
        "cells": (bounds.cells, bounds.cells_setting, "too_many_cells", "elements"),
        "bytes": (bounds.expanded_bytes, bounds.bytes_setting, "too_many_bytes", "bytes of data"),
    }[what]
    said = (f"holds {declared:,} {unit}; tetmorph reads at most {bound:,} ({setting})" if held else
            f"declares {declared:,} {unit}; tetmorph reads at most {bound:,} ({setting}); nothing was read")
    return UnreadableFileError(f"{name!r} {said}", code=code, file=name, declared=declared, bound=bound,
                               setting=setting)


def check_read_sizes(name: str, points: int, cells: int, bounds: ReadBounds) -> None:
    """Refuse a mesh, once read, that holds more nodes or elements than ``bounds``.

    The bound on what a file declares (:func:`check_declared_sizes`) is checked before reading where
    the format declares counts; a format that declares none (Abaqus, Nastran, OBJ, ...) is held to
    the same settings here, so the bounds mean the same whatever the format.

    Raises
    ------
    UnreadableFileError
        ``too_many_points`` or ``too_many_cells``, naming the count, the bound and its setting.
    """
    for what, n, bound in (("points", points, bounds.points), ("cells", cells, bounds.cells)):
        if n > bound:
            raise too_many(name, what, n, bounds, held=True)


def check_bounds(name: str, bounds: ReadBounds, points: int = 0, cells: int = 0, nbytes: int = 0) -> None:
    """Refuse declared ``points``, ``cells`` or ``nbytes`` over their bounds (:func:`too_many`)."""
    for what, n, bound in (("points", points, bounds.points), ("cells", cells, bounds.cells),
                           ("bytes", nbytes, bounds.expanded_bytes)):
        if n > bound:
            raise too_many(name, what, n, bounds)


def check_holds(name: str, what: str, declared: int, least: int, size: int) -> None:
    """Refuse ``declared`` entries of at least ``least`` bytes each in a file of ``size`` bytes."""
    if declared * least > size:
        raise UnreadableFileError(
            f"{name!r} declares {declared:,} {what}, which need at least {declared * least:,} bytes; the file "
            f"has {size:,}: it is truncated or its count is wrong", code="truncated_file", file=name,
            declared=declared, size=size)


def check_node_tags(name: str, tag: int, bounds: ReadBounds) -> None:
    """Refuse node tags up to ``tag`` when arrays indexed by tag would be too large (Gmsh)."""
    if tag > 4 * bounds.points:
        raise UnreadableFileError(
            f"{name!r} declares node tags up to {tag:,}; tetmorph reads at most {bounds.points:,} nodes "
            f"({bounds.points_setting})", code="too_many_points", file=name, declared=tag, bound=bounds.points,
            setting=bounds.points_setting)


def check_block(name: str, section: str, n: int, total: int, code: str, bound: int) -> None:
    """Refuse a block of ``n`` entries in a section of ``total`` (a Gmsh 4.1 ``$Nodes`` or ``$Elements`` block)."""
    if n > total:
        raise UnreadableFileError(
            f"{name!r}: a ${section} block declares {n:,} entries, more than the {total:,} of the whole "
            "section: the file is inconsistent", code=code, file=name, declared=n, bound=min(total, bound))
