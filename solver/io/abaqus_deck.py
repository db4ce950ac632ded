"""Abaqus and CalculiX decks: flat decks, Abaqus/CAE assemblies and ``*INCLUDE``.

A deck is read as Abaqus reads it, not as a list of ``*NODE`` lines:

- keywords in any case, with blanks around ``=`` and keyword lines continued
  by a trailing comma; ``**`` comments; data lines continued by a trailing
  comma (element lines of more than 15 nodes);
- any number of ``*NODE`` and ``*ELEMENT`` blocks anywhere in the deck;
- ``*PART ... *END PART`` with part-local node and element numbers, and
  ``*ASSEMBLY`` / ``*INSTANCE`` placing each part: the translation line, then
  the rotation line (points a and b on the axis, the angle in degrees), the
  translation applied first; nodes, elements and sets defined inside an
  instance;
- ``*NSET`` / ``*ELSET`` with ``GENERATE``, ``INSTANCE=``, ``ELSET=``, set names
  among the labels, and ``instance.label`` references; a set defined in a part
  or an instance is named ``Instance.Set``;
- ``*INCLUDE, INPUT=file`` relative to the deck's folder, at most
  :data:`MAX_INCLUDE_DEPTH` deep, never outside that folder.

The mesh is in assembly coordinates. :func:`patch_deck` writes it back in
place: each moved node's line of its part gets the part-local coordinates
(the inverse of its instance's placement), and nothing else changes. A part
placed by several instances that no longer agree is refused, naming the part
and the instances; :func:`solver.io.abaqus_flat.flatten` then writes one flat deck instead.
"""

from __future__ import annotations

import os
import re
from typing import Any

import meshio
import numpy as np

from ..errors import UnreadableFileError
from .abaqus_parse import (
    MAX_INCLUDE_DEPTH,
    Deck,
    Instance,
    Scope,
    _walk,
    deck_points,
    folder_loader,
    kind_words,
    parse_deck,
)
from .diagnose import check_last_line, undefined_node_error
from .element_words import no_volume_words
from .patch_inp import coordinate_text
from .patchers import Patcher
from .read_bounds import ReadBounds, check_read_sizes
from .registry import FileFormat, register_format

__all__ = ["is_assembly", "read_deck", "to_meshio", "patch_deck", "deck_includes", "AssemblyWriteError",
           "MAX_INCLUDE_DEPTH", "parse_deck", "sniff", "undefined_inp_node"]


class _Resolver:
    """Node and element labels of a scope (with its instance) to global rows."""

    def __init__(self, deck: Deck) -> None:
        self.deck = deck
        self.rows: dict[tuple[str, int], tuple[np.ndarray, np.ndarray]] = {}
        start = 0
        for sc, inst in deck.origin:
            lab, order = sc.index_of()
            self.rows[(inst.name.upper() if inst else "", id(sc))] = (lab, order + start)
            start += len(sc.labels)
        self.n = start

    def node_rows(self, inst: Instance | None, scopes: list[Scope], labels: np.ndarray) -> tuple[np.ndarray,
                                                                                                 np.ndarray]:
        """Rows of ``labels`` looked up in ``scopes`` (first match wins); -1 where undefined."""
        out = np.full(labels.shape, -1, np.int64)
        key = inst.name.upper() if inst else ""
        for sc in scopes:
            lab, rows = self.rows[(key, id(sc))]
            if not len(lab):
                continue
            at = np.clip(np.searchsorted(lab, labels), 0, len(lab) - 1)
            hit = (lab[at] == labels) & (out < 0)
            out[hit] = rows[at[hit]]
        return out, out < 0


def _check_duplicates(deck: Deck) -> None:
    for sc, _ in deck.origin:
        lab, order = sc.index_of()
        dup = np.flatnonzero(lab[1:] == lab[:-1])
        if dup.size:
            i, j = sorted((int(order[dup[0]]), int(order[dup[0] + 1])))
            a, b = sc.lines[i], sc.lines[j]
            where = f"part {sc.name!r}" if sc.name else "the model"
            raise UnreadableFileError(
                f"{deck.name!r}: node {int(lab[dup[0]])} of {where} is defined twice ({a.file or deck.name} line "
                f"{a.row + 1} and {b.file or deck.name} line {b.row + 1}); {dup.size} labels are defined more "
                "than once", code="duplicate_node", file=deck.name, node=int(lab[dup[0]]), count=int(dup.size))


