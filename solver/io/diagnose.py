"""Why a mesh file cannot be read, in the words of the file's format.

A reader's own exception rarely says what is wrong with the file (meshio
answers a truncated VTU with ``1`` and a deck naming an undefined node with
``np.int64(100)``). :func:`check_file` refuses what can be told from the bytes
before reading (an empty file, another format than the name says);
:func:`diagnose` turns a reader's exception into an
:class:`~solver.errors.UnreadableFileError` that names the defect (a truncated
file, the element and the node of an undefined reference), and
:func:`check_complete` catches a text file cut in the middle of a line.
"""

from __future__ import annotations

import io
import os
import re

from ..errors import UnreadableFileError, UnsupportedElementError
from .element_words import element_words
from .formats import a_format, detect_format
from .patch_medit import medit_keywords

__all__ = ["check_file", "diagnose", "check_complete", "undefined_inp_node", "undefined_bdf_node",
           "medit_high_order"]

#: Formats with a signature strong enough to tell that a file is something else.
_STRONG = {"gmsh", "vtu", "vtk-xml", "xdmf", "vtk", "hdf5", "netcdf", "zip", "gzip", "pdf", "json", "html",
           "ply", "off", "stl", "abaqus", "nastran", "ansys", "lsdyna", "ansys-cdb"}
#: Formats whose files always carry their signature near the start.
_SIGNED = {"gmsh", "vtu", "vtk", "ply", "off", "stl"}


#: Container formats and the meshio formats stored in them (netCDF-4, meshio's Exodus default, is HDF5).
_CONTAINERS = {"hdf5": {"med", "cgns", "h5m", "xdmf", "hmf", "exodus"}, "netcdf": {"exodus"}, "vtk-xml": set()}


def _expected_ok(expected: str, detected: str | None) -> bool:
    if detected is None or detected == expected or expected in _CONTAINERS.get(detected, set()):
        return True
    if expected == "gmsh22" and detected == "gmsh":
        return True
    return detected not in _STRONG


def check_file(path: str, fmt: str | None) -> bytes:
    """Refuse an empty file or one whose content is another format than ``fmt``.

    Parameters
    ----------
    path : str
    fmt : str or None
        The meshio format the name (or the caller) says.

    Returns
    -------
    bytes
        The first 8 kB of the file.

    Raises
    ------
    UnreadableFileError
        ``empty_file``, ``wrong_format`` (details ``expected``, ``detected``) or
        ``unknown_format`` (an extension that names no format).
    """
    name = os.path.basename(path)
    size = os.path.getsize(path)
    if size == 0:
        raise UnreadableFileError(f"{name!r} is empty (0 bytes): there is nothing to read. Check that the "
                                  "upload or the export that wrote it finished.", code="empty_file", file=name)
    with open(path, "rb") as fh:
        head = fh.read(8192)
    if not head.strip():
        raise UnreadableFileError(f"{name!r} holds only blanks ({size} bytes): there is nothing to read.",
                                  code="empty_file", file=name)
    detected = detect_format(head, size)
    if fmt is None:
        seen = f"; its content looks like {a_format(detected)}: pass its format" if detected else ""
        raise UnreadableFileError(f"cannot tell the format of {name!r} from its extension{seen}",
                                  code="unknown_format", file=name, detected=detected)
    if not _expected_ok(fmt, detected):
        raise UnreadableFileError(
            f"{name!r} is named as {a_format(fmt)} but its content is {a_format(detected)}"
            f"{_hint(detected)}", code="wrong_format", file=name, expected=fmt, detected=detected)
    if fmt == "stl" and detected is None and size >= 84 and head[:5].lower() != b"solid":
        n = int.from_bytes(head[80:84], "little")
        raise UnreadableFileError(
            f"{name!r} is a binary STL declaring {n:,} triangles, which take {84 + 50 * n:,} bytes; the file has "
            f"{size:,}: it is truncated or its count is wrong", code="truncated_file", file=name, declared=n,
            size=size)
    if fmt in _SIGNED and detected is None:
        raise UnreadableFileError(
            f"{name!r} is named as {a_format(fmt)} but does not start like one (first bytes "
            f"{head[:40]!r}); it is no mesh format tetmorph recognises", code="wrong_format", file=name,
            expected=fmt, detected=None)
    return head


