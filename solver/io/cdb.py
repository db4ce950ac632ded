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
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

import meshio
import numpy as np

from ..errors import UnreadableFileError, UnsupportedElementError
from .patchers import Patcher
from .read_bounds import ReadBounds, check_read_sizes, too_many
from .registry import FileFormat, keyword_sniffer, register_format

__all__ = ["read_cdb", "patch_cdb", "node_line_count", "fortran_real", "fortran_e", "CDB"]

#: Most nodes an element may list (MAPDL's largest solids have 20).
MAX_ELEMENT_NODES = 64

# element numbers by how their node lists read (MAPDL Element Reference)
_TET4 = frozenset({285})
_TET10 = frozenset({87, 92, 98, 123, 168, 187, 221, 227, 232, 237})
_BRICK8 = frozenset({5, 30, 45, 46, 64, 65, 69, 70, 96, 97, 164, 185, 190, 278})
_BRICK20 = frozenset({90, 95, 122, 186, 220, 226, 231, 236, 279})

#: Element name prefixes by element number (for messages: ``181`` -> ``SHELL181``).
_PREFIX = {
    "SOLID": (5, 45, 46, 64, 65, 69, 70, 87, 90, 92, 95, 96, 97, 98, 122, 123, 164, 168, 185, 186, 187, 226, 227,
              231, 232, 236, 237, 278, 279, 285),
    "SOLSH": (190,),
    "FLUID": (29, 30, 38, 79, 80, 81, 116, 129, 130, 136, 220, 221),
    "SHELL": (28, 41, 43, 57, 61, 63, 91, 93, 99, 131, 132, 157, 163, 181, 208, 209, 281),
    "BEAM": (3, 4, 23, 24, 44, 54, 161, 188, 189),
    "LINK": (1, 8, 10, 11, 31, 32, 33, 34, 68, 160, 180),
    "PIPE": (16, 17, 18, 20, 59, 60, 288, 289),
    "ELBOW": (290,),
    "CABLE": (280,),
    "PLANE": (2, 13, 25, 35, 42, 53, 55, 67, 75, 77, 78, 82, 83, 121, 162, 182, 183, 222, 223, 230, 233, 238, 292,
              293),
    "MASS": (21, 71, 166),
    "COMBIN": (7, 14, 37, 39, 40),
    "COMBI": (165, 214, 250),
    "CONTAC": (12, 52),
    "CONTA": (171, 172, 173, 174, 175, 176, 177, 178),
    "TARGE": (169, 170),
    "SURF": (19, 22, 151, 152, 153, 154, 155, 156, 159, 251, 252),
    "MPC": (184,),
    "PRETS": (179,),
    "FOLLW": (201,),
    "MESH": (200,),
    "MATRIX": (27, 50),
    "INFIN": (9, 47, 110, 111, 257),
    "INTER": (192, 193, 194, 195, 202, 203, 204, 205),
    "REINF": (263, 264, 265),
}
_NAMES = {number: f"{prefix}{number}" for prefix, numbers in _PREFIX.items() for number in numbers}

#: What each element name prefix is, in words (singular, plural).
_WORDS = {
    "SHELL": ("shell element", "shell elements"), "BEAM": ("beam element", "beam elements"),
    "LINK": ("link element", "link elements"), "PIPE": ("pipe element", "pipe elements"),
    "ELBOW": ("elbow element", "elbow elements"), "CABLE": ("cable element", "cable elements"),
    "PLANE": ("2-D plane element", "2-D plane elements"), "MASS": ("point mass", "point masses"),
    "COMBIN": ("spring-damper", "spring-dampers"), "COMBI": ("spring-damper", "spring-dampers"),
    "CONTAC": ("contact element", "contact elements"), "CONTA": ("contact element", "contact elements"),
    "TARGE": ("contact target element", "contact target elements"),
    "SURF": ("surface effect element", "surface effect elements"),
    "MPC": ("multipoint constraint element", "multipoint constraint elements"),
    "PRETS": ("pretension element", "pretension elements"),
    "FOLLW": ("follower load element", "follower load elements"),
    "MESH": ("mesh-only element", "mesh-only elements"), "MATRIX": ("matrix element", "matrix elements"),
    "INFIN": ("infinite element", "infinite elements"), "INTER": ("interface element", "interface elements"),
    "REINF": ("reinforcing element", "reinforcing elements"),
}

