"""LS-DYNA keyword decks: a deck and the files it includes read into a :class:`KeywordDeck`.

:func:`read_deck` walks the deck and its includes, reads the ``*NODE`` and
``*ELEMENT_SOLID`` cards, the node and part sets (``*SET_NODE...``,
``*SET_PART...``) and the ``*PART`` headings, counts the element keywords
tetmorph does not deform, and turns the node ids of elements and sets into
point indices, refusing a node or element defined twice and an element or set
naming an undefined node.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import UnreadableFileError
from .lsdyna_cards import _Block, _DiskLoader, _in, _Loader, _walk, _where
from .lsdyna_elements import (
    _CELL_ORDER,
    _KEPT_ELEMENTS,
    _check_shapes,
    _shapes,
    _solid_cards,
    _solid_options,
    _Solids,
    _unsupported_count,
)
from .lsdyna_fields import _bad_field, _free, _int, _node_cards
from .read_bounds import ReadBounds, too_many

# ----------------------------------------------------------------------------------------------------------------
# sets and parts


def _id_cards(block: _Block, name: str, skip: int, width: int,
              count: int = 8) -> tuple[int, list[tuple[int, list[int]]]]:
    """A set keyword: the id on its header card, and the ids on each following card (zeros dropped).

    ``skip`` cards come before the header (the ``_TITLE`` card).
    """
    cards = block.lines(blank=bool(skip))
    if len(cards) <= skip:
        raise UnreadableFileError(f"{name!r}, {_where(block.file, block.line)}: *{block.name} has no header card",
                                  code="bad_set", file=name, line=block.line, **_in(block.file))
    head_line, head = cards[skip]
    try:
        sid = _int(_free(head)[0] if b"," in head else head[:width])
    except ValueError:
        raise _bad_field(name, block, head_line, head, "a set id") from None
    out = []
    for line, text in cards[skip + 1:]:
        if not text.strip():
            continue
        try:
            values = ([_int(f) for f in _free(text)] if b"," in text else
                      [_int(text[j * width:(j + 1) * width]) for j in range(count)])
        except ValueError:
            raise _bad_field(name, block, line, text, "ids") from None
        out.append((line, values))
    return sid, out


@dataclass
class _Sets:
    """Node and part sets as the deck defines them, by set id."""

    nodes: dict[int, list[tuple[str, int, np.ndarray]]] = field(default_factory=dict)  # (file, line, node ids)
    node_ranges: dict[int, list[tuple[int, int, int]]] = field(default_factory=dict)  # (first, last, step)
    node_adds: dict[int, list[tuple[str, int, list[int]]]] = field(default_factory=dict)
    parts: dict[int, list[int]] = field(default_factory=dict)
    part_ranges: dict[int, list[tuple[int, int]]] = field(default_factory=dict)
    titles: dict[str, str] = field(default_factory=dict)


def _read_set(block: _Block, name: str, sets: _Sets) -> None:
    """Add a ``*SET_NODE...`` or ``*SET_PART...`` keyword to ``sets`` (forms tetmorph does not read are left)."""
    kind = "NODE" if block.name.startswith("SET_NODE") else "PART"
    opts = {o for o in block.name[len("SET_") + len(kind):].split("_") if o}
    title = "TITLE" in opts
    opts -= {"TITLE", "COLLECT"}
    width = 20 if block.fmt == "long" else 10
    if kind == "NODE" and opts in ({"LIST", "GENERATE"}, {"LIST", "GENERATE", "INCREMENT"}):
        step = "INCREMENT" in opts
        sid, cards = _id_cards(block, name, int(title), width)
        for _, values in cards:
            group = 3 if step else 2
            for j in range(0, len(values) - group + 1, group):
                b, e = values[j], values[j + 1]
                inc = values[j + 2] if step else 1
                if b or e:
                    sets.node_ranges.setdefault(sid, []).append((b, e, inc if inc > 0 else 1))
    elif kind == "NODE" and opts <= {"LIST"}:
        sid, cards = _id_cards(block, name, int(title), width)
        for line, values in cards:
            ids = np.asarray([v for v in values if v], np.int64)
            sets.nodes.setdefault(sid, []).append((block.file, line, ids))
        sets.nodes.setdefault(sid, [])
    elif kind == "NODE" and opts == {"ADD"}:
        sid, cards = _id_cards(block, name, int(title), width)
        for line, values in cards:
            sets.node_adds.setdefault(sid, []).append((block.file, line, [v for v in values if v > 0]))
    elif kind == "PART" and opts <= {"LIST"}:
        sid, cards = _id_cards(block, name, int(title), width)
        sets.parts.setdefault(sid, []).extend(v for _, values in cards for v in values if v)
    elif kind == "PART" and opts == {"LIST", "GENERATE"}:
        sid, cards = _id_cards(block, name, int(title), width)
        for _, values in cards:
            sets.part_ranges.setdefault(sid, []).extend(
                (values[j], values[j + 1]) for j in range(0, len(values) - 1, 2) if values[j] or values[j + 1])
    else:
        return
    if title:
        head = block.lines(blank=True)
        if head and head[0][1].strip():
            sets.titles[f"SET_{kind}_{sid}"] = head[0][1].decode("utf-8", "replace").strip()


def _read_parts(block: _Block, sets: _Sets) -> None:
    """The headings of a ``*PART`` keyword's parts, kept as titles of the ``PART_<pid>`` sets."""
    width = 20 if block.fmt == "long" else 10
    cards = block.lines(blank=True)
    pairs = range(0, len(cards) - 1, 2) if block.name == "PART" else range(0, min(len(cards) - 1, 1))
    for j in pairs:
        heading, card = cards[j][1], cards[j + 1][1]
        try:
            pid = _int(_free(card)[0] if b"," in card else card[:width])
        except ValueError:
            continue
        if pid > 0 and heading.strip():
            sets.titles[f"PART_{pid}"] = heading.decode("utf-8", "replace").strip()


