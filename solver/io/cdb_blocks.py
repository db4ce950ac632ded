"""The blocks of Ansys MAPDL archives (``.cdb``): where each one is, its Fortran format line, and its rows read.

A block is a header (``NBLOCK,6,SOLID,1041,1041``), a Fortran format line
(``(3i8,6e20.13)``) and rows of fixed-width fields up to its end line (``-1``;
a ``CMBLOCK`` ends after as many rows as its count of fields needs).
:func:`_scan` finds the blocks and the ``ET`` lines in file order, and
:func:`_parse` reads them into a :class:`_Deck`: the node numbers and
coordinates of every ``NBLOCK``, the fields and node lists (continued on the
rows past the first) of every ``SOLID`` ``EBLOCK``, and the node and element
components of every ``CMBLOCK``, their ranges expanded. A row that does not
fit its format, a count that does not match the rows and a block cut short are
refused, naming the line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..errors import UnsupportedElementError
from .cdb_elements import MAX_ELEMENT_NODES, _et_line
from .cdb_fields import _as_text, _error, _field, _grid, _ints, _is_int, _reals, _shown
from .read_bounds import ReadBounds, too_many

_COMMAND = re.compile(rb"^[ \t]*(NBLOCK|EBLOCK|CMBLOCK|ETBLOCK|ET)[ \t]*,([^\r\n]*)", re.IGNORECASE | re.MULTILINE)
#: The newline before the first line of a block that is not a row of numbers.
_END = re.compile(rb"\n(?![ \t]*[0-9])")
_NODE_FORMAT = re.compile(rb"^\(\s*(\d*)\s*i\s*(\d+)\s*,\s*(\d*)\s*e\s*(\d+)\s*\.\s*(\d+)\s*(?:e\s*(\d+))?\s*\)$",
                          re.IGNORECASE)
_BLANK_TO_END = re.compile(rb"\s*\Z")
_INT_FORMAT = re.compile(rb"^\(\s*(\d*)\s*i\s*(\d+)\s*\)$", re.IGNORECASE)


@dataclass(frozen=True)
class _Block:
    """One block of a deck: its header, its format line and where its rows are.

    Attributes
    ----------
    key : str
        The command, upper case (``"NBLOCK"``).
    fields : tuple of str
        The header's comma-separated fields after the command, stripped, comment dropped.
    line : int
        Line number (1-based) of the header.
    fmt : bytes
        The format line, stripped.
    start, end : int
        Byte offsets of the first row and of the line after the last row.
    first : int
        Line number of the first row.
    """

    key: str
    fields: tuple[str, ...]
    line: int
    fmt: bytes
    start: int
    end: int
    first: int

    def rows(self, raw: bytes) -> list[bytes]:
        """The block's rows, split at newlines (a carriage return before one is kept)."""
        text = raw[self.start:self.end]
        rows = text.split(b"\n")
        return rows[:-1] if text.endswith(b"\n") or not text else rows


@dataclass(frozen=True)
class _NodeFormat:
    """An ``NBLOCK`` format: ``ints`` integers of ``iw`` columns, ``reals`` reals ``Ew.d[Ee]``."""

    ints: int
    iw: int
    reals: int
    w: int
    d: int
    e: int | None

    @property
    def width(self) -> int:
        """Columns of a full row."""
        return self.ints * self.iw + self.reals * self.w

    @property
    def text(self) -> str:
        """The format as written, e.g. ``(3i8,6e20.13)``."""
        return f"({self.ints}i{self.iw},{self.reals}e{self.w}.{self.d}{'' if self.e is None else f'e{self.e}'})"


@dataclass
class _Deck:
    """What :func:`_parse` read: nodes, element rows, components and element types."""

    node_ids: np.ndarray
    xyz: np.ndarray
    node_lines: np.ndarray
    fields: np.ndarray
    nodes: np.ndarray
    elem_lines: np.ndarray
    types: dict[int, tuple[int | None, str]]
    components: list[tuple[str, str, np.ndarray, int]]


