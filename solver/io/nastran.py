"""Nastran bulk data: GRID cards (small, large and free field), real fields, and a writer.

meshio reads GRID and element cards; :func:`read_nastran`, registered as
meshio's Nastran reader when this module is imported, also reads a deck of bulk
data alone (no ``BEGIN BULK`` line and no ``CEND``, as OptiStruct ``.fem`` files
and include files come). GRID positions given in local coordinate systems are
moved to the basic system by :mod:`solver.io.nastran_coords`. meshio's writer
fails on reals such as ``-3.55e-15`` (a 16-character check) and writes no
executive or case control; tetmorph patches a deck in place
(:mod:`solver.io.patch_bdf`) and writes other meshes with :func:`write_nastran`,
whose fields it formats itself.

Field formats (MSC/NX Nastran Quick Reference): small field has ten 8-column
fields per line; large field (``GRID*``) has 8-column first and last fields and
four 16-column fields per line, the card continuing on a line starting with
``*``; free field separates fields with commas. A real field may omit the ``E``
of its exponent (``1.5-3`` is 1.5e-3).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import IO

import meshio
import numpy as np
from meshio.nastran._nastran import read as _meshio_read
from meshio.nastran._nastran import read_buffer as _meshio_read_buffer

__all__ = ["nastran_float", "nastran_real", "bulk_start", "grid_cards", "GridCard",
           "read_nastran", "write_nastran", "NASTRAN_TYPES"]

_REAL = re.compile(r"^([+-]?(?:\d+\.?\d*|\.\d+))(?:[eEdD]([+-]?\d+)|([+-]\d+))?$")


def nastran_float(field: str | bytes) -> float:
    """The value of a Nastran real field (blank is 0).

    Examples
    --------
    >>> nastran_float("1.5-3"), nastran_float(" -.25E+2 "), nastran_float(""), nastran_float("7.")
    (0.0015, -25.0, 0.0, 7.0)
    """
    s = (field.decode("ascii", "replace") if isinstance(field, bytes) else field).strip()
    if not s:
        return 0.0
    m = _REAL.match(s)
    if m is None:
        raise ValueError(f"not a Nastran real: {s!r}")
    exp = m.group(2) or m.group(3)
    return float(m.group(1) + ("e" + exp if exp else ""))


def nastran_real(x: float, width: int | None) -> str:
    """The most precise Nastran real for ``x`` in at most ``width`` characters (free field: None).

    Candidates are fixed notation (``-.001234``) and exponent notation without
    the ``E`` (``-3.55-15``); the closer one wins. Every candidate holds a
    decimal point, as Nastran requires of reals.

    Examples
    --------
    >>> nastran_real(-3.55e-15, 8), nastran_real(123.456789, 8), nastran_real(0.0, 8)
    ('-3.55-15', '123.4568', '0.')
    >>> nastran_real(1e-05, None), nastran_real(2.0, None), nastran_real(-0.1, 16)
    ('1.E-05', '2.0', '-.1')
    """
    x = float(x)
    if not np.isfinite(x):
        raise ValueError(f"cannot write {x} as a Nastran real")
    if x == 0.0:
        return "0." if width is not None else "0.0"
    if width is None:
        s = repr(x).upper()
        if "E" in s:
            mant, exp = s.split("E")
            return (mant if "." in mant else mant + ".") + "E" + exp
        return s if "." in s else s + "."
    best: tuple[float, str] | None = None
    for digits in range(width, -1, -1):  # fixed notation, most digits first
        s = f"{x:.{digits}f}"
        if "." in s:
            s = s.rstrip("0")
        s = s.replace("-0.", "-.") if s.startswith("-0.") else (s[1:] if s.startswith("0.") else s)
        if len(s) <= width and float(s if s not in (".", "-.") else "0") != 0.0:
            best = (abs(float(s) - x), s)
            break
    for digits in range(width, -1, -1):  # exponent notation without the E
        mant, e = f"{x:.{digits}e}".split("e")
        mant = mant.rstrip("0") if "." in mant else mant + "."
        s = mant + ("+" if int(e) >= 0 else "-") + str(abs(int(e)))
        if len(s) <= width:
            err = abs(nastran_float(s) - x)
            if best is None or err < best[0]:
                best = (err, s)
            break
    if best is None:
        raise ValueError(f"cannot write {x} in a {width}-character Nastran field")
    return best[1]


@dataclass(frozen=True)
class GridCard:
    """Where one GRID card's coordinates are in a deck.

    Attributes
    ----------
    id : int
        The grid id.
    cp : int
        Its coordinate system (0 or blank: basic).
    style : str
        ``"small"``, ``"large"`` or ``"free"``.
    spans : tuple of (line, start, end)
        Byte spans of X1, X2, X3 in the deck's lines (``end`` may pass the
        end of a short line: the field is blank there).
    """

    id: int
    cp: int
    style: str
    spans: tuple[tuple[int, int, int], ...]


def _free_spans(line: bytes, k: int, first: int, count: int) -> list[tuple[int, int, int]]:
    body = line.rstrip(b"\r\n")
    cuts = [-1] + [i for i, c in enumerate(body) if c == 44] + [len(body)]  # 44 = ","
    return [(k, cuts[j] + 1, cuts[j + 1]) for j in range(first, first + count) if j + 1 < len(cuts)]


def bulk_start(lines: list[bytes]) -> int:
    r"""The index of a deck's first bulk data line.

    The line after ``BEGIN BULK``; without that line, 0 for a deck of bulk data
    alone (no ``CEND`` either: an OptiStruct ``.fem`` file, an include file), and
    ``len(lines)`` for a deck with executive and case control but no bulk data.

    Examples
    --------
    >>> bulk_start([b"SOL 101\n", b"CEND\n", b"BEGIN BULK\n", b"GRID,1,,0.,0.,0.\n"])
    3
    >>> bulk_start([b"$$ HyperMesh\n", b"GRID,1,,0.,0.,0.\n"]), bulk_start([b"SOL 101\n", b"CEND\n"])
    (0, 2)
    """
    control = False
    for k, line in enumerate(lines):
        word = line.strip().upper()
        if word.startswith(b"BEGIN BULK"):
            return k + 1
        control = control or word == b"CEND"
    return len(lines) if control else 0


def grid_cards(lines: list[bytes]) -> list[GridCard]:
    """The GRID cards of a deck's bulk data (from :func:`bulk_start` up to ``ENDDATA``), in order.

    Parameters
    ----------
    lines : list of bytes
        The deck's lines, with their line ends.

    Returns
    -------
    list of GridCard
        In the order meshio numbers the points.

    Raises
    ------
    ValueError
        A GRID card whose id or coordinate system is not an integer, or a large-field
        card without its continuation line.
    """
    out: list[GridCard] = []
    k = bulk_start(lines)
    while k < len(lines):
        line = lines[k]
        if line.startswith(b"ENDDATA"):
            break
        if not line.startswith(b"GRID"):
            k += 1
            continue
        free = b"," in line
        large = line.startswith(b"GRID*")
        if free:
            fields = line.rstrip(b"\r\n").split(b",")
            gid, cp = fields[1], fields[2] if len(fields) > 2 else b""
            spans = _free_spans(line, k, 3, 2 if large else 3)
            if large:
                nxt = _next_data_line(lines, k)
                if nxt is None:
                    raise ValueError(f"line {k + 1}: GRID* card without its continuation line")
                spans += _free_spans(lines[nxt], nxt, 1, 1)
        elif large:
            gid, cp = line[8:24], line[24:40]
            spans = [(k, 40, 56), (k, 56, 72)]
            nxt = _next_data_line(lines, k)
            if nxt is None or not lines[nxt].startswith(b"*"):
                raise ValueError(f"line {k + 1}: GRID* card without its '*' continuation line")
            spans.append((nxt, 8, 24))
        else:
            gid, cp = line[8:16], line[16:24]
            spans = [(k, 24, 32), (k, 32, 40), (k, 40, 48)]
        if len(spans) != 3:
            raise ValueError(f"line {k + 1}: GRID card with fewer than three coordinate fields")
        try:
            out.append(GridCard(int(gid), int(cp.strip() or b"0"), "free" if free else
                                "large" if large else "small", tuple(spans)))
        except ValueError:
            raise ValueError(f"line {k + 1}: GRID card with id {gid.strip()!r} and coordinate "
                             f"system {cp.strip()!r}") from None
        k += 1
    return out


def _next_data_line(lines: list[bytes], k: int) -> int | None:
    for j in range(k + 1, min(k + 1000, len(lines))):
        if lines[j].strip() and not lines[j].startswith((b"$", b"//", b"#")):
            return j
    return None


class _BulkOnly:
    """A deck of bulk data alone as meshio's reader wants it: a ``BEGIN BULK`` line first, ``ENDDATA`` at its end."""

    def __init__(self, fh: IO[str]) -> None:
        self._fh = fh
        self._started = False

    def readline(self) -> str:
        if not self._started:
            self._started = True
            return "BEGIN BULK\n"
        line = self._fh.readline()
        if not line:
            return "ENDDATA\n"  # meshio reads on to ENDDATA, which an include file need not have
        return line if line.endswith("\n") else line + "\n"


