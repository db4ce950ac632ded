"""LS-DYNA keyword decks: the ``*ELEMENT_SOLID`` cards, their shapes, and the elements refused, in words.

:func:`_solid_cards` reads an ``*ELEMENT_SOLID`` block (``_ORTHO``, ``_DOF``,
``_TET4TOTET10``) in the one-card form (``EID PID N1 ... N8``) or the two-card
form (``EID PID``, then ``N1 ... N8`` or ``N1 ... N10``). :func:`_shapes`
sorts its elements by the pattern of their repeated nodes into tetrahedra,
pyramids, wedges and hexahedra (10 nodes: ``tetra10``), and
:func:`_check_shapes` refuses a pattern that makes none of them. The element
keywords tetmorph does not deform are counted (:func:`_unsupported_count`)
and named in words (:func:`_words`) for the refusal.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UnreadableFileError, UnsupportedElementError
from .lsdyna_cards import _Block, _in, _where
from .lsdyna_fields import _WIDTHS, _bad_field, _card_lines, _check_truncated, _fast_ints, _free, _int, _plain, _table

#: Element keywords kept as they are: they sit on nodes and carry no volume.
_KEPT_ELEMENTS = ("ELEMENT_MASS", "ELEMENT_INERTIA", "ELEMENT_PLOTEL")
#: Options of ``*ELEMENT_SOLID`` read, and the extra cards each adds per element.
_SOLID_OPTIONS = {"ORTHO": 2, "DOF": 1, "TET4TOTET10": 0, "FORMAT2": 0}
#: Element families in words, for refusals.
_FAMILY_WORDS = {"SHELL": "shell", "TSHELL": "thick shell", "BEAM": "beam", "DISCRETE": "discrete",
                 "SEATBELT": "seatbelt", "SPH": "SPH", "SOLID": "higher-order solid"}
_SOLID_WORDS = {"H20": "20-node solid", "H27": "27-node solid", "H64": "64-node solid", "P15": "15-node pentahedron",
                "P40": "40-node pentahedron", "T15": "15-node tetrahedron", "T20": "20-node tetrahedron",
                "H8TOH20": "20-node solid (H8TOH20)", "H8TOH27": "27-node solid (H8TOH27)",
                "H8TOH64": "64-node solid (H8TOH64)", "PERI": "peridynamic solid", "NURBS": "NURBS solid"}
#: Cell types in the order their blocks are written.
_CELL_ORDER = ("tetra", "tetra10", "hexahedron", "wedge", "pyramid")
#: Columns of the eight solid nodes taken for each degenerate shape (0-based).
_SHAPES = {"tetra": [0, 1, 2, 3], "tetB": [0, 1, 2, 4], "pyramid": [0, 1, 2, 3, 4], "wedgeA": [0, 1, 4, 3, 2, 6],
           "wedgeB": [0, 1, 2, 4, 5, 6], "hexahedron": list(range(8))}


@dataclass
class _Solids:
    """The cards of one ``*ELEMENT_SOLID`` block."""

    eids: np.ndarray  # (m,)
    pids: np.ndarray  # (m,)
    nodes: np.ndarray  # (m, 10): node ids, 0 where blank
    lines: np.ndarray  # (m,) line of each element's first card
    file: str
    keyword: str
    tets_only: bool  # TET4TOTET10: 4-node tetrahedra only


def _solid_options(name: str) -> set[str] | None:
    """The options of an ``*ELEMENT_SOLID`` keyword, or None for a form tetmorph does not read."""
    opts = {o for o in name[len("ELEMENT_SOLID"):].split("_") if o}
    return opts if opts <= set(_SOLID_OPTIONS) else None


def _solid_cards(block: _Block, name: str) -> _Solids:
    """Read an ``*ELEMENT_SOLID`` block (one- or two-card form, fixed or free format)."""
    opts = _solid_options(block.name) or set()
    extra = sum(_SOLID_OPTIONS[o] for o in opts)
    wi = _WIDTHS[block.fmt][0]
    starts, ends, numbers = _card_lines(block)
    _check_truncated(block, name, starts, ends, numbers)
    k = len(starts)
    out = None
    if k:
        table = _table(block.data, starts, ends, 10 * wi)
        short = (table[:, 2 * wi:3 * wi] == 32).all(axis=1)  # a card with EID and PID alone: the nodes follow
        plain = _plain(block, table)
        for per, two in ((1 + extra, False), (2 + extra, True)):
            if k % per or not plain:
                continue
            heads = np.arange(0, k, per)
            if two and not (short[heads].all() and not short[heads + 1].any()):
                continue
            if not two and short[heads].any():
                continue
            first = table if per == 1 else table[heads]
            head = _fast_ints(first, 0, wi, 2)
            nodes = np.zeros((len(heads), 10), np.int64)
            got = (_fast_ints(table[heads + 1], 0, wi, 10, nodes) if two else
                   _fast_ints(first, 2 * wi, wi, 8, nodes[:, :8]))
            if head is not None and got is not None:
                out = _Solids(head[:, 0], head[:, 1], nodes, numbers[heads], block.file, block.name,
                              "TET4TOTET10" in opts)
            break
    if out is None:
        out = _slow_solids(block, name, starts, ends, numbers, extra, "TET4TOTET10" in opts)
    bad = np.flatnonzero(out.eids <= 0)
    if bad.size:
        line = int(out.lines[bad[0]])
        raise UnreadableFileError(f"{name!r}, {_where(block.file, line)} (*{block.name}): element id "
                                  f"{int(out.eids[bad[0]])}; element ids are positive", code="bad_element_line",
                                  file=name, line=line, **_in(block.file))
    return out


def _slow_solids(block: _Block, name: str, starts: np.ndarray, ends: np.ndarray, numbers: np.ndarray, extra: int,
                 tets_only: bool) -> _Solids:
    """Solid cards read one element at a time (free format, mixed card forms), naming what cannot be read."""
    wi = _WIDTHS[block.fmt][0]
    rows: list[list[int]] = []
    lines: list[int] = []
    texts = [block.data[s:e] for s, e in zip(starts.tolist(), ends.tolist(), strict=True)]
    k = 0
    while k < len(texts):
        text, line = texts[k], int(numbers[k])
        try:
            if b"," in text:
                values = [_int(f) for f in _free(text)]
            else:
                if b"\t" in text:
                    raise ValueError(text)
                values = [_int(text[j * wi:(j + 1) * wi]) for j in range(10)]
                while len(values) > 2 and values[-1] == 0 and not text[(len(values) - 1) * wi:].strip():
                    values.pop()
        except ValueError:
            raise _bad_field(name, block, line, text, "an element id, a part id and node ids") from None
        if not any(values[2:]):  # EID and PID alone: the nodes are on the next card
            if k + 1 >= len(texts):
                raise UnreadableFileError(
                    f"{name!r}, {_where(block.file, line)} (*{block.name}): element {values[0] if values else '?'} "
                    "has its element and part ids but no card of nodes after them: the block is cut short",
                    code="truncated_file", file=name, line=line, **_in(block.file))
            nodes_text = texts[k + 1]
            try:
                nodes = ([_int(f) for f in _free(nodes_text)] if b"," in nodes_text else
                         [_int(nodes_text[j * wi:(j + 1) * wi]) for j in range(10)])
            except ValueError:
                raise _bad_field(name, block, int(numbers[k + 1]), nodes_text, "node ids") from None
            k += 2
        else:
            nodes = values[2:]
            k += 1
        k += extra
        if len(nodes) > 10 or len(values) < 2:
            raise UnreadableFileError(
                f"{name!r}, {_where(block.file, line)} (*{block.name}): a solid card with {len(values)} fields "
                "where LS-DYNA has an element id, a part id and up to 10 nodes", code="bad_element_line", file=name,
                line=line, **_in(block.file))
        rows.append(values[:2] + nodes + [0] * (10 - len(nodes)))
        lines.append(line)
    if k > len(texts):
        raise UnreadableFileError(
            f"{name!r}, {_where(block.file, lines[-1] if lines else block.line)} (*{block.name}): the last element "
            "lacks its orientation cards: the block is cut short", code="truncated_file", file=name,
            **_in(block.file))
    a = np.asarray(rows, np.int64).reshape(-1, 12)
    return _Solids(a[:, 0], a[:, 1], a[:, 2:], np.asarray(lines, np.int64), block.file, block.name, tets_only)


def _shapes(s: _Solids) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The elements of a solid block by meshio type: (rows of the block, node ids (r, nodes per cell))."""
    n = s.nodes[:, :8]
    quad = (s.nodes[:, 8:] != 0).any(axis=1)
    tetA = (n[:, 4:] == n[:, 3:4]).all(axis=1) | (n[:, 4:] == 0).all(axis=1)
    if not quad.any() and tetA.all():  # the common deck: tetrahedra alone
        return {"tetra": (np.arange(len(n)), np.ascontiguousarray(n[:, :4]))}
    top = (n[:, 5:] == n[:, 4:5]).all(axis=1)
    flat = n[:, 2] == n[:, 3]
    pairs = (n[:, 4] == n[:, 5]) & (n[:, 6] == n[:, 7])
    code = np.select([quad, tetA, flat & top, top, pairs, flat & (n[:, 6] == n[:, 7])], [0, 1, 2, 3, 4, 5], 6)
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    # meshio type, the codes it gathers, the node columns of the first and of the second code
    for kind, first, second, cols, other in (("tetra10", 0, 0, "", ""), ("tetra", 1, 2, "tetra", "tetB"),
                                             ("pyramid", 3, 3, "pyramid", "pyramid"),
                                             ("wedge", 4, 5, "wedgeA", "wedgeB"),
                                             ("hexahedron", 6, 6, "hexahedron", "hexahedron")):
        rows = np.flatnonzero((code == first) | (code == second))
        if not rows.size:
            continue
        if kind == "tetra10":
            conn = s.nodes[rows]
        else:
            sub = n[rows]
            conn = sub[:, _SHAPES[cols]]
            if other != cols:
                conn = np.where((code[rows] == second)[:, None], sub[:, _SHAPES[other]], conn)
        out[kind] = (rows, conn)
    return out