class _Lines:
    """Line numbers of byte offsets, counted on from the offset asked last."""

    def __init__(self, raw: bytes) -> None:
        self.raw, self.pos, self.line = raw, 0, 1

    def at(self, pos: int) -> int:
        if pos < self.pos:
            self.pos, self.line = 0, 1
        self.line += self.raw.count(b"\n", self.pos, pos)
        self.pos = pos
        return self.line


# ------------------------------------------------------------------ blocks


def _scan(raw: bytes, name: str) -> tuple[list[_Block], dict[int, tuple[int | None, str]]]:
    """The blocks of a deck, in file order, and its element types (``ET`` lines).

    Returns
    -------
    blocks : list of _Block
    types : dict of int to (int or None, str)
        Element type number -> (element number, element name as written).

    Raises
    ------
    UnreadableFileError
        A block without its format line or without its end (``truncated_file``).
    """
    lines = _Lines(raw)
    blocks: list[_Block] = []
    types: dict[int, tuple[int | None, str]] = {}
    pos = 0
    while True:
        m = _COMMAND.search(raw, pos)
        if m is None:
            return blocks, types
        key = m.group(1).decode("ascii").upper()
        fields = tuple(f.strip() for f in m.group(2).split(b"!", 1)[0].decode("ascii", "replace").split(","))
        line = lines.at(m.start())
        pos = m.end()
        if key == "ET":
            _et_line(fields, types)
            continue
        block = _block(raw, name, key, fields, line, m.end(), lines)
        blocks.append(block)
        pos = block.end
        if key == "ETBLOCK":
            _etblock(raw, block, types)


def _etblock(raw: bytes, block: _Block, types: dict[int, tuple[int | None, str]]) -> None:
    """``ETBLOCK`` rows: type number, element number, key options."""
    for row in block.rows(raw):
        parts = row.split()
        if len(parts) >= 2 and parts[0].isdigit() and parts[1].isdigit():
            types[int(parts[0])] = (int(parts[1]), parts[1].decode("ascii"))


def _block(raw: bytes, name: str, key: str, fields: tuple[str, ...], line: int, after: int, lines: _Lines
           ) -> _Block:
    """The block whose header ends at ``after``: its format line and the span of its rows."""
    fmt_start = raw.find(b"\n", after)
    fmt_end = raw.find(b"\n", fmt_start + 1) if fmt_start >= 0 else -1
    if fmt_end < 0:
        raise _error(name, line, f"the file ends after the {key} header, before its format line and rows: the file "
                     "is truncated", code="truncated_file")
    fmt = raw[fmt_start + 1:fmt_end].strip()
    start = fmt_end + 1
    first = line + 2
    if key == "CMBLOCK":
        end = _component_end(raw, name, fields, line, fmt, start)
    else:
        m = _END.search(raw, start - 1)
        end = len(raw) if m is None else m.start() + 1
        _check_end(raw, name, key, line, end, lines.at(end) if end < len(raw) else None)
    return _Block(key, fields, line, fmt, start, end, first)


def _check_end(raw: bytes, name: str, key: str, line: int, end: int, end_line: int | None) -> None:
    """Refuse a block that ends on anything but its end line (``-1``; ``N,R5.3,LOC,-1`` after nodes)."""
    nl = raw.find(b"\n", end)
    stop = raw[end:nl if nl >= 0 else len(raw)].strip()
    ends = "'-1' or N,R5.3,LOC,-1" if key == "NBLOCK" else "'-1'"
    if not stop:
        if _BLANK_TO_END.match(raw, end):
            raise _error(name, line, f"the file ends inside this {key}, before its end line ({ends}): the file is "
                         "truncated", code="truncated_file")
        raise _error(name, end_line, f"a blank line inside the {key} of line {line}, before its end line ({ends})")
    if re.match(rb"-1(?![0-9])", stop):
        return
    if key == "NBLOCK" and (stop[:2].upper() == b"N," or stop.startswith(b"!")):
        return
    raise _error(name, end_line, f"{_shown(stop)[:40]!r} where the {key} of line {line} should go on or end "
                 f"(with {ends})")


