"""Abaqus and CalculiX decks parsed as Abaqus reads them (:mod:`solver.io.abaqus_deck` makes the mesh).

The parse keeps, per scope (the model, each part, each instance, the
assembly), the node labels and positions with the line each came from, the
element blocks and the sets as written; :class:`Instance` holds a part's
placement. Keyword lines in any case with blanks around ``=``, keyword lines
continued by a trailing comma, ``**`` comments, element lines continued until
the element has its nodes, and ``*INCLUDE`` spliced in where it stands
(relative to the deck's folder, at most :data:`MAX_INCLUDE_DEPTH` deep, never
outside that folder).
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from meshio._common import num_nodes_per_cell

from ..errors import UnreadableFileError

__all__ = ["Deck", "Scope", "Instance", "Line", "parse_deck", "deck_points", "kind_words", "folder_loader",
           "MAX_INCLUDE_DEPTH"]

#: Deepest chain of ``*INCLUDE`` followed.
MAX_INCLUDE_DEPTH = 8


def _meshio_type(abaqus: str) -> str | None:
    """The meshio cell type of an Abaqus element type, or None (``C3D10MH`` -> ``tetra10``)."""
    from meshio.abaqus._abaqus import abaqus_to_meshio_type

    key = abaqus.upper()
    if key in abaqus_to_meshio_type:
        return abaqus_to_meshio_type[key]
    for prefix, kind in (("C3D10", "tetra10"), ("C3D4", "tetra"), ("C3D8", "hexahedron"), ("C3D6", "wedge"),
                         ("C3D20", "hexahedron20"), ("C3D15", "wedge15"), ("C3D5", "pyramid")):
        if key.startswith(prefix) and (len(key) == len(prefix) or not key[len(prefix)].isdigit()):
            return kind
    return None


#: Words for the element kinds tetmorph does not morph (messages).
_KIND_WORDS = {"S": "shell", "M3D": "membrane", "B": "beam", "T3D": "truss", "T2D": "truss", "CPS": "plane stress",
               "CPE": "plane strain", "CAX": "axisymmetric", "R3D": "rigid", "SPRING": "spring",
               "CONN": "connector", "DC": "heat transfer", "MASS": "mass", "ROTARYI": "rotary inertia",
               "SC": "continuum shell", "COH": "cohesive", "GK": "gasket"}


def kind_words(abaqus: str) -> str:
    """What an Abaqus element type is, in words (``S4R`` -> ``shell``)."""
    key = abaqus.upper()
    for prefix in sorted(_KIND_WORDS, key=len, reverse=True):
        if key.startswith(prefix):
            return _KIND_WORDS[prefix]
    return "other"


# --------------------------------------------------------------------------- lines and keywords


class Line(NamedTuple):
    """One line of a deck or of a file it includes."""

    file: str  #: "" for the deck, else the include's path relative to the deck's folder
    row: int  #: 0-based line number in that file
    text: bytes  #: without its line end


@dataclass
class Keyword:
    """A keyword line: its name (upper case, blanks squeezed) and parameters (keys upper case)."""

    name: str
    params: dict[str, str]
    line: Line

    def get(self, key: str, default: str | None = None) -> str | None:
        return self.params.get(key, default)


def _split_keyword(text: str) -> tuple[str, dict[str, str]]:
    parts = [p.strip() for p in text.lstrip()[1:].split(",")]
    name = " ".join(parts[0].upper().split())
    params: dict[str, str] = {}
    for p in parts[1:]:
        if not p:
            continue
        k, _, v = p.partition("=")
        params[" ".join(k.upper().split())] = v.strip().strip('"')
    return name, params


_INCLUDE = re.compile(r"^\s*\*\s*include\b", re.IGNORECASE)


def _walk(name: str, load: Callable[[str], bytes], rel: str = "", depth: int = 0,
          seen: tuple[str, ...] = ()) -> Iterator[Line]:
    """The deck's lines, with ``*INCLUDE`` files spliced in where they are named."""
    data = load(rel)
    lines = data.splitlines()
    k = 0
    while k < len(lines):
        text = lines[k]
        if text.lstrip().startswith(b"*") and not text.lstrip().startswith(b"**") \
                and _INCLUDE.match(text.decode("latin-1")):
            full, j = text.decode("latin-1"), k
            while full.rstrip().endswith(",") and j + 1 < len(lines):
                j += 1
                full += lines[j].decode("latin-1")
            _, params = _split_keyword(full)
            target = params.get("INPUT")
            where = f"{rel or name} line {k + 1}"
            if not target:
                raise UnreadableFileError(f"{where}: *INCLUDE names no INPUT= file", code="bad_include", file=name,
                                          line=k + 1)
            inc = _include_path(name, rel, target, where)
            if depth + 1 > MAX_INCLUDE_DEPTH or inc in seen:
                why = "includes itself" if inc in seen else f"nests deeper than {MAX_INCLUDE_DEPTH} files"
                raise UnreadableFileError(f"{where}: *INCLUDE of {target!r} {why}", code="bad_include", file=name,
                                          include=target)
            yield from _walk(name, load, inc, depth + 1, (*seen, rel))
            k = j + 1
            continue
        yield Line(rel, k, text)
        k += 1