#: Corner positions (in the 8- or 20-node brick's list I..P, Q..B) of each form of a brick, in meshio's
#: order: a wedge's triangles K-J-I and O-N-M, the first one's normal pointing away from the second.
_BRICK_CORNERS = {"hexahedron": [0, 1, 2, 3, 4, 5, 6, 7], "wedge": [2, 1, 0, 6, 5, 4], "pyramid": [0, 1, 2, 3, 4],
                  "tetra": [0, 1, 2, 4]}
#: Mid-side positions of each form of a 20-node brick (Q=8 on I-J ... B=19 on L-P), in meshio's order.
_BRICK_MIDS = {"hexahedron": list(range(8, 20)), "wedge": [9, 8, 11, 13, 12, 15, 18, 17, 16],
               "pyramid": [8, 9, 10, 11, 16, 17, 18, 19], "tetra": [8, 9, 11, 16, 17, 18]}
#: The quadratic cell type of each linear one.
_QUADRATIC = {"tetra": "tetra10", "hexahedron": "hexahedron20", "wedge": "wedge15", "pyramid": "pyramid13"}
#: The cell types read, in the order of the mesh's cell blocks.
_READ_TYPES = ("tetra", "tetra10", "hexahedron", "wedge", "pyramid")
#: Refused cell types, in words (singular, plural).
_OTHER = ("element of a kind tetmorph does not read", "elements of a kind tetmorph does not read")
_SHAPE_WORDS = {"hexahedron20": ("quadratic (20-node) hexahedron", "quadratic (20-node) hexahedra"),
                "wedge15": ("quadratic (15-node) wedge", "quadratic (15-node) wedges"),
                "pyramid13": ("quadratic (13-node) pyramid", "quadratic (13-node) pyramids")}

_COMMAND = re.compile(rb"^[ \t]*(NBLOCK|EBLOCK|CMBLOCK|ETBLOCK|ET)[ \t]*,([^\r\n]*)", re.IGNORECASE | re.MULTILINE)
#: The newline before the first line of a block that is not a row of numbers.
_END = re.compile(rb"\n(?![ \t]*[0-9])")
_NODE_FORMAT = re.compile(rb"^\(\s*(\d*)\s*i\s*(\d+)\s*,\s*(\d*)\s*e\s*(\d+)\s*\.\s*(\d+)\s*(?:e\s*(\d+))?\s*\)$",
                          re.IGNORECASE)
_BLANK_TO_END = re.compile(rb"\s*\Z")
_INT_FORMAT = re.compile(rb"^\(\s*(\d*)\s*i\s*(\d+)\s*\)$", re.IGNORECASE)
_REAL = re.compile(rb"^\s*([+-]?(?:\d+\.?\d*|\.\d+))(?:[EeDd]([+-]?\d+)|([+-]\d+))?\s*$")
_ENAME = re.compile(r"^([A-Za-z]*)\s*(\d+)$")


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


def _error(name: str, line: int | None, what: str, code: str = "unreadable_file", **details: object
           ) -> UnreadableFileError:
    where = f"{name!r} line {line}:" if line is not None else repr(name)
    return UnreadableFileError(f"{where} {what}", code=code, file=name, **({"line": line} if line else {}),
                               **details)


# ------------------------------------------------------------------ numbers


def fortran_real(text: bytes) -> float:
    """The value of a Fortran real field (blank is 0; ``D`` exponents; ``1.0-100`` without ``E``).

    Examples
    --------
    >>> fortran_real(b" 1.5000000000000E+00"), fortran_real(b"-2.5D-3"), fortran_real(b"1.0-100"), fortran_real(b"  ")
    (1.5, -0.0025, 1e-100, 0.0)
    """
    if not text.strip():
        return 0.0
    m = _REAL.match(text)
    if m is None:
        raise ValueError(f"not a real number: {text.decode('ascii', 'replace').strip()!r}")
    exp = m.group(2) or m.group(3) or b"0"
    return float(m.group(1) + b"e" + exp)