def _check_shapes(s: _Solids, shapes: dict[str, tuple[np.ndarray, np.ndarray]], name: str) -> None:
    """Refuse elements whose nodes repeat in no known pattern, and non-tetrahedra among TET4TOTET10 elements."""
    for kind, (rows, conn) in shapes.items():
        srt = np.sort(conn, axis=1)
        bad = rows[((srt[:, 1:] == srt[:, :-1]) & (srt[:, 1:] != 0)).any(axis=1)]
        if bad.size:
            r = int(bad[0])
            line = int(s.lines[r])
            nodes = " ".join(str(int(v)) for v in s.nodes[r] if v)
            raise UnsupportedElementError(
                f"{name!r}, {_where(s.file, line)} (*{s.keyword}): element {int(s.eids[r])} repeats its nodes "
                f"({nodes}) in a pattern that makes no tetrahedron, pyramid, wedge or hexahedron "
                f"({bad.size:,} such elements)", types={"degenerate solid": int(bad.size)}, element=int(s.eids[r]),
                line=line, **_in(s.file))
        if s.tets_only and kind != "tetra":
            r = int(rows[0])
            line = int(s.lines[r])
            raise UnsupportedElementError(
                f"{name!r}, {_where(s.file, line)} (*{s.keyword}): element {int(s.eids[r])} is a {kind}, where "
                "*ELEMENT_SOLID_TET4TOTET10 holds 4-node tetrahedra", types={f"*{s.keyword} {kind}": int(rows.size)},
                element=int(s.eids[r]), line=line, **_in(s.file))