def _include_path(name: str, rel: str, target: str, where: str) -> str:
    """The include's path relative to the deck's folder; refuses one outside it."""
    t = target.replace("\\", "/")
    if os.path.isabs(t) or re.match(r"^[A-Za-z]:", t):
        raise UnreadableFileError(
            f"{where}: *INCLUDE, INPUT={target} is an absolute path; tetmorph reads included files only from the "
            "deck's folder and below: give the path relative to the deck", code="include_outside", file=name,
            include=target)
    joined = os.path.normpath(os.path.join(os.path.dirname(rel), t)).replace("\\", "/")
    if joined.startswith("../") or joined == "..":
        raise UnreadableFileError(
            f"{where}: *INCLUDE, INPUT={target} lies outside the deck's folder; tetmorph reads included files "
            "only from the deck's folder and below", code="include_outside", file=name, include=target)
    return joined


def folder_loader(path: str) -> Callable[[str], bytes]:
    """``load(rel) -> bytes`` for :func:`parse_deck`: the deck at ``path``, or a file it includes."""
    folder = os.path.dirname(os.path.abspath(path))
    name = os.path.basename(path)

    def load(rel: str) -> bytes:
        target = path if not rel else os.path.join(folder, rel)
        try:
            with open(target, "rb") as fh:
                return fh.read()
        except OSError:
            raise UnreadableFileError(f"{name!r} includes {rel!r}, which is not beside it (looked for "
                                      f"{os.path.join(os.path.dirname(name), rel)!r} relative to the deck)",
                                      code="include_missing", file=name, include=rel) from None
    return load


# --------------------------------------------------------------------------- the deck's structure


@dataclass
class _Block:
    """One ``*ELEMENT`` block of a scope."""

    abaqus: str
    kind: str | None
    labels: list[int] = field(default_factory=list)
    nodes: Any = field(default_factory=list)  #: list of lists, or an (n, k) int array
    lines: list[Line] = field(default_factory=list)


@dataclass
class Scope:
    """Nodes, elements and sets numbered together: the model (a flat deck), a part, an instance, the assembly."""

    name: str
    labels: list[int] = field(default_factory=list)
    xyz: list[tuple[float, float, float]] = field(default_factory=list)
    lines: list[Line] = field(default_factory=list)
    blocks: list[_Block] = field(default_factory=list)
    nsets: dict[str, tuple[str, list[Any]]] = field(default_factory=dict)  # upper -> (name as written, items)
    elsets: dict[str, tuple[str, list[Any]]] = field(default_factory=dict)
    _sorted: tuple[np.ndarray, np.ndarray] | None = None

    def index_of(self) -> tuple[np.ndarray, np.ndarray]:
        """Sorted node labels and, for each, the row of the node in this scope."""
        if self._sorted is None:
            lab = np.asarray(self.labels, np.int64)
            order = np.argsort(lab, kind="stable")
            self._sorted = (lab[order], order)
        return self._sorted