def fortran_e(x: float, w: int, d: int, e: int | None = None) -> str:
    """``x`` as MAPDL writes it with the Fortran format ``1PEw.d[Ee]``: one digit before the point, right-justified.

    Without ``Ee`` the exponent has two digits, and three without the ``E`` past 99, as Fortran writes
    it. A value the field cannot hold with ``d`` decimals is written with as many as fit.

    Parameters
    ----------
    x : float
    w, d : int
        Field width and decimals.
    e : int, optional
        Exponent digits.

    Returns
    -------
    str
        ``w`` characters.

    Raises
    ------
    ValueError
        ``x`` is not finite, or does not fit ``w`` columns with one decimal.

    Examples
    --------
    >>> fortran_e(1.0, 20, 13), fortran_e(-0.5, 20, 13)
    (' 1.0000000000000E+00', '-5.0000000000000E-01')
    >>> fortran_e(-0.28749388208227, 21, 13, 3), fortran_e(2.5e-120, 20, 13)
    ('-2.8749388208227E-001', ' 2.5000000000000-120')
    >>> fortran_e(-1.0 / 3.0, 12, 9)
    '-3.33333E-01'
    """
    if not np.isfinite(x):
        raise ValueError(f"{x} is not a finite coordinate")
    for dec in range(d, 0, -1):
        mant, _, ex = f"{x:.{dec}E}".partition("E")
        n = int(ex)
        if e is not None:
            text = f"{mant}E{n:+0{e + 1}d}" if abs(n) < 10 ** e else ""
        else:
            text = f"{mant}E{n:+03d}" if abs(n) < 100 else f"{mant}{n:+04d}" if abs(n) < 1000 else ""
        if text and len(text) <= w:
            return text.rjust(w)
    raise ValueError(f"{x!r} does not fit a field of {w} columns (format e{w}.{d}{'' if e is None else f'e{e}'})")


def _grid(rows: list[bytes], width: int) -> np.ndarray:
    """(n, width) uint8: each row cut or padded with blanks to ``width`` columns."""
    if not rows or width <= 0:
        return np.full((len(rows), max(width, 0)), 32, np.uint8)
    buf = b"".join(rows)
    if len(buf) != width * len(rows) or any(len(r) != width for r in rows):
        buf = b"".join([r[:width].ljust(width) for r in rows])
    return np.frombuffer(buf, np.uint8).reshape(len(rows), width)


def _field(A: np.ndarray, start: int, width: int) -> np.ndarray:
    """(n, width) uint8 copy of columns ``start`` .. ``start + width`` of ``A``, blanks past its end."""
    out = np.full((A.shape[0], width), 32, np.uint8)
    have = max(0, min(width, A.shape[1] - start))
    out[:, :have] = A[:, start:start + have]
    return out


def _as_text(F: np.ndarray) -> np.ndarray:
    """(n,) bytes strings of the rows of a (n, width) uint8 array."""
    return np.ascontiguousarray(F).view(f"S{F.shape[1]}").ravel()


def _ints(F: np.ndarray) -> tuple[np.ndarray, int | None]:
    """Integers of the fields ``F`` (n, width) uint8; blank fields are 0.

    Returns the values (n,) and the first row that is not an integer, or None (then the values
    are not to be used).
    """
    F = F.copy()
    F[(F == 32).all(axis=1), -1] = ord("0")
    text = _as_text(F)
    try:
        return text.astype(np.int64), None
    except (ValueError, OverflowError):
        pass
    bad = next((r for r, t in enumerate(text.tolist()) if not _is_int(t)), 0)
    return np.zeros(len(text), np.int64), bad