# ----------------------------------------------------------------------------------------------------------------
# the deck


@dataclass
class KeywordDeck:
    """What an LS-DYNA keyword deck holds, as :func:`read_deck` reads it.

    Attributes
    ----------
    node_ids : (n,) int64 array
        The ``*NODE`` ids, in reading order (the deck's, its includes' where their ``*INCLUDE`` is).
    points : (n, 3) float64 array
        Their positions.
    cells : dict of str to tuple
        By meshio type (``"tetra"``, ``"tetra10"``, ``"hexahedron"``, ``"wedge"``, ``"pyramid"``):
        ``(element ids (m,), part ids (m,), point indices (m, k))`` in reading order.
    point_sets : dict of str to (k,) int64 array
        ``SET_NODE_<sid>``: sorted point indices.
    part_sets : dict of str to list of int
        ``SET_PART_<sid>``: the part ids it lists.
    titles : dict of str to str
        Set name to the deck's title for it (``*PART`` headings, ``_TITLE`` cards).
    unsupported : dict of str to int
        Element keywords tetmorph does not deform (``"*ELEMENT_SHELL"``) and their element counts.
    files : list of str
        The included files, relative to the deck's folder, in reading order.
    """

    node_ids: np.ndarray
    points: np.ndarray
    cells: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
    point_sets: dict[str, np.ndarray]
    part_sets: dict[str, list[int]]
    titles: dict[str, str]
    unsupported: dict[str, int]
    files: list[str]