def _hint(detected: str | None) -> str:
    ext = {"gmsh": ".msh", "vtu": ".vtu", "vtk": ".vtk", "abaqus": ".inp", "nastran": ".bdf", "stl": ".stl",
           "off": ".off", "ply": ".ply", "medit": ".mesh", "obj": ".obj", "lsdyna": ".k",
           "ansys-cdb": ".cdb"}.get(detected or "")
    if ext:
        return f": rename it to {ext} or pass its format"
    if detected == "ansys":
        return ": tetmorph reads Gmsh .msh files, not ANSYS/Fluent ones"
    if detected == "vtk-xml":
        return " (PolyData, ImageData...): save the mesh as an unstructured grid (.vtu)"
    return ": it is not a mesh"


def diagnose(path: str, fmt: str, exc: BaseException) -> UnreadableFileError | UnsupportedElementError:
    """The error to raise when the reader of ``fmt`` failed on ``path`` with ``exc``.

    Parameters
    ----------
    path : str
    fmt : str
        The meshio format that was read.
    exc : BaseException
        What the reader raised.

    Returns
    -------
    UnreadableFileError or UnsupportedElementError
        ``truncated_file``, ``no_nodes``, ``no_elements``, ``undefined_node``
        or, when nothing more specific is known, ``unreadable_file`` quoting the reader;
        ``unsupported_element`` for a Medit file with quadratic or higher-order
        elements (``TetrahedraP2``...), which meshio's reader stops at.
    """
    name = os.path.basename(path)
    with open(path, "rb") as fh:
        data = fh.read()
    if fmt == "medit":
        high = medit_high_order(data)
        if high:
            return _high_order_error(name, high)
    if fmt in ("gmsh", "gmsh22"):
        for sec in (b"Nodes", b"Elements"):
            if re.search(rb"^\$" + sec + rb"\s*$", data, re.M) and not re.search(rb"^\$End" + sec, data, re.M):
                return UnreadableFileError(
                    f"{name!r} ends inside its ${sec.decode()} section (no $End{sec.decode()}): the file is "
                    "truncated", code="truncated_file", file=name, section=sec.decode())
        for sec, code in ((b"Nodes", "no_nodes"), (b"Elements", "no_elements")):
            if not re.search(rb"^\$" + sec, data, re.M):
                return UnreadableFileError(f"{name!r} is a Gmsh file without a ${sec.decode()} section: it "
                                           f"defines no {sec.decode().lower()}", code=code, file=name)
    if fmt == "vtu" and b"</VTKFile>" not in data[-4096:]:
        return UnreadableFileError(f"{name!r} ends before its closing </VTKFile> tag: the file is truncated",
                                   code="truncated_file", file=name)
    if fmt == "medit" and not re.search(rb"^\s*End\b", data[-4096:], re.M) and data.lstrip()[:1] != b"\x01":
        return UnreadableFileError(f"{name!r} ends before Medit's closing 'End' keyword: the file is "
                                   "truncated", code="truncated_file", file=name)
    if fmt == "abaqus" and isinstance(exc, KeyError):
        found = undefined_inp_node(data)
        if found is not None:
            return _undefined(name, *found)
    if fmt == "nastran":
        if isinstance(exc, KeyError):
            found = undefined_bdf_node(data)
            if found is not None:
                return _undefined(name, *found)
        if "BEGIN BULK" in str(exc):
            return UnreadableFileError(f"{name!r} has no BEGIN BULK line: a Nastran deck's GRID and element "
                                       "cards follow it", code="no_nodes", file=name)
        if "Premature EOF" in str(exc):
            return UnreadableFileError(f"{name!r} ends inside a card, before ENDDATA: the file is truncated",
                                       code="truncated_file", file=name)
    if fmt == "vtk":
        counts = b", ".join(k + b" " + v for k, v in re.findall(rb"^\s*(POINTS|CELLS)\s+(\d+)", data, re.M))
        if b"CELL_TYPES" not in data:  # every unstructured grid has it, after its CELLS
            return UnreadableFileError(
                f"{name!r} ends before its CELL_TYPES section ({counts.decode() or 'no POINTS'} announced): "
                "the file is truncated", code="truncated_file", file=name)
    return UnreadableFileError(f"cannot read {name!r} as {a_format(fmt)}: {_reason(exc)}",
                               code="unreadable_file", file=name, reader_error=type(exc).__name__)