def _reals(F: np.ndarray) -> tuple[np.ndarray, int | None]:
    """Reals of the fields ``F`` (n, width) uint8 (blank is 0); the first row that is no real, or None."""
    F = F.copy()
    F[(F == 32).all(axis=1), -1] = ord("0")
    text = _as_text(F)
    try:
        return text.astype(np.float64), None
    except ValueError:
        pass
    out = np.empty(len(text))
    for r, t in enumerate(text.tolist()):
        try:
            out[r] = fortran_real(t)
        except ValueError:
            return out, r
    return out, None


def _count(n: int, what: str) -> str:
    """``n`` and ``what``, plural unless one: ``_count(2, "element")`` is ``"2 elements"``."""
    return f"{n} {what}{'' if n == 1 else 's'}"


def _shown(b: bytes) -> str:
    return b.decode("ascii", "replace").strip()


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


def _et_line(fields: tuple[str, ...], types: dict[int, tuple[int | None, str]]) -> None:
    """``ET,itype,ename``: type ``itype`` is element ``ename`` (``187`` or ``SOLID187``); parameters skipped."""
    if len(fields) < 2 or not fields[0].isdigit():
        return
    m = _ENAME.match(fields[1])
    types[int(fields[0])] = (int(m.group(2)) if m else None, fields[1].upper())


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


def _is_int(text: bytes) -> bool:
    try:
        int(text)
    except (ValueError, OverflowError):
        return False
    return True


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


# ------------------------------------------------------------------ elements -> cells


def _element_name(types: dict[int, tuple[int | None, str]], itype: int) -> str:
    number, written = types[itype]
    if number is None:
        return written
    return _NAMES.get(number, written if not written.isdigit() else f"element {number}")


def _forms(C: np.ndarray) -> np.ndarray:
    """The form of each 8-node brick's corner list ``C`` (m, 8): hexahedron, wedge, pyramid or tetra.

    Examples
    --------
    >>> _forms(np.array([[1, 2, 3, 4, 5, 6, 7, 8], [1, 2, 3, 3, 4, 4, 4, 4], [1, 2, 3, 3, 4, 5, 6, 6],
    ...                  [1, 2, 3, 4, 5, 5, 5, 5]])).tolist()
    ['hexahedron', 'tetra', 'wedge', 'pyramid']
    """
    kl = C[:, 2] == C[:, 3]
    top = (C[:, 4] == C[:, 5]) & (C[:, 5] == C[:, 6]) & (C[:, 6] == C[:, 7])
    op = C[:, 6] == C[:, 7]
    form = np.full(len(C), "hexahedron", dtype=object)
    form[kl & op & ~top] = "wedge"
    form[top & ~kl] = "pyramid"
    form[top & kl] = "tetra"
    return form


def _take(N: np.ndarray, cols: list[int]) -> np.ndarray:
    """Columns ``cols`` of ``N``, 0 past its width."""
    out = np.zeros((N.shape[0], len(cols)), np.int64)
    for k, c in enumerate(cols):
        if c < N.shape[1]:
            out[:, k] = N[:, c]
    return out


def _shapes(number: int, N: np.ndarray) -> list[tuple[str, np.ndarray, list[int]]]:
    """The cells of the elements of element number ``number`` whose node lists are ``N`` (m, k).

    Returns
    -------
    list of (str, (r,) int array, list of int)
        A cell type, the elements (rows of ``N``) of that type and the positions of the cell's nodes
        in their node lists (meshio's order). The type is ``""`` for elements that give some but
        not all of their mid-side nodes.
    """
    if number in _TET4 or number in _TET10:
        linear = np.full(len(N), "tetra", dtype=object)
        corners, mids = {"tetra": [0, 1, 2, 3]}, {"tetra": [4, 5, 6, 7, 8, 9] if number in _TET10 else []}
    else:
        linear = _forms(_take(N, list(range(8))))
        corners = _BRICK_CORNERS
        mids = _BRICK_MIDS if number in _BRICK20 else {k: [] for k in _BRICK_CORNERS}
    out = []
    for form in np.unique(linear).tolist():
        rows = np.flatnonzero(linear == form)
        given = (_take(N[rows], mids[form]) != 0).sum(axis=1)
        out.append((form, rows[given == 0], corners[form]))
        if mids[form]:
            out.append((_QUADRATIC[form], rows[given == len(mids[form])], corners[form] + mids[form]))
            out.append(("", rows[(given > 0) & (given < len(mids[form]))], []))
    return [(kind, rows, cols) for kind, rows, cols in out if rows.size]