def _scopes_of(deck: Deck, sc: Scope, inst: Instance | None) -> list[Scope]:
    """The scopes whose nodes an element or set of ``sc`` may name."""
    if inst is not None:
        return [deck.parts[inst.part.upper()], inst.own]
    return [sc]


def to_meshio(deck: Deck) -> meshio.Mesh:
    """The deck as a :class:`meshio.Mesh` in assembly coordinates, with its sets.

    Raises
    ------
    UnreadableFileError
        ``undefined_node``, ``duplicate_node``, ``bad_set``.
    """
    _check_duplicates(deck)
    res = _Resolver(deck)
    cells: list[meshio.CellBlock] = []
    cell_labels: list[np.ndarray] = []
    cell_owner: list[tuple[str, Scope]] = []  # (instance name or "", scope) per block
    other: dict[str, int] = {}
    for sc, inst in deck.origin:
        for b in sc.blocks:
            if not b.labels:
                continue
            if b.kind not in _VOLUME:
                other[b.abaqus] = other.get(b.abaqus, 0) + len(b.labels)
            if b.kind is None:
                continue
            conn = np.asarray(b.nodes, np.int64)
            rows, missing = res.node_rows(inst, _scopes_of(deck, sc, inst), conn)
            if missing.any():
                e, k = np.argwhere(missing)[0]
                ln = b.lines[e]
                where = f" of instance {inst.name!r}" if inst else (f" of part {sc.name!r}" if sc.name else "")
                raise UnreadableFileError(
                    f"{ln.file or deck.name!r} line {ln.row + 1}: element {b.labels[e]} ({b.abaqus}){where} refers "
                    f"to node {int(conn[e, k])}, which no node definition{where} defines; "
                    f"{int(missing.any(1).sum())} element lines name undefined nodes", code="undefined_node",
                    file=deck.name, element=int(b.labels[e]), node=int(conn[e, k]), line=ln.row + 1)
            cells.append(meshio.CellBlock(b.kind, rows))
            cell_labels.append(np.asarray(b.labels, np.int64))
            cell_owner.append((inst.name.upper() if inst else "", sc))
    if not any(c.type in _VOLUME or c.type == "triangle" for c in cells):
        _refuse_unsupported(deck, other)
    m = meshio.Mesh(deck_points(deck), cells)
    m.point_sets, m.cell_sets = _sets(deck, res, cells, cell_labels, cell_owner)
    labels = np.concatenate([np.asarray(sc.labels, np.int64) for sc, _ in deck.origin]) if deck.origin else \
        np.zeros(0, np.int64)
    m.points_id = labels  # type: ignore[attr-defined]
    m.cells_id = cell_labels  # type: ignore[attr-defined]
    m.instances = [i.name for i in deck.instances]  # type: ignore[attr-defined]
    return m


def is_assembly(mesh: Any) -> bool:
    """Whether a mesh was read from an Abaqus/CAE assembly deck (parts placed by instances)."""
    return bool(getattr(getattr(mesh, "source", None), "instances", None))


#: meshio cell types of volume elements.
_VOLUME = {"tetra", "tetra10", "hexahedron", "wedge", "pyramid", "hexahedron20", "wedge15", "pyramid13"}


def _refuse_unsupported(deck: Deck, counts: dict[str, int]) -> None:
    """A deck of shells, beams and other elements without a volume (or a triangle surface) to morph."""
    if not counts:
        return  # no elements at all: the mesh's own check names it
    words = ", ".join(f"{n:,} {kind_words(t)} element{'s' if n > 1 else ''} ({t})" for t, n in counts.items())
    shells = all(kind_words(t) in _SHELL_KINDS for t in counts)
    raise UnreadableFileError(no_volume_words(repr(deck.name), shells, words, "C3D4, C3D10"), code="no_elements",
                              file=deck.name, cells=counts)


#: Abaqus element kinds (:func:`kind_words`) that are shells or surfaces: faces without a volume.
_SHELL_KINDS = {"shell", "membrane", "rigid"}