@dataclass
class Instance:
    """A part placed in the assembly: ``x = R (x_part + t - a) + a``."""

    name: str
    part: str
    R: np.ndarray
    t: np.ndarray
    a: np.ndarray
    own: Scope
    line: Line

    def place(self, X: np.ndarray) -> np.ndarray:
        """Part-local (n, 3) positions in assembly coordinates."""
        return (X + self.t - self.a) @ self.R.T + self.a

    def unplace(self, X: np.ndarray) -> np.ndarray:
        """Assembly (n, 3) positions in part-local coordinates (the inverse of :meth:`place`)."""
        return (X - self.a) @ self.R + self.a - self.t

    @property
    def moves(self) -> bool:
        """Whether the placement is not the identity."""
        return bool(np.any(self.t) or not np.array_equal(self.R, np.eye(3)))


@dataclass
class Deck:
    """A parsed deck: its scopes and where each point of the mesh comes from.

    Attributes
    ----------
    model : Scope
        Nodes, elements and sets outside any part, instance and assembly.
    parts : dict of str to Scope
        By upper-case name.
    instances : list of Instance
    assembly : Scope
        Nodes and sets of the assembly (not inside an instance).
    origin : list of (Scope, Instance or None)
        The points of the mesh in order: each scope's nodes, placed by the instance.
    """

    name: str
    model: Scope
    parts: dict[str, Scope]
    instances: list[Instance]
    assembly: Scope
    origin: list[tuple[Scope, Instance | None]]

    @property
    def is_assembly(self) -> bool:
        """Whether the deck places parts with instances."""
        return bool(self.instances)


def _rotation(axis_a: np.ndarray, axis_b: np.ndarray, angle_deg: float, where: str, name: str) -> np.ndarray:
    d = axis_b - axis_a
    n = float(np.linalg.norm(d))
    if angle_deg == 0.0:
        return np.eye(3)
    if not n > 0:
        raise UnreadableFileError(f"{where}: the rotation axis of the instance has two equal points a and b",
                                  code="bad_instance", file=name)
    u = d / n
    th = np.deg2rad(angle_deg)
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * (K @ K)


def _numbers(text: bytes) -> list[str]:
    return [f.strip() for f in text.decode("latin-1").split(",")]


def _int_table(lines: list[Line], width: int) -> np.ndarray | None:
    """The data lines as one (n, width) int64 table, or None when they are not exactly that (then line by line)."""
    flat = b",".join([ln.text for ln in lines]).split(b",")
    if len(flat) != width * len(lines):
        return None
    try:
        return np.array(flat).astype(np.int64).reshape(len(lines), width)
    except ValueError:
        return None


def _node_table(lines: list[Line]) -> tuple[np.ndarray, np.ndarray] | None:
    """Node labels (n,) and finite positions (n, 3) of lines that are all ``label, x, y, z``; else None."""
    if not lines:
        return None
    joined = b",".join([ln.text for ln in lines])
    if b"d" in joined or b"D" in joined:
        joined = joined.replace(b"d", b"e").replace(b"D", b"e")  # Fortran exponents
    flat = joined.split(b",")
    if len(flat) != 4 * len(lines):
        return None
    try:
        labels = np.array(flat[0::4]).astype(np.int64)
        X = np.array(flat).reshape(-1, 4)[:, 1:].astype(np.float64)
    except ValueError:
        return None
    if not np.isfinite(X).all():
        return None  # line by line, to name the node
    return labels, X


def _float(f: str) -> float:
    return float(f.replace("d", "e").replace("D", "e")) if f else 0.0