def _cells(name: str, deck: _Deck) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], dict[tuple[str, str, str], int]]:
    """The elements as cells, and the refused ones counted.

    Returns
    -------
    cells : dict of str to (positions (k,), node numbers (k, c))
        By cell type: the elements (positions in ``deck.fields``, in file order) and their nodes.
    refused : dict of (str, str, str) to int
        ``(words, element, key) -> count``: ``("shell elements", "SHELL181, type 3", "SHELL181") -> 12``.
    """
    F, N, where, types = deck.fields, deck.nodes, deck.elem_lines, deck.types
    itypes = F[:, 1]
    undefined = np.flatnonzero(~np.isin(itypes, np.fromiter(types, np.int64, len(types))))
    if undefined.size:
        r = int(undefined[0])
        raise _error(name, int(where[r]), f"element {int(F[r, 10])} has type {int(itypes[r])}, which no ET line "
                     f"defines ({_count(undefined.size, 'element')} of undefined types)", element=int(F[r, 10]),
                     type=int(itypes[r]))
    parts: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    refused: dict[tuple[str, str, str], int] = {}
    for itype in np.unique(itypes).tolist():
        rows = np.flatnonzero(itypes == itype)
        number = types[itype][0]
        ename = _element_name(types, itype)
        label = f"{ename}, type {itype}"
        if number not in _TET4 | _TET10 | _BRICK8 | _BRICK20:
            prefix = _ENAME.match(ename)
            words = _WORDS.get(prefix.group(1) if prefix else "", _OTHER)
            refused[(words[1], label, ename)] = rows.size
            continue
        _check_count(name, F[rows], where[rows], number, label)
        for kind, sub, cols in _shapes(number, N[rows]):
            at = rows[sub]
            if kind == "":
                r = int(at[0])
                raise _error(name, int(where[r]), f"element {int(F[r, 10])} ({label}) gives some of its mid-side "
                             f"nodes but not all ({_count(at.size, 'such element')}): tetmorph reads quadratic "
                             "elements with every mid-side node, or linear ones with none", element=int(F[r, 10]))
            if kind in _SHAPE_WORDS:
                refused[(_SHAPE_WORDS[kind][1], label, kind)] = at.size
                continue
            parts.setdefault(kind, []).append((at, _take(N[at], cols)))
    cells = {}
    for kind in _READ_TYPES:
        if kind in parts:
            at = np.concatenate([p[0] for p in parts[kind]])
            conn = np.concatenate([p[1] for p in parts[kind]])
            order = np.argsort(at, kind="stable")
            cells[kind] = (at[order], conn[order])
    return cells, refused


def _check_count(name: str, F: np.ndarray, where: np.ndarray, number: int, label: str) -> None:
    """Refuse elements that list more nodes than their element has."""
    cap = 4 if number in _TET4 else 10 if number in _TET10 else 8 if number in _BRICK8 else 20
    over = np.flatnonzero(F[:, 8] > cap)
    if over.size:
        r = int(over[0])
        raise _error(name, int(where[r]), f"element {int(F[r, 10])} ({label}) lists {int(F[r, 8])} nodes; the "
                     f"element has {cap}", element=int(F[r, 10]))


def _refuse(name: str, refused: dict[tuple[str, str, str], int]) -> UnsupportedElementError:
    """The refusal of the elements tetmorph does not read, each kind in words with its count."""
    singular = {many: one for one, many in (*_WORDS.values(), *_SHAPE_WORDS.values(), _OTHER)}
    items = sorted(refused.items(), key=lambda kv: -kv[1])
    parts = [f"{count} {singular[words] if count == 1 else words} ({label})" for (words, label, _), count in items]
    said = parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
    types: dict[str, int] = {}
    for (_, _, key), count in items:
        types[key] = types.get(key, 0) + count
    return UnsupportedElementError(
        f"{name!r} holds {said}: tetmorph deforms solid elements (tetrahedra, hexahedra, wedges and pyramids; "
        "ten-node tetrahedra alone) and refuses the others rather than move part of a model", types=types, file=name)


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