def _parse(data: bytes, loader: _Loader) -> KeywordDeck:
    """Read a deck's bytes (and its includes through ``loader``) into a :class:`KeywordDeck`."""
    name, bounds = loader.name, loader.bounds
    ids: list[np.ndarray] = []
    xyz: list[np.ndarray] = []
    where: list[tuple[str, np.ndarray]] = []
    solids: list[_Solids] = []
    sets = _Sets()
    unsupported: dict[str, int] = {}
    n_points = n_cells = 0
    for block in _walk(data, loader):
        if block.name == "NODE":
            i, x, _, _, numbers = _node_cards(block, name)
            ids.append(i)
            xyz.append(x)
            where.append((block.file, numbers))
            n_points += len(i)
            if n_points > bounds.points:
                raise too_many(name, "points", n_points, bounds, held=True)
        elif block.name.startswith("ELEMENT_SOLID") and _solid_options(block.name) is not None:
            s = _solid_cards(block, name)
            solids.append(s)
            n_cells += len(s.eids)
            if n_cells > bounds.cells:
                raise too_many(name, "cells", n_cells, bounds, held=True)
        elif block.name.startswith("ELEMENT_"):
            if block.name.startswith(_KEPT_ELEMENTS):
                continue
            count = _unsupported_count(block)
            if count:
                key = f"*{block.name}"
                unsupported[key] = unsupported.get(key, 0) + count
        elif block.name.startswith(("SET_NODE", "SET_PART")):
            _read_set(block, name, sets)
        elif block.name == "PART" or block.name.startswith("PART_"):
            _read_parts(block, sets)
    node_ids = np.concatenate(ids) if ids else np.zeros(0, np.int64)
    points = np.concatenate(xyz) if xyz else np.zeros((0, 3))
    order = np.argsort(node_ids, kind="stable")
    sorted_ids = node_ids[order]
    dup = np.flatnonzero(sorted_ids[1:] == sorted_ids[:-1])
    if dup.size:
        a, b = int(order[dup[0]]), int(order[dup[0] + 1])
        lines = [_row_line(where, r) for r in (a, b)]
        raise UnreadableFileError(f"{name!r} defines node {int(sorted_ids[dup[0]])} twice ({' and '.join(lines)}); "
                                  f"{dup.size:,} node ids are defined more than once", code="duplicate_node",
                                  file=name, node=int(sorted_ids[dup[0]]), count=int(dup.size))

    top = int(sorted_ids[-1]) if len(sorted_ids) else 0
    lookup = None
    if 0 < top <= 4 * len(sorted_ids) + 1024:  # ids dense enough for a table from id to point
        lookup = np.full(top + 2, -1, np.int64)
        lookup[node_ids] = np.arange(len(node_ids))

    def index(nodes: np.ndarray, what: Callable[[int], tuple[str, int, dict[str, Any]]]) -> np.ndarray:
        if lookup is not None:
            found = lookup[np.clip(nodes, 0, top + 1)]
            ok = found >= 0
            if ok.all():
                return found
        pos = np.searchsorted(sorted_ids, nodes)
        pos_c = np.minimum(pos, max(len(sorted_ids) - 1, 0))
        ok = (pos < len(sorted_ids)) & (sorted_ids[pos_c] == nodes) if len(sorted_ids) else np.zeros(nodes.shape, bool)
        if not ok.all():
            flat = int(np.flatnonzero(~ok.reshape(-1))[0])
            node = int(nodes.reshape(-1)[flat])
            text, line, details = what(flat)
            raise UnreadableFileError(f"{name!r}, {text} names node {node}, which the deck does not define"
                                      + (" (a blank node field)" if node == 0 else ""), code="undefined_node",
                                      file=name, node=node, line=line, **details)
        return order[pos_c]

    cells: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
    seen_eids: list[np.ndarray] = []
    for s in solids:
        shapes = _shapes(s)
        for kind, (rows, conn) in shapes.items():
            def what(flat: int, rows: np.ndarray = rows, width: int = conn.shape[1],
                     s: _Solids = s) -> tuple[str, int, dict[str, Any]]:
                r = int(rows[flat // width])
                line = int(s.lines[r])
                return (f"{_where(s.file, line)} (*{s.keyword}): element {int(s.eids[r])}", line,
                        {"element": int(s.eids[r])})
            idx = index(conn, what)
            cells.setdefault(kind, []).append((s.eids[rows], s.pids[rows], idx))
        _check_shapes(s, shapes, name)
        seen_eids.append(s.eids)
    if seen_eids:
        e = np.sort(np.concatenate(seen_eids))
        dup = np.flatnonzero(e[1:] == e[:-1])
        if dup.size:
            raise UnreadableFileError(f"{name!r} defines solid element {int(e[dup[0]])} twice; {dup.size:,} element "
                                      "ids are defined more than once", code="bad_element_line", file=name,
                                      element=int(e[dup[0]]), count=int(dup.size))
    point_sets = _point_sets(sets, sorted_ids, order, name, index)
    part_sets: dict[str, list[int]] = {}
    for sid, pids in sets.parts.items():
        part_sets[f"SET_PART_{sid}"] = sorted(set(pids))
    all_pids = np.unique(np.concatenate([s.pids for s in solids])) if solids else np.zeros(0, np.int64)
    for sid, ranges in sets.part_ranges.items():
        chosen = {int(p) for b, e in ranges for p in all_pids[(all_pids >= b) & (all_pids <= e)]}
        part_sets[f"SET_PART_{sid}"] = sorted(chosen | set(part_sets.get(f"SET_PART_{sid}", [])))
    merged = {k: (np.concatenate([a for a, _, _ in v]), np.concatenate([b for _, b, _ in v]),
                  np.concatenate([c for _, _, c in v])) for k, v in cells.items()}
    return KeywordDeck(node_ids, points, {k: merged[k] for k in _CELL_ORDER if k in merged}, point_sets, part_sets,
                       sets.titles, unsupported, list(loader.order))


def _row_line(where: list[tuple[str, np.ndarray]], row: int) -> str:
    """Where the card of point ``row`` is (file and line)."""
    for f, nums in where:
        if row < len(nums):
            return _where(f, int(nums[row]))
        row -= len(nums)
    return "?"


def _point_sets(sets: _Sets, sorted_ids: np.ndarray, order: np.ndarray, name: str,
                index: Callable[..., np.ndarray]) -> dict[str, np.ndarray]:
    """``SET_NODE_<sid>``: point indices of the node sets (lists, generated ranges, unions)."""
    out: dict[str, np.ndarray] = {}
    for sid, cards in sets.nodes.items():
        parts = []
        for file, line, ids in cards:
            def what(flat: int, file: str = file, line: int = line,
                     sid: int = sid) -> tuple[str, int, dict[str, Any]]:
                return f"{_where(file, line)}: node set {sid}", line, {"set": sid, **_in(file)}
            parts.append(index(ids, what))
        out[f"SET_NODE_{sid}"] = np.unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)
    for sid, ranges in sets.node_ranges.items():
        parts = [out.get(f"SET_NODE_{sid}", np.zeros(0, np.int64))]
        for b, e, inc in ranges:
            lo, hi = np.searchsorted(sorted_ids, b, "left"), np.searchsorted(sorted_ids, e, "right")
            chosen = sorted_ids[lo:hi]
            parts.append(order[lo:hi][(chosen - b) % inc == 0])
        out[f"SET_NODE_{sid}"] = np.unique(np.concatenate(parts))
    pending = dict(sets.node_adds)
    for _ in range(len(pending) + 1):
        if not pending:
            break
        for sid, adds in list(pending.items()):
            refs = [r for _, _, values in adds for r in values]
            if all(f"SET_NODE_{r}" in out for r in refs):
                out[f"SET_NODE_{sid}"] = np.unique(np.concatenate(
                    [out.get(f"SET_NODE_{sid}", np.zeros(0, np.int64))] + [out[f"SET_NODE_{r}"] for r in refs]))
                del pending[sid]
    if pending:
        sid, adds = next(iter(pending.items()))
        file, line, _ = adds[0]
        missing = sorted({r for _, _, values in adds for r in values if f"SET_NODE_{r}" not in out})
        raise UnreadableFileError(f"{name!r}, {_where(file, line)}: *SET_NODE_ADD {sid} joins node sets {missing} "
                                  "that the deck does not define (or that join each other)", code="bad_set",
                                  file=name, set=sid, missing=missing[:100], line=line, **_in(file))
    return {k: v.astype(np.int64) for k, v in out.items()}


def read_deck(path: str | os.PathLike[str], bounds: ReadBounds | None = None) -> KeywordDeck:
    """Read an LS-DYNA keyword deck and the files it includes.

    Parameters
    ----------
    path : str or path
        The deck (``.k``, ``.key``, ``.dyn``).
    bounds : ReadBounds, optional
        Most nodes, elements and bytes (the deck and its includes together) read.

    Returns
    -------
    KeywordDeck
        Nodes, solids by type, sets, and the element keywords tetmorph does not deform (not refused here).

    Raises
    ------
    UnreadableFileError
        A card that cannot be read, a node or element defined twice, an element or set naming an undefined
        node, an include outside the deck's folder, missing, repeated or cyclic, more than ``bounds``.
    UnsupportedElementError
        A solid whose repeated nodes make no known shape.
    """
    path = os.fspath(path)
    with open(path, "rb") as fh:
        data = fh.read()
    loader = _DiskLoader(path, bounds)
    if len(data) > loader.bounds.expanded_bytes:
        raise too_many(loader.name, "bytes", len(data), loader.bounds, held=True)
    loader.total = len(data)
    return _parse(data, loader)