def _reason(exc: BaseException) -> str:
    text = str(exc).strip()
    if isinstance(exc, SystemExit) or not text or text.isdigit():
        return f"the reader stopped ({type(exc).__name__}) without saying why; the file is corrupt or truncated"
    return f"{type(exc).__name__}: {text[:300]}"


def _undefined(name: str, element: int, node: int, line: int, kind: str, count: int) -> UnreadableFileError:
    more = f"; {count} element lines name undefined nodes" if count > 1 else ""
    return UnreadableFileError(
        f"{name!r} line {line}: element {element} ({kind}) refers to node {node}, which no node "
        f"definition in the file defines{more}", code="undefined_node", file=name, element=element, node=node,
        line=line, count=count)


_KEY = re.compile(rb"^\s*\*\s*([A-Za-z ]+)", re.I)


def undefined_inp_node(data: bytes) -> tuple[int, int, int, str, int] | None:
    r"""The first element of an Abaqus deck that names a node no ``*NODE`` block defines.

    Returns
    -------
    (element, node, line, type, count) or None
        ``line`` is 1-based; ``count`` the number of such element lines.

    Examples
    --------
    >>> undefined_inp_node(b"*NODE\n1,0,0,0\n2,1,0,0\n*ELEMENT, TYPE=T3D2\n1, 1, 2\n2, 2, 100\n")
    (2, 100, 6, 'T3D2', 1)
    """
    nodes: set[int] = set()
    elements: list[tuple[int, list[int], int, str]] = []
    block, kind, pending = None, "", None
    for k, raw in enumerate(data.splitlines()):
        line = raw.strip()
        if not line or line.startswith(b"**"):
            continue
        m = _KEY.match(line)
        if m:
            word = m.group(1).strip().upper()
            block = b"NODE" if word == b"NODE" else b"ELEMENT" if word == b"ELEMENT" else None
            typ = re.search(rb"type\s*=\s*([\w]+)", line, re.I)
            kind = typ.group(1).decode() if typ else "?"
            pending = None
            continue
        fields = [f for f in line.split(b",") if f.strip()]
        try:
            ints = [int(f) for f in fields] if block == b"ELEMENT" else [int(fields[0])]
        except (ValueError, IndexError):
            continue
        if block == b"NODE":
            nodes.add(ints[0])
        elif block == b"ELEMENT":
            if pending is not None:
                pending[1].extend(ints)
            else:
                pending = (ints[0], ints[1:], k + 1, kind)
                elements.append(pending)
            if not line.endswith(b","):
                pending = None
    bad = [(e, [n for n in ns if n not in nodes], ln, t) for e, ns, ln, t in elements]
    bad = [b for b in bad if b[1]]
    if not bad:
        return None
    e, ns, ln, t = bad[0]
    return e, ns[0], ln, t, len(bad)


def undefined_bdf_node(data: bytes) -> tuple[int, int, int, str, int] | None:
    """The first element card of a Nastran deck that names a grid no GRID card defines.

    Only single-line element cards are checked field by field (the first line of
    a continued card gives its first six grids).

    Returns
    -------
    (element, grid, line, card, count) or None
    """
    from .nastran import NASTRAN_TYPES, grid_cards

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


#: Medit element keywords without their order, and meshio's name of the linear type.
_MEDIT_SHAPES = {"Edges": "line", "Triangles": "triangle", "Quadrilaterals": "quad", "Tetrahedra": "tetra",
                 "Prisms": "wedge", "Pyramids": "pyramid", "Hexahedra": "hexahedron"}
_MEDIT_HIGH = re.compile(rb"(?m)^[ \t]*(" + "|".join(_MEDIT_SHAPES).encode()
                         + rb")([PQ])([2-9])[ \t]*(?:\r?\n[ \t]*)?(\d+)?")
_MEDIT_NAME = re.compile(r"(?:Gmf)?(" + "|".join(_MEDIT_SHAPES) + r")([PQ])([2-9])\Z")