def _parse(raw: bytes, name: str, bounds: ReadBounds) -> _Deck:
    blocks, types = _scan(raw, name)
    ids, xyz, node_lines = _nodes(raw, name, [b for b in blocks if b.key == "NBLOCK"], bounds)
    fields, nodes, elem_lines = _elements(raw, name, [b for b in blocks if b.key == "EBLOCK"], bounds)
    components = [c for b in blocks if b.key == "CMBLOCK" for c in [_component(raw, name, b, bounds)] if c]
    return _Deck(ids, xyz, node_lines, fields, nodes, elem_lines, types, components)


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
    cells, refused = _cells(name, deck)
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


# ------------------------------------------------------------------ writing back


def node_line_count(raw: bytes) -> int:
    r"""Number of node lines in the ``NBLOCK``\ s of a deck (-1 when its blocks cannot be read).

    Examples
    --------
    >>> node_line_count(b"NBLOCK,6,SOLID,2,2\n(3i8,6e20.13)\n       1       0       0\n"
    ...                 b"       2       0       0 1.0000000000000E+00\nN,R5.3,LOC,       -1,\n")
    2
    """
    try:
        blocks, _ = _scan(raw, "deck")
    except ValueError:  # UnreadableFileError included
        return -1
    return sum(raw.count(b"\n", b.start, b.end) for b in blocks if b.key == "NBLOCK")


def patch_cdb(raw: bytes, V: np.ndarray) -> bytes | None:
    """The deck ``raw`` with the coordinates of its node lines set to ``V``, every other byte kept.

    Each moved node's three coordinate fields are written in its ``NBLOCK``'s own format
    (:func:`fortran_e`: ``e20.13`` as `` 1.0000000000000E+00``), so with that format's precision;
    its node number, other integer fields and the reals past z keep their text. A node whose
    parsed coordinates equal its row of ``V`` keeps its line; a line that left out trailing zero
    coordinates gets them where they are no longer zero.

    Parameters
    ----------
    raw : bytes
        The deck as read.
    V : (n, 3) float array
        New positions, row k for the k-th node line of the deck.

    Returns
    -------
    bytes or None
        None when the deck has no ``NBLOCK``.

    Raises
    ------
    ValueError
        ``V`` does not have a row per node line, a value does not fit its field, or the deck
        cannot be read (:class:`~solver.errors.UnreadableFileError` is a ValueError).
    """
    V = np.asarray(V, dtype=np.float64)
    blocks = [b for b in _scan(raw, "deck")[0] if b.key == "NBLOCK"]
    if not blocks:
        return None
    count = sum(raw.count(b"\n", b.start, b.end) for b in blocks)
    if V.ndim != 2 or V.shape != (count, 3):
        raise ValueError(f"the deck has {count} node lines; the positions have shape {V.shape}")
    out: list[bytes] = []
    prev = k = 0
    for b in blocks:
        rows = b.rows(raw)
        f = _node_format("deck", b)
        _, P, written = _node_rows("deck", b, rows, f)
        W = V[k:k + len(rows)]
        k += len(rows)
        moved = np.flatnonzero((W != P).any(axis=1))
        texts = [_e_column(W[moved, j], f) for j in range(3)]
        for i, (r, keep) in enumerate(zip(moved.tolist(), _kept(W[moved], written[moved]).tolist(), strict=True)):
            rows[r] = _node_line(rows[r], "".join([texts[0][i], texts[1][i], texts[2][i]][:keep]), keep, f)
        out += [raw[prev:b.start], b"\n".join(rows), b"\n"]
        prev = b.end
    out.append(raw[prev:])
    return b"".join(out)