class _Parser:
    """One pass over the deck's lines, filling the scopes."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.model = Scope("")
        self.parts: dict[str, Scope] = {}
        self.instances: list[Instance] = []
        self.assembly = Scope("")
        self.scope = self.model
        self.instance_kw: Keyword | None = None
        self.instance_data: list[list[float]] = []
        self.where = "model"

    def where_of(self, line: Line) -> str:
        return f"{line.file or self.name} line {line.row + 1}"

    def error(self, line: Line, msg: str, code: str = "bad_deck", **details: Any) -> UnreadableFileError:
        return UnreadableFileError(f"{self.where_of(line)}: {msg}", code=code, file=self.name,
                                   line=line.row + 1, **({"in": line.file} if line.file else {}), **details)

    def run(self, lines: Iterator[Line]) -> None:
        kw: Keyword | None = None
        pending: list[Line] = []
        cont: Line | None = None
        text = ""
        for line in lines:
            s = line.text.lstrip()
            if s.startswith(b"**"):
                continue
            if cont is not None:  # a keyword line continued by a trailing comma
                text += line.text.decode("latin-1")
                if text.rstrip().endswith(","):
                    continue
                kw = self.keyword(text, cont)
                cont = None
                continue
            if s.startswith(b"*"):
                if kw is not None:
                    self.data(kw, pending)
                pending = []
                text = line.text.decode("latin-1")
                if text.rstrip().endswith(","):
                    cont = line
                    continue
                kw = self.keyword(text, line)
                continue
            if s.strip() and kw is not None:
                pending.append(line)
        if cont is not None:
            kw = self.keyword(text, cont)
        if kw is not None:
            self.data(kw, pending)
        if self.instance_kw is not None:
            raise self.error(self.instance_kw.line, f"*INSTANCE, NAME={self.instance_kw.get('NAME')} has no "
                             "*END INSTANCE: the deck is truncated", code="truncated_file")

    def keyword(self, text: str, line: Line) -> Keyword:
        name, params = _split_keyword(text)
        kw = Keyword(name, params, line)
        if name == "PART":
            part = params.get("NAME")
            if not part:
                raise self.error(line, "*PART has no NAME=")
            if part.upper() in self.parts:
                raise self.error(line, f"part {part!r} is defined twice", code="duplicate_part")
            self.scope = self.parts[part.upper()] = Scope(part)
        elif name == "END PART":
            self.scope = self.model
        elif name == "ASSEMBLY":
            self.scope = self.assembly
        elif name == "END ASSEMBLY":
            self.scope = self.model
        elif name == "INSTANCE":
            self.start_instance(kw)
        elif name == "END INSTANCE":
            self.end_instance(line)
        return kw

    def start_instance(self, kw: Keyword) -> None:
        inst, part = kw.get("NAME"), kw.get("PART")
        if kw.get("INSTANCE") or kw.get("LIBRARY"):
            raise self.error(kw.line, f"*INSTANCE {inst!r} is imported from a previous analysis (INSTANCE= or "
                             "LIBRARY=): tetmorph reads instances of parts defined in the deck", code="bad_instance")
        if not inst or not part:
            raise self.error(kw.line, "*INSTANCE needs NAME= and PART=", code="bad_instance")
        if any(i.name.upper() == inst.upper() for i in self.instances):
            raise self.error(kw.line, f"instance {inst!r} is defined twice", code="bad_instance")
        self.instance_kw = kw
        self.instance_data = []
        self.scope = Scope(inst)

    def end_instance(self, line: Line) -> None:
        kw = self.instance_kw
        if kw is None:
            raise self.error(line, "*END INSTANCE without *INSTANCE", code="bad_instance")
        inst, part = kw.get("NAME") or "", kw.get("PART") or ""
        if part.upper() not in self.parts:
            known = ", ".join(s.name for s in self.parts.values()) or "none"
            raise self.error(kw.line, f"instance {inst!r} places part {part!r}, which no *PART defines before it "
                             f"(parts: {known})", code="bad_instance", part=part)
        t, R, a = np.zeros(3), np.eye(3), np.zeros(3)
        rows = self.instance_data
        if len(rows) >= 1:
            t = np.asarray((rows[0] + [0.0] * 3)[:3], float)
        if len(rows) >= 2:
            r = rows[1] + [0.0] * (7 - len(rows[1]))
            a, b = np.asarray(r[:3], float), np.asarray(r[3:6], float)
            R = _rotation(a, b, float(r[6]), self.where_of(kw.line), self.name)
        self.instances.append(Instance(inst, self.parts[part.upper()].name, R, t, a, self.scope, kw.line))
        self.instance_kw = None
        self.scope = self.assembly

    def data(self, kw: Keyword, lines: list[Line]) -> None:
        name = kw.name
        if name == "INSTANCE":
            for ln in lines:
                try:
                    self.instance_data.append([_float(f) for f in _numbers(ln.text) if f])
                except ValueError:
                    raise self.error(ln, f"the placement line of instance {kw.get('NAME')!r} holds a field that "
                                     f"is not a number: {ln.text[:80]!r}", code="bad_instance") from None
        elif name == "NODE":
            self.nodes(kw, lines)
        elif name == "ELEMENT":
            self.elements(kw, lines)
        elif name == "NSET":
            self.set_(kw, lines, "NSET")
        elif name == "ELSET":
            self.set_(kw, lines, "ELSET")

    def nodes(self, kw: Keyword, lines: list[Line]) -> None:
        if kw.get("INPUT"):
            raise self.error(kw.line, "*NODE, INPUT= reads nodes from another file: use *INCLUDE instead",
                             code="unsupported_keyword")
        sc = self.scope
        first = len(sc.labels)
        fast = _node_table(lines)
        if fast is not None:
            sc.labels.extend(fast[0].tolist())
            sc.xyz.extend(fast[1].tolist())
            sc.lines.extend(lines)
            lines = []
        for ln in lines:
            f = _numbers(ln.text)
            try:
                label = int(f[0])
                x = [_float(v) for v in f[1:4]]
            except (ValueError, IndexError):
                raise self.error(ln, f"a node line needs a node number and coordinates: {ln.text[:80]!r}",
                                 code="bad_node_line") from None
            if not x:
                raise self.error(ln, f"node {label} has no coordinates: {ln.text[:80]!r}", code="bad_node_line")
            if not all(np.isfinite(x)):
                raise self.error(ln, f"node {label} has a coordinate that is not a finite number: "
                                 f"{ln.text[:80]!r}", code="non_finite_coordinates", node=label)
            sc.labels.append(label)
            sc.xyz.append((x + [0.0, 0.0])[:3])  # type: ignore[arg-type]
            sc.lines.append(ln)
        nset = kw.get("NSET")
        if nset:
            self.add_set(sc.nsets, nset, sc.labels[first:])

    def elements(self, kw: Keyword, lines: list[Line]) -> None:
        typ = kw.get("TYPE")
        if not typ:
            raise self.error(kw.line, "*ELEMENT has no TYPE=", code="bad_element_line")
        kind = _meshio_type(typ)
        block = _Block(typ.upper(), kind)
        per = num_nodes_per_cell.get(kind, 0) if kind else 0
        acc: list[int] = []
        start: Line | None = None
        table = _int_table(lines, per + 1) if per and per < 16 else None
        if table is not None:  # one element a line, every field a number: read at once
            block.labels, block.nodes, block.lines = table[:, 0].tolist(), table[:, 1:], list(lines)
            lines = []
        for ln in lines:
            try:
                vals = [int(v) for v in _numbers(ln.text) if v]
            except ValueError:
                raise self.error(ln, f"an element line of {typ} holds a field that is not a number: "
                                 f"{ln.text[:80]!r}", code="bad_element_line") from None
            if start is None:
                start = ln
            acc += vals
            more = ln.text.rstrip().endswith(b",") if not per else len(acc) < per + 1
            if more:
                continue
            if per and len(acc) != per + 1:
                raise self.error(start, f"element {acc[0]} of type {typ} lists {len(acc) - 1} nodes, where "
                                 f"{typ} has {per}", code="bad_element_line", element=acc[0])
            block.labels.append(acc[0])
            block.nodes.append(acc[1:])
            block.lines.append(start)
            acc, start = [], None
        if acc and start is not None:
            raise self.error(start, f"element {acc[0]} of type {typ} lists {len(acc) - 1} of its {per} nodes and "
                             "the block ends: the deck is truncated", code="truncated_file", element=acc[0])
        self.scope.blocks.append(block)
        elset = kw.get("ELSET")
        if elset:
            self.add_set(self.scope.elsets, elset, np.asarray(block.labels).tolist())

    def set_(self, kw: Keyword, lines: list[Line], key: str) -> None:
        name = kw.get(key)
        if not name:
            raise self.error(kw.line, f"*{key} has no {key}=", code="bad_set")
        items: list[Any] = []
        generate = "GENERATE" in kw.params
        for ln in lines:
            fields = [f for f in _numbers(ln.text) if f]
            if generate:
                try:
                    g = [int(v) for v in fields] + [1]
                except ValueError:
                    raise self.error(ln, f"a GENERATE line of set {name!r} needs first, last[, step]: "
                                     f"{ln.text[:80]!r}", code="bad_set") from None
                first, last, step = g[0], g[1] if len(g) > 2 else g[0], g[2] if len(g) > 3 else 1
                if step <= 0 or last < first or (last - first) // step > 50_000_000:
                    raise self.error(ln, f"GENERATE {first}, {last}, {step} of set {name!r} is not an increasing "
                                     "range", code="bad_set")
                items.extend(range(first, last + 1, step))
                continue
            for f in fields:
                try:
                    items.append(int(f))
                except ValueError:
                    items.append(f)  # a set name, or instance.label
        target = self.scope
        inst = kw.get("INSTANCE")
        if inst:
            items = [("@", inst, x) for x in items]
        if key == "NSET" and kw.get("ELSET"):
            items.append(("ELSET", inst, kw.get("ELSET")))
        self.add_set(target.nsets if key == "NSET" else target.elsets, name, items)

    @staticmethod
    def add_set(sets: dict[str, tuple[str, list[Any]]], name: str, items: list[Any]) -> None:
        old = sets.get(name.upper())
        sets[name.upper()] = (old[0] if old else name, (old[1] if old else []) + list(items))


def parse_deck(name: str, load: Callable[[str], bytes]) -> Deck:
    """Parse a deck and the files it includes.

    Parameters
    ----------
    name : str
        The deck's file name (for messages).
    load : callable
        ``load(rel) -> bytes``: the deck (``rel == ""``) or an included file
        (its path relative to the deck's folder).

    Returns
    -------
    Deck
    """
    p = _Parser(name)
    p.run(_walk(name, load))
    origin: list[tuple[Scope, Instance | None]] = []
    if p.instances:
        for inst in p.instances:
            origin.append((p.parts[inst.part.upper()], inst))
            origin.append((inst.own, inst))
        origin.append((p.assembly, None))
    elif p.parts and any(s.labels for s in p.parts.values()):
        part = next(s for s in p.parts.values() if s.labels)
        raise UnreadableFileError(
            f"{name!r} defines part {part.name!r} but no *ASSEMBLY places it with an *INSTANCE: a part alone is "
            "not in the model", code="bad_instance", file=name, part=part.name)
    origin.append((p.model, None))
    return Deck(name, p.model, p.parts, p.instances, p.assembly, origin)


# --------------------------------------------------------------------------- the mesh


def _scope_points(sc: Scope, inst: Instance | None) -> np.ndarray:
    X = np.asarray(sc.xyz, np.float64).reshape(-1, 3)
    return inst.place(X) if inst is not None and inst.moves and len(X) else X


def deck_points(deck: Deck) -> np.ndarray:
    """(n, 3) assembly positions of the deck's points, in :attr:`Deck.origin` order."""
    parts = [_scope_points(sc, inst) for sc, inst in deck.origin]
    return np.concatenate(parts) if parts else np.zeros((0, 3))