def _sets(deck: Deck, res: _Resolver, cells: list[meshio.CellBlock], cell_labels: list[np.ndarray],
          owner: list[tuple[str, Scope]]) -> tuple[dict[str, np.ndarray], dict[str, list[np.ndarray]]]:
    """Node sets (global rows) and element sets (per block indices), named ``Instance.Set`` where scoped."""
    point_sets: dict[str, np.ndarray] = {}
    cell_sets: dict[str, list[np.ndarray]] = {}
    by_inst = {i.name.upper(): i for i in deck.instances}

    def elem_index(inst_key: str, scopes: list[Scope], labels: list[int]) -> list[np.ndarray]:
        want = np.asarray(labels, np.int64)
        out = []
        for (key, sc), lab in zip(owner, cell_labels, strict=True):
            ok = key == inst_key and any(sc is s for s in scopes)
            out.append(np.flatnonzero(np.isin(lab, want)) if ok else np.zeros(0, np.int64))
        return out

    def resolve(sc: Scope, inst: Instance | None, items: list[Any], kind: str, seen: tuple[str, ...],
                setname: str) -> tuple[list[np.ndarray], list[list[np.ndarray]]]:
        """Node rows (kind NSET) or element indices per block (kind ELSET) of a set's items."""
        scopes = _scopes_of(deck, sc, inst)
        ints = [x for x in items if isinstance(x, int)]
        nodes: list[np.ndarray] = []
        elems: list[list[np.ndarray]] = []
        key = inst.name.upper() if inst else ""
        if ints:
            if kind == "NSET":
                rows, missing = res.node_rows(inst, scopes, np.asarray(ints, np.int64))
                nodes.append(rows[~missing])
            else:
                elems.append(elem_index(key, scopes, ints))
        for x in items:
            if isinstance(x, int):
                continue
            if isinstance(x, tuple) and x[0] == "@":  # INSTANCE= on an assembly set
                target = by_inst.get(str(x[1]).upper())
                if target is None:
                    raise UnreadableFileError(f"{deck.name!r}: set {setname!r} names instance {x[1]!r}, which the "
                                              "assembly does not define", code="bad_set", file=deck.name,
                                              set=setname, instance=x[1])
                n, e = resolve(target.own, target, [x[2]], kind, seen, setname)
                nodes += n
                elems += e
                continue
            if isinstance(x, tuple) and x[0] == "ELSET":  # *NSET, ELSET=: the nodes of the elements
                target = by_inst.get(str(x[1]).upper()) if x[1] else inst
                _, e = resolve(target.own if target else sc, target, [x[2]], "ELSET", seen, setname)
                nodes += [np.asarray(c.data)[ix].ravel() for per in e for c, ix in zip(cells, per, strict=True)]
                continue
            text = str(x)
            inst_name, dot, rest = text.partition(".")
            if dot and inst_name.upper() in by_inst and inst is None:  # instance.label or instance.set
                target = by_inst[inst_name.upper()]
                item: Any = int(rest) if rest.lstrip("-").isdigit() else rest
                n, e = resolve(target.own, target, [item], kind, seen, setname)
                nodes += n
                elems += e
                continue
            found = None
            for s in scopes if inst is None else [deck.parts[inst.part.upper()], inst.own]:
                table = s.nsets if kind == "NSET" else s.elsets
                if text.upper() in table:
                    found = (s, table[text.upper()][1])
                    break
            if found is None or text.upper() in seen:
                raise UnreadableFileError(
                    f"{deck.name!r}: set {setname!r} lists {text!r}, which is neither a number nor a "
                    f"{'node' if kind == 'NSET' else 'element'} set defined before it", code="bad_set",
                    file=deck.name, set=setname, item=text[:80])
            n, e = resolve(found[0] if inst is None else sc, inst, found[1], kind, (*seen, text.upper()), setname)
            nodes += n
            elems += e
        return nodes, elems

    def add(prefix: str, sc: Scope, inst: Instance | None) -> None:
        for upper, (written, items) in sc.nsets.items():
            n, _ = resolve(sc, inst, items, "NSET", (upper,), written)
            rows = np.unique(np.concatenate(n)) if n else np.zeros(0, np.int64)
            point_sets[prefix + written] = rows
        for upper, (written, items) in sc.elsets.items():
            _, e = resolve(sc, inst, items, "ELSET", (upper,), written)
            per = [np.unique(np.concatenate([x[b] for x in e])) if e else np.zeros(0, np.int64)
                   for b in range(len(cells))]
            cell_sets[prefix + written] = per

    try:
        add("", deck.model, None)
        for inst in deck.instances:
            add(inst.name + ".", deck.parts[inst.part.upper()], inst)
            add(inst.name + ".", inst.own, inst)
        add("", deck.assembly, None)
        return point_sets, cell_sets
    finally:
        # resolve calls itself through its closure cell, a cycle that would hold the whole parsed deck (a
        # tuple per line) until the next full garbage collection: cleared, the deck is freed on return
        resolve = None  # type: ignore[assignment]