def _e_column(x: np.ndarray, f: _NodeFormat) -> list[str]:
    """:func:`fortran_e` of each of ``x`` (n,) in the reals of format ``f``.

    Python's ``%E`` writes what Fortran does where the exponent has two digits; three-digit
    exponents get their ``0`` put in. Values outside 1e-99 .. 1e99, and formats too narrow for
    a sign, go through :func:`fortran_e` one by one.

    Examples
    --------
    >>> _e_column(np.array([1.0, -2.5e-12]), _NodeFormat(3, 9, 6, 21, 13, 3))
    [' 1.0000000000000E+000', '-2.5000000000000E-012']
    >>> _e_column(np.array([-2.5e-120]), _NodeFormat(3, 8, 6, 20, 13, None))
    ['-2.5000000000000-120']
    """
    digits = 2 if f.e is None else f.e
    a = np.abs(x)
    plain = np.isfinite(x).all() and ((a == 0) | ((a >= 1e-99) & (a < 1e99))).all() and f.w >= f.d + 5 + digits
    if not plain or digits not in (2, 3):
        return [fortran_e(v, f.w, f.d, f.e) for v in x.tolist()]
    if digits == 2:
        return list(map(f"%{f.w}.{f.d}E".__mod__, x.tolist()))
    text = "\n".join(map(f"%{f.w - 1}.{f.d}E".__mod__, x.tolist()))
    return text.replace("E+", "E+0").replace("E-", "E-0").split("\n") if len(x) else []


def _kept(X: np.ndarray, written: np.ndarray) -> np.ndarray:
    """How many coordinate fields to write on each moved node's line.

    All three where the line had them (or more reals), else as many as it had or as its last
    non-zero coordinate needs.

    Examples
    --------
    >>> _kept(np.array([[1.0, 0, 0], [1.0, 2.0, 0], [0, 0, 0], [0, 0, 5.0]]), np.array([1, 0, 6, 1])).tolist()
    [1, 2, 3, 3]
    """
    nonzero = X != 0
    last = np.where(nonzero.any(axis=1), 3 - np.argmax(nonzero[:, ::-1], axis=1), 0)
    return np.where(written >= 3, 3, np.maximum(written, last))


def _node_line(row: bytes, reals: str, keep: int, f: _NodeFormat) -> bytes:
    """A node row with its first ``keep`` reals replaced by ``reals``: the integer fields and the reals past z kept."""
    cr = row.endswith(b"\r")
    body = row[:-1] if cr else row
    head = body[:f.ints * f.iw].ljust(f.ints * f.iw)
    tail = body[f.ints * f.iw + 3 * f.w:] if keep == 3 else b""
    return head + reals.encode("ascii") + tail + (b"\r" if cr else b"")


# ------------------------------------------------------------------ registration


#: The format's entry in :mod:`solver.io.registry`.
CDB = register_format(FileFormat(
    name="ansys-cdb", title="Ansys MAPDL archive (.cdb)", extensions=(".cdb",), aliases=("cdb", "mapdl"),
    sniff=keyword_sniffer(rb"^[ \t]*(?:NBLOCK|EBLOCK|CMBLOCK|ETBLOCK)[ \t]*,|^/(?:PREP7|COM|TITLE|BATCH|NOPR)\b"
                          rb"|^[ \t]*ET[ \t]*,[ \t]*\d+[ \t]*,"),
    read=read_cdb,
    patcher=Patcher("ansys-cdb", ("cdb", "mapdl"), ("cdb",), lambda raw, n: node_line_count(raw) == n, patch_cdb),
    writes=False,
    reads="NBLOCK nodes; SOLID EBLOCK tets (4, 10 nodes), 8-node bricks and their wedge, pyramid and tet forms, "
          "20-node bricks in tet form; CMBLOCK components as sets; written back in place in each block's format",
    refuses="shells, beams, links, contact and other non-solid elements, quadratic hexahedra, wedges and pyramids, "
            "EBLOCKs without the SOLID key: UnsupportedElementError naming each kind and count"))