def _bulk_only(path: str) -> bool:
    """Whether a deck has neither ``BEGIN BULK`` nor ``CEND`` (read line by line: a deck may be large)."""
    with open(path, "rb") as fh:
        for line in fh:
            word = line.strip().upper()
            if word.startswith(b"BEGIN BULK") or word == b"CEND":
                return False
    return True


def read_nastran(filename: str | os.PathLike[str]) -> meshio.Mesh:
    """Read a Nastran deck with meshio's reader, a deck of bulk data alone included.

    Parameters
    ----------
    filename : str or path

    Returns
    -------
    meshio.Mesh
        As meshio reads it: GRID fields as they are written (see
        :mod:`solver.io.nastran_coords` for local coordinate systems), the
        CP field as point data ``nastran:ref``.

    Notes
    -----
    A deck with neither ``BEGIN BULK`` nor ``CEND`` is bulk data (an OptiStruct
    ``.fem`` file, an include file): it is read as if it began with
    ``BEGIN BULK`` and ended with ``ENDDATA``. Other decks go to meshio's reader
    as they are.
    """
    path = os.fspath(filename)
    if not _bulk_only(path):
        return _meshio_read(path)
    with open(path, encoding="utf-8", errors="replace") as fh:
        return _meshio_read_buffer(_BulkOnly(fh))