def _nodes(shape: str, p: int) -> int:
    """Nodes of a Lagrange element of order ``p``."""
    return {"line": p + 1, "triangle": (p + 1) * (p + 2) // 2, "quad": (p + 1) ** 2,
            "tetra": (p + 1) * (p + 2) * (p + 3) // 6, "hexahedron": (p + 1) ** 3,
            "wedge": (p + 1) ** 2 * (p + 2) // 2, "pyramid": (p + 1) * (p + 2) * (2 * p + 3) // 6}[shape]


def medit_high_order(data: bytes) -> dict[str, int]:
    r"""The quadratic and higher-order element keywords of a Medit file (text or binary), with their counts.

    meshio reads Medit's linear elements only: its text reader stops at a
    keyword such as ``TetrahedraP2`` without a word, its binary reader skips
    the keyword's elements.

    Examples
    --------
    >>> medit_high_order(b"MeshVersionFormatted 2\nDimension 3\nVertices\n0\nTetrahedraP2\n12\nTrianglesP2 3\nEnd\n")
    {'TetrahedraP2': 12, 'TrianglesP2': 3}
    """
    found: dict[str, int] = {}
    if data[:4] in (b"\x01\x00\x00\x00", b"\x00\x00\x00\x01"):
        for kw, _, _ in medit_keywords(io.BytesIO(data)):
            if _MEDIT_NAME.match(kw.name):
                found[kw.name[3:]] = found.get(kw.name[3:], 0) + kw.count
        return found
    for m in _MEDIT_HIGH.finditer(data):
        key = (m[1] + m[2] + m[3]).decode()
        found[key] = found.get(key, 0) + int(m[4] or 0)
    return found


def _high_order_error(name: str, found: dict[str, int]) -> UnsupportedElementError:
    """The refusal of a Medit file's quadratic or higher-order elements, named with their counts."""
    types: dict[str, int] = {}
    labels: dict[str, str] = {}
    for key, count in found.items():
        m = _MEDIT_NAME.match(key)
        assert m is not None
        shape = _MEDIT_SHAPES[m[1]]
        kind = f"{shape}{_nodes(shape, int(m[3]))}"
        types[kind], labels[kind] = types.get(kind, 0) + count, key
    order = "quadratic" if all(k[-1] == "2" for k in found) else "quadratic or higher-order"
    return UnsupportedElementError(
        f"{name!r} holds {element_words(types, labels)}; tetmorph does not read {order} Medit elements, only "
        "linear ones (Edges, Triangles, Quadrilaterals, Tetrahedra, Prisms, Pyramids, Hexahedra). Quadratic "
        "tetrahedra are read from Gmsh (.msh), VTU or Abaqus (.inp) files.",
        file=name, keywords=dict(found), types=types)


def check_complete(path: str, fmt: str, data: bytes | None = None) -> None:
    """Refuse a text mesh whose last line stops in the middle.

    No line end, and fewer fields than the line before it: a file cut short
    that a reader would take as complete.

    Raises
    ------
    UnreadableFileError
        ``truncated_file``.
    """
    if fmt == "medit" and path.endswith("b"):  # binary: meshio skips elements it does not know
        with open(path, "rb") as fh:
            high = medit_high_order(fh.read())
        if high:
            raise _high_order_error(os.path.basename(path), high)
        return
    if fmt not in ("abaqus", "nastran", "tetgen", "medit", "gmsh", "vtk"):
        return
    if data is None:
        with open(path, "rb") as fh:
            fh.seek(max(0, os.path.getsize(path) - 4096))
            data = fh.read()
    if not data or data.endswith((b"\n", b"\r")):
        return
    tail = data.splitlines()[-2:]
    if len(tail) < 2:
        return
    prev, last = tail
    sep = re.compile(rb"[,\s]+")
    nprev = len([f for f in sep.split(prev.strip()) if f])
    nlast = len([f for f in sep.split(last.strip()) if f])
    if re.match(rb"^\s*[-+.\d]", last) and re.match(rb"^\s*[-+.\d]", prev) and nlast < nprev:
        raise UnreadableFileError(
            f"{os.path.basename(path)!r} ends in the middle of a line ({nlast} fields where the line before "
            f"has {nprev}, and no line end): the file is truncated", code="truncated_file",
            file=os.path.basename(path))