# --------------------------------------------------------------------------- reading


def deck_includes(path: str) -> list[str]:
    """The files a deck includes, relative to its folder, in the order they are read."""
    name = os.path.basename(path)
    seen: list[str] = []
    load = folder_loader(path)

    def tracking(rel: str) -> bytes:
        if rel and rel not in seen:
            seen.append(rel)
        return load(rel)

    for _ in _walk(name, tracking):
        pass
    return seen


def read_deck(path: str, bounds: ReadBounds | None = None) -> meshio.Mesh:
    """Read an Abaqus or CalculiX deck (flat or an assembly, with its includes) as a meshio mesh.

    Parameters
    ----------
    path : str
    bounds : ReadBounds, optional

    Returns
    -------
    meshio.Mesh
        Points in assembly coordinates, in :attr:`Deck.origin` order; ``point_sets`` and
        ``cell_sets`` by name (``Instance.Set`` where scoped); ``points_id`` the deck's own node numbers.
    """
    name = os.path.basename(path)
    deck = parse_deck(name, folder_loader(path))
    n = sum(len(sc.labels) for sc, _ in deck.origin)
    check_read_sizes(name, n, sum(len(b.labels) for sc, _ in deck.origin for b in sc.blocks), bounds or ReadBounds())
    return to_meshio(deck)


# --------------------------------------------------------------------------- writing back


class AssemblyWriteError(ValueError):
    """A part placed by several instances whose shapes now differ: one set of part nodes cannot hold them."""


def _format_line(line: bytes, X_new: np.ndarray, X_old: np.ndarray) -> bytes:
    body = line.rstrip(b"\r\n")
    end = line[len(body):]
    fields = body.split(b",")
    for j in range(3):
        if X_new[j] == X_old[j]:
            continue
        if 1 + j < len(fields):
            f = fields[1 + j]
            fields[1 + j] = f[: len(f) - len(f.lstrip())] + coordinate_text(X_new[j])
        else:
            fields.append(b" " + coordinate_text(X_new[j]))
    return b",".join(fields) + end


def _local_positions(deck: Deck, V: np.ndarray, X0: np.ndarray, tol: float) -> dict[int, np.ndarray]:
    """Per scope (by id) the part-local positions its node lines must hold.

    Raises
    ------
    AssemblyWriteError
        A part's instances disagree.
    """
    out: dict[int, np.ndarray] = {}
    who: dict[int, str] = {}
    moved_by: dict[int, np.ndarray] = {}
    start = 0
    for sc, inst in deck.origin:
        k = len(sc.labels)
        Vs, Xs = V[start:start + k], X0[start:start + k]
        start += k
        if not k:
            continue
        moved = (Vs != Xs).any(1)
        local0 = np.asarray(sc.xyz, np.float64).reshape(-1, 3)
        local = local0.copy()
        if moved.any():
            local[moved] = inst.unplace(Vs[moved]) if inst is not None and inst.moves else Vs[moved]
        key = id(sc)
        if key in out:  # another instance of the same part
            prev = out[key]
            diff = np.abs(prev - local).max(1)
            bad = np.flatnonzero(diff > tol)
            if bad.size:
                assert inst is not None
                raise AssemblyWriteError(
                    f"part {sc.name!r} is placed by instances {who[key]!r} and {inst.name!r}, which now differ "
                    f"(node {sc.labels[int(bad[0])]} by {float(diff[bad].max()):.3g}, {bad.size} nodes in all): one "
                    "part cannot hold both shapes. Move the instances alike, or write a flat deck "
                    "(flatten=True; CLI --flatten)")
            moved_by[key] |= moved
            continue
        out[key], who[key], moved_by[key] = local, inst.name if inst else "", moved
    return {k: np.where(moved_by[k][:, None], v, np.nan) for k, v in out.items()}