meshio.register_format("nastran", [], read_nastran, {})


#: meshio cell type -> (Nastran card, nodes).
NASTRAN_TYPES = {
    "tetra": ("CTETRA", 4), "tetra10": ("CTETRA", 10), "hexahedron": ("CHEXA", 8),
    "wedge": ("CPENTA", 6), "pyramid": ("CPYRAM", 5), "triangle": ("CTRIA3", 3),
    "quad": ("CQUAD4", 4), "triangle6": ("CTRIA6", 6), "quad8": ("CQUAD8", 8),
}


def write_nastran(path: str | os.PathLike[str], m: meshio.Mesh, pid: list[np.ndarray] | None = None) -> None:
    """Write a bulk data deck: GRID* (large field, 16 columns), then the elements (small field).

    Parameters
    ----------
    path : str or path
    m : meshio.Mesh
        Points and the cell blocks of :data:`NASTRAN_TYPES` (others are skipped:
        the caller lists them as losses).
    pid : list of (k,) int arrays, optional
        Property id of each element, per block; 1 by default.
    """
    P = np.asarray(m.points, dtype=np.float64)
    if P.shape[1] == 2:
        P = np.c_[P, np.zeros(len(P))]
    with open(path, "w", encoding="ascii") as fh:
        fh.write("$ bulk data written by tetmorph\nBEGIN BULK\n")
        for k, x in enumerate(P):
            gid = k + 1
            r = [nastran_real(v, 16) for v in x]
            fh.write(f"GRID*   {gid:<16d}{'':16}{r[0]:>16}{r[1]:>16}*G{gid:<6d}\n"
                     f"*G{gid:<6d}{r[2]:>16}\n")
        eid = 0
        for b, block in enumerate(m.cells):
            if block.type not in NASTRAN_TYPES:
                continue
            card, _ = NASTRAN_TYPES[block.type]
            props = pid[b] if pid is not None else np.ones(len(block.data), np.int64)
            for row, p in zip(np.asarray(block.data, np.int64) + 1, props, strict=True):
                eid += 1
                fields = [f"{int(p):<8d}"] + [f"{int(g):<8d}" for g in row]
                first, rest = fields[:7], fields[7:]
                text = f"{card:<8}{eid:<8d}" + "".join(first)
                while rest:
                    text += "+\n+       " + "".join(rest[:8])
                    rest = rest[8:]
                fh.write(text.rstrip() + "\n")
        fh.write("ENDDATA\n")