def _component_end(raw: bytes, name: str, fields: tuple[str, ...], line: int, fmt: bytes, start: int) -> int:
    """The end of a ``CMBLOCK``'s rows: as many as its count of fields needs."""
    count, per, width = _component_head(name, fields, line, fmt)
    need = -(-count // per)
    pos = start
    for k in range(need):
        nl = raw.find(b"\n", pos)
        if nl < 0:
            if pos < len(raw) and k == need - 1 and len(raw[pos:].rstrip()) % width == 0:
                return len(raw)  # the last line of the file, its fields whole (right-justified)
            raise _error(name, line, f"the file ends inside the component {fields[0].upper()!r}, which declares "
                         f"{count} fields on {need} line{'s' if need > 1 else ''}: the file is truncated",
                         code="truncated_file")
        pos = nl + 1
    return pos


def _component_head(name: str, fields: tuple[str, ...], line: int, fmt: bytes) -> tuple[int, int, int]:
    """``CMBLOCK,name,entity,count`` and ``(8i10)``: the count, fields per line and their width."""
    if len(fields) < 3 or not fields[2].isdigit():
        raise _error(name, line, "CMBLOCK needs a name, an entity and a count of fields (CMBLOCK,NAME,NODE,12)")
    m = _INT_FORMAT.match(fmt)
    if m is None:
        raise _error(name, line + 1, f"CMBLOCK format {_shown(fmt)!r} is not an integer format like (8i10)")
    per, width = int(m.group(1) or 1), int(m.group(2))
    if not (1 <= per <= 64 and 1 <= width <= 20):
        raise _error(name, line + 1, f"CMBLOCK format {_shown(fmt)!r}: {per} fields of {width} columns")
    return int(fields[2]), per, width


# ------------------------------------------------------------------ NBLOCK


def _node_format(name: str, block: _Block) -> _NodeFormat:
    m = _NODE_FORMAT.match(block.fmt)
    if m is None:
        raise _error(name, block.first - 1, f"NBLOCK format {_shown(block.fmt)!r} is not like (3i8,6e20.13)")
    ints, iw, reals, w, d = (int(g) if g else 1 for g in m.groups()[:5])
    f = _NodeFormat(ints, iw, reals, w, d, int(m.group(6)) if m.group(6) else None)
    if not (1 <= f.ints <= 16 and 1 <= f.iw <= 20 and 3 <= f.reals <= 16 and 3 <= f.w <= 40 and f.d < f.w
            and (f.e is None or 1 <= f.e <= 4)):
        raise _error(name, block.first - 1, f"NBLOCK format {_shown(block.fmt)!r}: no node table has these fields")
    return f


def _node_rows(name: str, block: _Block, rows: list[bytes], f: _NodeFormat
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node numbers (n,), coordinates (n, 3) and number of reals written (n,) of the rows of an ``NBLOCK``.

    Raises
    ------
    UnreadableFileError
        A row longer than the format, without a node number, or with a field that is no number
        (naming the line, the columns and the text).
    """
    body = [r.rstrip() for r in rows]
    if not body:
        return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, np.int64)
    lens = np.fromiter(map(len, body), np.int64, len(body))
    long = np.flatnonzero(lens > f.width)
    if long.size:
        r = int(long[0])
        raise _error(name, block.first + r, f"NBLOCK declares format {f.text} ({f.width} columns) but the line has "
                     f"{int(lens[r])} characters", format=f.text)
    short = np.flatnonzero(lens < f.ints * f.iw)
    if short.size:
        r = int(short[0])
        raise _error(name, block.first + r, f"a node line of {int(lens[r])} characters: the format {f.text} starts "
                     f"with {f.ints * f.iw} columns of integers", format=f.text)
    A = _grid(body, min(f.ints * f.iw + 3 * f.w, int(lens.max())))
    ids, bad = _ints(_field(A, 0, f.iw))
    if bad is None and (ids <= 0).any():
        bad = int(np.flatnonzero(ids <= 0)[0])
    if bad is not None:
        raise _error(name, block.first + bad, f"no node number in columns 1-{f.iw} (format {f.text}): "
                     f"{_shown(body[bad][:f.iw])!r}", format=f.text)
    xyz = np.empty((len(body), 3))
    for j in range(3):
        at = f.ints * f.iw + j * f.w
        xyz[:, j], bad = _reals(_field(A, at, f.w))
        if bad is not None:
            raise _error(name, block.first + bad, f"node {int(ids[bad])}: columns {at + 1}-{at + f.w} (format "
                         f"{f.text}) hold {_shown(body[bad][at:at + f.w])!r}, not a number", format=f.text)
    nonfinite = np.flatnonzero(~np.isfinite(xyz).all(axis=1))
    if nonfinite.size:
        r = int(nonfinite[0])
        raise _error(name, block.first + r, f"node {int(ids[r])} has a coordinate that is not a finite number")
    written = np.clip(-(-(lens - f.ints * f.iw) // f.w), 0, f.reals)
    return ids, xyz, written


def _nodes(raw: bytes, name: str, blocks: list[_Block], bounds: ReadBounds
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node numbers (n,), coordinates (n, 3) and line numbers (n,) of every ``NBLOCK``, in file order."""
    ids, xyz, where = [], [], []
    total = 0
    for b in blocks:
        declared = int(b.fields[3]) if len(b.fields) > 3 and b.fields[3].isdigit() else None
        if declared is not None and declared > bounds.points:
            raise too_many(name, "points", declared, bounds)
        n = raw.count(b"\n", b.start, b.end)
        total += n
        if total > bounds.points:
            raise too_many(name, "points", total, bounds)
        if declared is not None and declared != n:
            raise _error(name, b.line, f"NBLOCK declares {declared} nodes but {n} node lines follow")
        f = _node_format(name, b)
        i, x, _ = _node_rows(name, b, b.rows(raw), f)
        ids.append(i)
        xyz.append(x)
        where.append(b.first + np.arange(n))
    if not ids:
        return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, np.int64)
    return np.concatenate(ids), np.concatenate(xyz), np.concatenate(where)


# ------------------------------------------------------------------ EBLOCK


def _element_rows(name: str, block: _Block, rows: list[bytes]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The elements of a ``SOLID`` ``EBLOCK``.

    Returns
    -------
    fields : (m, 11) int64 array
        Material, type, real, section, coordinate system, birth/death, solid model reference, shape,
        node count, (unused), element number.
    nodes : (m, k) int64 array
        Node numbers, 0 past each element's count (and where the file gives 0: dropped mid-side nodes).
    lines : (m,) int64 array
        Line number of each element's first row.
    """
    m = _INT_FORMAT.match(block.fmt)
    if m is None:
        raise _error(name, block.first - 1, f"EBLOCK format {_shown(block.fmt)!r} is not an integer format "
                     "like (19i8)")
    per, iw = int(m.group(1) or 1), int(m.group(2))
    if not (12 <= per <= 40 and 1 <= iw <= 20):
        raise _error(name, block.first - 1, f"EBLOCK format {_shown(block.fmt)!r}: a SOLID row has 11 fields and "
                     "at least one node")
    body = [r.rstrip() for r in rows]
    lens = np.fromiter(map(len, body), np.int64, len(body))
    long = np.flatnonzero(lens > per * iw)
    if long.size:
        r = int(long[0])
        raise _error(name, block.first + r, f"EBLOCK declares format {_shown(block.fmt)} ({per * iw} columns) but "
                     f"the line has {int(lens[r])} characters")
    count, bad = _ints(_grid([r[8 * iw:9 * iw] for r in body], iw))
    if bad is not None:
        raise _error(name, block.first + bad, f"EBLOCK field 9 (columns {8 * iw + 1}-{9 * iw}, the node count) is "
                     f"{_shown(body[bad][8 * iw:9 * iw])!r}, not a whole number")
    heads = _element_heads(name, block, count, per)
    short = np.flatnonzero(lens[heads] <= 11 * iw)
    if short.size:
        r = int(heads[short[0]])
        raise _error(name, block.first + r, f"an element line of {int(lens[r])} characters: its 11 fields of "
                     f"{iw} columns and its first node take at least {11 * iw + 1}")
    H = _int_rows(name, block, body, heads, per, iw)
    nn = H[:, 8]
    cap = max(1, int(nn.max())) if heads.size else 1
    N = np.zeros((heads.size, cap), np.int64)
    first = per - 11
    N[:, :min(cap, first)] = H[:, 11:11 + min(cap, first)]
    for c in range(1, -(-(cap - first) // per) + 1 if cap > first else 1):
        lo = first + (c - 1) * per
        sel = np.flatnonzero(nn > lo)
        k = min(per, cap - lo)
        N[sel, lo:lo + k] = _int_rows(name, block, body, heads[sel] + c, per, iw)[:, :k]
    N[np.arange(cap)[None, :] >= nn[:, None]] = 0
    return H[:, :11], N, block.first + heads


def _int_rows(name: str, block: _Block, body: list[bytes], which: np.ndarray, per: int, iw: int) -> np.ndarray:
    """The ``per`` integer fields of ``iw`` columns (blank: 0) of rows ``which`` of ``body``: (len(which), per)."""
    picked = body if which.size == len(body) and (which == np.arange(len(body))).all() else \
        [body[r] for r in which.tolist()]
    values, bad = _ints(_grid(picked, per * iw).reshape(len(picked) * per, iw))
    if bad is not None:
        r, j = divmod(bad, per)
        row = int(which[r])
        raise _error(name, block.first + row, f"EBLOCK field {j + 1} (columns {j * iw + 1}-{(j + 1) * iw}) is "
                     f"{_shown(body[row][j * iw:(j + 1) * iw])!r}, not a whole number")
    return values.reshape(len(picked), per)


def _element_heads(name: str, block: _Block, count: np.ndarray, per: int) -> np.ndarray:
    """The rows that start an element: each is followed by the rows its nodes past the first line fill.

    ``count`` (rows,) is field 9 of every row (the node count where the row starts an element).
    """
    first = per - 11
    if not count.size or ((count >= 1) & (count <= first)).all():
        return np.arange(count.size)
    heads = []
    r, n = 0, count.size
    values = count.tolist()
    while r < n:
        k = values[r]
        if not 1 <= k <= MAX_ELEMENT_NODES:
            raise _error(name, block.first + r, f"an element with {k} nodes (field 9): elements have 1 to "
                         f"{MAX_ELEMENT_NODES}")
        heads.append(r)
        r += 1 + (-(-(k - first) // per) if k > first else 0)
    if r > n:
        raise _error(name, block.first + heads[-1], f"the element of this line has {values[heads[-1]]} nodes, "
                     f"but the EBLOCK of line {block.line} ends before its last node line")
    return np.asarray(heads, np.int64)


def _elements(raw: bytes, name: str, blocks: list[_Block], bounds: ReadBounds
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fields (m, 11), nodes (m, k) and line numbers (m,) of the elements of every ``EBLOCK``."""
    fields, nodes, where = [], [], []
    total = 0
    for b in blocks:
        declared = int(b.fields[3]) if len(b.fields) > 3 and b.fields[3].isdigit() else None
        if declared is not None and declared > bounds.cells:
            raise too_many(name, "cells", declared, bounds)
        if len(b.fields) < 2 or b.fields[1].upper() != "SOLID":
            count = declared if declared is not None else raw.count(b"\n", b.start, b.end)
            raise UnsupportedElementError(
                f"{name!r} line {b.line}: an EBLOCK without the SOLID key ({count} elements; Workbench writes "
                "contact, target and surface elements so): tetmorph reads the SOLID layout, which names each "
                "element's node count", types={"EBLOCK without SOLID": count}, file=name, line=b.line)
        f, n, w = _element_rows(name, b, b.rows(raw))
        total += len(f)
        if total > bounds.cells:
            raise too_many(name, "cells", total, bounds)
        if declared is not None and declared != len(f):
            raise _error(name, b.line, f"EBLOCK declares {declared} elements but holds {len(f)}")
        fields.append(f)
        nodes.append(n)
        where.append(w)
    if not fields:
        return np.zeros((0, 11), np.int64), np.zeros((0, 1), np.int64), np.zeros(0, np.int64)
    cap = max(n.shape[1] for n in nodes)
    nodes = [np.pad(n, ((0, 0), (0, cap - n.shape[1]))) for n in nodes]
    return np.concatenate(fields), np.concatenate(nodes), np.concatenate(where)


# ------------------------------------------------------------------ CMBLOCK


def _component(raw: bytes, name: str, block: _Block, bounds: ReadBounds) -> tuple[str, str, np.ndarray, int] | None:
    """``(name, entity, ids, line)`` of a ``CMBLOCK`` of nodes or elements (ranges expanded); None for others."""
    count, per, width = _component_head(name, block.fields, block.line, block.fmt)
    entity = block.fields[1].upper()
    if entity not in ("NODE", "ELEM"):
        return None
    label = block.fields[0].upper()
    rows = [r.rstrip() for r in block.rows(raw)]
    long = [r for r, row in enumerate(rows) if len(row) > per * width]
    if long:
        raise _error(name, block.first + long[0], f"component {label!r}: the line has {len(rows[long[0]])} "
                     f"characters; its format {_shown(block.fmt)} has {per * width} columns")
    F = _grid(rows, per * width).reshape(len(rows), per, width)
    filled = ~(F == 32).all(axis=2)
    text = _as_text(F[filled]) if filled.any() else np.zeros(0, "S1")
    try:
        flat = text.astype(np.int64)
    except (ValueError, OverflowError):
        bad = next(i for i, t in enumerate(text.tolist()) if not _is_int(t))
        r, j = (int(x) for x in np.argwhere(filled)[bad])
        raise _error(name, block.first + r, f"component {label!r}: columns {j * width + 1}-{(j + 1) * width} hold "
                     f"{_shown(text[bad])!r}, not a whole number") from None
    if flat.size != count:
        raise _error(name, block.line, f"component {label!r} declares {count} fields and holds {flat.size}")
    bound = bounds.points if entity == "NODE" else bounds.cells
    return label, entity, _expand(name, label, block.line, flat, bound, entity == "NODE"), block.line


def _expand(name: str, label: str, line: int, v: np.ndarray, bound: int, nodes: bool = True) -> np.ndarray:
    """Component ids from MAPDL's list, where ``-k`` after ``j`` means ``j+1 .. k`` as well.

    Examples
    --------
    >>> _expand("x.cdb", "A", 1, np.array([1, -4, 9, 11, -12]), 100).tolist()
    [1, 2, 3, 4, 9, 11, 12]
    """
    neg = v < 0
    if not neg.any():
        if (v == 0).any():
            raise _error(name, line, f"component {label!r} lists id 0")
        return v
    k = np.flatnonzero(neg)
    if k[0] == 0 or neg[k - 1].any() or (v == 0).any():
        raise _error(name, line, f"component {label!r}: a range (-k) must follow a positive id")
    lo, hi = v[k - 1], -v[k]
    if (hi < lo).any():
        r = int(np.flatnonzero(hi < lo)[0])
        raise _error(name, line, f"component {label!r}: the range {int(lo[r])} to {int(hi[r])} runs backwards")
    size = int((hi - lo).sum()) + int((~neg).sum())
    if size > bound:
        raise _error(name, line, f"component {label!r} ranges over {size:,} ids, more than the {bound:,} "
                     f"{'nodes' if nodes else 'elements'} tetmorph reads",
                     code="too_many_points" if nodes else "too_many_cells", declared=size, bound=bound)
    lengths = hi - lo
    starts = np.repeat(lo + 1 - np.concatenate([[0], np.cumsum(lengths)[:-1]]), lengths)
    filled = starts + np.arange(int(lengths.sum()))
    return np.sort(np.concatenate([v[~neg], filled]))


# ------------------------------------------------------------------ deck


def _parse(raw: bytes, name: str, bounds: ReadBounds) -> _Deck:
    blocks, types = _scan(raw, name)
    ids, xyz, node_lines = _nodes(raw, name, [b for b in blocks if b.key == "NBLOCK"], bounds)
    fields, nodes, elem_lines = _elements(raw, name, [b for b in blocks if b.key == "EBLOCK"], bounds)
    components = [c for b in blocks if b.key == "CMBLOCK" for c in [_component(raw, name, b, bounds)] if c]
    return _Deck(ids, xyz, node_lines, fields, nodes, elem_lines, types, components)