def patch_deck(raw: bytes, V: np.ndarray, included: dict[str, bytes] | None = None) -> dict[str, bytes]:
    """The deck and its included files with new coordinates, nothing else changed.

    Parameters
    ----------
    raw : bytes
        The deck.
    V : (n, 3) float array
        New assembly positions, in the order the deck was read (:func:`read_deck`).
    included : dict of str to bytes, optional
        The included files by relative path.

    Returns
    -------
    dict of str to bytes
        ``""``: the deck; each included file by its path.

    Raises
    ------
    ValueError
        ``V`` does not match the deck's nodes; :class:`AssemblyWriteError` when
        instances of one part differ.
    """
    files = {"": raw, **(included or {})}

    def load(rel: str) -> bytes:
        if rel not in files:
            raise ValueError(f"the deck includes {rel!r}, which was not kept with it")
        return files[rel]

    deck = parse_deck("deck", load)
    X0 = deck_points(deck)
    V = np.asarray(V, np.float64)
    if V.shape != X0.shape:
        raise ValueError(f"the deck has {len(X0)} nodes, the positions {V.shape[0]} rows")
    scale = float(np.abs(X0).max()) if X0.size else 1.0
    local = _local_positions(deck, V, X0, 1e-9 * max(scale, 1.0))
    lines = {k: v.splitlines(keepends=True) for k, v in files.items()}
    for sc, _ in deck.origin:
        L = local.get(id(sc))
        if L is None:
            continue
        old = np.asarray(sc.xyz, np.float64).reshape(-1, 3)
        for i in np.flatnonzero(~np.isnan(L[:, 0])):
            ln = sc.lines[i]
            lines[ln.file][ln.row] = _format_line(lines[ln.file][ln.row], L[i], old[i])
    return {k: b"".join(v) for k, v in lines.items()}


def _patch_main(raw: bytes, V: np.ndarray) -> bytes:
    return patch_deck(raw, V)[""]


def _node_count(raw: bytes, n: int) -> bool:
    try:
        deck = parse_deck("deck", lambda rel: raw if not rel else b"")
    except (UnreadableFileError, ValueError):
        return False
    return sum(len(sc.labels) for sc, _ in deck.origin) == n


_KEYWORDS = re.compile(rb"^\s*\*\s*(heading|node|element|part|assembly|nset|elset|include|material|step)\b",
                       re.IGNORECASE | re.MULTILINE)


def sniff(head: bytes, size: int | None = None) -> bool:
    r"""Whether a file's first bytes hold an Abaqus keyword at a line start (``*HEADING``, ``*NODE``...).

    Asked after LS-DYNA's sniffer, whose decks have ``*NODE`` too.

    Examples
    --------
    >>> sniff(b"*Heading\n*Node\n1, 0, 0, 0\n"), sniff(b"GRID,1,,0.,0.,0.\n")
    (True, False)
    """
    return _KEYWORDS.search(head) is not None


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


def _diagnose(path: str, data: bytes, exc: BaseException) -> UnreadableFileError | None:
    """An element naming a node no ``*NODE`` block defines, for a reader that failed on the lookup."""
    found = undefined_inp_node(data) if isinstance(exc, KeyError) else None
    return undefined_node_error(os.path.basename(path), *found) if found is not None else None


register_format(FileFormat(
    "abaqus", "Abaqus/CalculiX deck (.inp)", (".inp",), aliases=("inp",), read=read_deck,
    sniff=sniff, sniff_order=900, telling=True, check_complete=check_last_line, diagnose=_diagnose,
    nodes_where="no *NODE data lines",
    patcher=Patcher("abaqus", ("inp",), ("inp",), _node_count, _patch_main, includes=deck_includes,
                    patch_tree=lambda raw, inc, V: patch_deck(raw, V, inc)),
    writes=True,
    reads="*NODE/*ELEMENT blocks anywhere, *PART/*ASSEMBLY/*INSTANCE placements, *NSET/*ELSET (GENERATE, "
          "INSTANCE=), *INCLUDE",
    refuses="parts no instance places, imported instances, includes outside the deck's folder"))