def _unsupported_count(block: _Block) -> int:
    """How many elements an element keyword tetmorph does not deform holds (cards per element by its options)."""
    starts, ends, _ = _card_lines(block)
    lines = len(starts)
    family, *opts = block.name[len("ELEMENT_"):].split("_")
    options = set(opts)
    if family == "SOLID":  # higher-order forms: a card of EID and PID starts each element
        wi = _WIDTHS[block.fmt][0]
        heads = 0
        for s, e in zip(starts.tolist(), ends.tolist(), strict=True):
            text = block.data[s:e]
            fields = [f for f in (_free(text) if b"," in text else [text[:wi], text[wi:2 * wi], text[2 * wi:]])
                      if f.strip()]
            heads += len(fields) <= 2
        return heads or lines
    per = 1
    if family in ("SHELL", "TSHELL"):
        per += bool(options & {"THICKNESS", "BETA", "MCID"}) + ("OFFSET" in options) + ("DOF" in options)
    elif family == "BEAM":
        per += (bool(options & {"THICKNESS", "SCALAR", "SCALR", "SECTION"}) + ("PID" in options)
                + ("OFFSET" in options) + ("ORIENTATION" in options) + ("WARPAGE" in options) + ("ELBOW" in options))
    elif family == "DISCRETE":
        per += "LCO" in options
    return -(-lines // per)


def _words(unsupported: dict[str, int]) -> str:
    """``"1,024 shell elements (*ELEMENT_SHELL) and 12 beam elements (*ELEMENT_BEAM)"``."""
    parts = []
    for keyword, count in unsupported.items():
        family, *opts = keyword[len("*ELEMENT_"):].split("_")
        word = _FAMILY_WORDS.get(family, family.lower())
        if family == "SOLID":
            word = next((w for o, w in _SOLID_WORDS.items() if o in opts), word)
        parts.append(f"{count:,} {word} element{'s' if count != 1 else ''} ({keyword})")
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
