"""A flat deck from an Abaqus/CAE assembly: one node and element numbering, no parts, instances or includes.

A part placed by several instances holds one shape; once the instances are
morphed apart, or for a solver that reads no assemblies (CalculiX), the deck
is written flat:

- each instance's nodes and elements get the instance's offset (a power of
  ten above every label of the deck, times the instance's rank), with the
  assembly positions;
- its sets become ``Instance_Set``, and the part's other keywords (sections,
  orientations, surfaces) are repeated per instance with the names the part
  defines prefixed the same way;
- assembly sets keep their names; assembly and model lines that name
  ``Instance.Set`` or ``Instance.label`` are rewritten to the flat name or number;
- ``*INCLUDE`` files are spliced in.
"""

from __future__ import annotations

import re

import numpy as np

from .abaqus_deck import to_meshio
from .abaqus_parse import Deck, Instance, Scope, _split_keyword, _walk, deck_points, parse_deck
from .patch_inp import coordinate_text

__all__ = ["flatten"]

_SETS = {"NSET", "ELSET"}
_MESH = {"NODE", "ELEMENT", "NSET", "ELSET"}


def _rows(ids: np.ndarray, per: int = 16) -> str:
    return "".join(", ".join(str(int(i)) for i in ids[k:k + per]) + "\n" for k in range(0, len(ids), per))


def _element_text(labels: np.ndarray, conn: np.ndarray) -> str:
    out = []
    for e, row in zip(labels.tolist(), conn.tolist(), strict=True):
        vals = [e, *row]
        chunks = [vals[k:k + 16] for k in range(0, len(vals), 16)]
        out.append(",\n".join(", ".join(str(v) for v in c) for c in chunks) + "\n")
    return "".join(out)


class _Flattener:
    def __init__(self, deck: Deck, V: np.ndarray) -> None:
        self.deck = deck
        self.V = V
        self.m = to_meshio(deck)
        top = max([0] + [max(sc.labels, default=0) for sc, _ in deck.origin]
                  + [max(b.labels, default=0) for sc, _ in deck.origin for b in sc.blocks])
        self.K = 10 ** len(str(top))
        self.offset = {i.name.upper(): (k + 1) * self.K for k, i in enumerate(deck.instances)}
        self.by_inst = {i.name.upper(): i for i in deck.instances}
        self.start: list[int] = []
        s = 0
        for sc, _ in deck.origin:
            self.start.append(s)
            s += len(sc.labels)
        self.flat_nodes = np.concatenate([np.asarray(sc.labels, np.int64) + self._off(inst)
                                          for sc, inst in deck.origin]) if deck.origin else np.zeros(0, np.int64)
        self.block_labels: list[np.ndarray] = []  # flat element labels per meshio cell block
        for sc, inst in deck.origin:
            for b in sc.blocks:
                if b.labels and b.kind is not None:
                    self.block_labels.append(np.asarray(b.labels, np.int64) + self._off(inst))
        self.rowmap = {(ln.file, ln.row): self.start[j] + i for j, (sc, inst) in enumerate(deck.origin)
                       if inst is None for i, ln in enumerate(sc.lines)}
        self.done_sets: set[str] = set()

    def _off(self, inst: Instance | None) -> int:
        return self.offset[inst.name.upper()] if inst is not None else 0

    # ----------------------------------------------------------------- names

    def token(self, tok: str, local: tuple[str, set[str]] | None = None) -> str:
        """A name or label rewritten for the flat deck: ``Inst.Set`` -> ``Inst_Set``, ``Inst.5`` -> offset label."""
        core = tok.strip()
        lead = tok[: len(tok) - len(tok.lstrip())]
        inst, dot, rest = core.partition(".")
        if dot and inst.upper() in self.by_inst:
            if rest.lstrip("-").isdigit():
                return lead + str(int(rest) + self.offset[inst.upper()])
            return lead + f"{self.by_inst[inst.upper()].name}_{rest}"
        if local is not None and core.upper() in local[1]:
            return lead + f"{local[0]}_{core}"
        return tok

    def rewrite(self, text: str, local: tuple[str, set[str]] | None = None, keyword: bool = False) -> str:
        """A keyword or data line with its names rewritten (parameter values, or comma-separated fields)."""
        body = text.rstrip("\r\n")
        end = text[len(body):]
        fields = body.split(",")
        out = []
        for k, f in enumerate(fields):
            if keyword and k > 0 and "=" in f:
                key, _, val = f.partition("=")
                skip = key.strip().upper() in ("TYPE", "MATERIAL", "NAME") and local is None
                out.append(key + "=" + (val if skip else self.token(val, local)))
            elif keyword and k == 0:
                out.append(f)
            else:
                out.append(self.token(f, local) if re.search(r"[A-Za-z]", f) else f)
        return ",".join(out) + end

    # ----------------------------------------------------------------- sets and meshes

    def set_text(self, key: str, flat: str, kind: str) -> str:
        if kind == "NSET":
            rows = self.m.point_sets.get(key)
            if rows is None:
                return ""
            return f"*NSET, NSET={flat}\n" + _rows(self.flat_nodes[np.asarray(rows, np.int64)])
        per = self.m.cell_sets.get(key)
        if per is None:
            return ""
        ids = np.concatenate([lab[np.asarray(ix, np.int64)] for lab, ix in zip(self.block_labels, per, strict=True)]) \
            if per else np.zeros(0, np.int64)
        return f"*ELSET, ELSET={flat}\n" + _rows(np.sort(ids))

    def instance_text(self, inst: Instance, extra: list[tuple[str, list[str]]]) -> str:
        part = self.deck.parts[inst.part.upper()]
        off = self.offset[inst.name.upper()]
        out = [f"** instance {inst.name} of part {part.name}, flattened (labels + {off})\n"]
        for j, (sc, i) in enumerate(self.deck.origin):
            if i is not inst or not sc.labels:
                continue
            X = self.V[self.start[j]:self.start[j] + len(sc.labels)]
            out.append("*NODE\n" + "".join(
                f"{lab + off}, " + ", ".join(coordinate_text(v).decode() for v in x) + "\n"
                for lab, x in zip(sc.labels, X.tolist(), strict=True)))
        for sc, i in self.deck.origin:
            if i is not inst:
                continue
            for b in sc.blocks:
                if b.labels:
                    out.append(f"*ELEMENT, TYPE={b.abaqus}\n" + _element_text(
                        np.asarray(b.labels, np.int64) + off, np.asarray(b.nodes, np.int64) + off))
        names = self.local_names(part, inst.own)
        for sc in (part, inst.own):
            for kind, table in (("NSET", sc.nsets), ("ELSET", sc.elsets)):
                for _, (written, _items) in table.items():
                    out.append(self.set_text(f"{inst.name}.{written}", f"{inst.name}_{written}", kind))
        for head, data in extra:
            out.append(self.rewrite(head, (inst.name, names), keyword=True))
            out.extend(self.rewrite(d, (inst.name, names)) for d in data)
        return "".join(out)

    @staticmethod
    def local_names(*scopes: Scope) -> set[str]:
        names: set[str] = set()
        for sc in scopes:
            names |= set(sc.nsets) | set(sc.elsets)
        return names


def flatten(raw: bytes, V: np.ndarray, included: dict[str, bytes]) -> bytes:
    """The assembly deck ``raw`` as one flat deck with assembly positions ``V`` (:mod:`solver.io.abaqus_flat`).

    Parameters
    ----------
    raw : bytes
    V : (n, 3) float array
        In the order :func:`solver.io.abaqus_deck.read_deck` reads the points.
    included : dict of str to bytes
        Included files by path relative to the deck.

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        ``V`` does not match the deck.
    """
    files = {"": raw, **included}

    def load(rel: str) -> bytes:
        if rel not in files:
            raise ValueError(f"the deck includes {rel!r}, which was not kept with it")
        return files[rel]

    deck = parse_deck("deck", load)
    V = np.asarray(V, np.float64)
    if V.shape != deck_points(deck).shape:
        raise ValueError(f"the deck has {len(deck_points(deck))} nodes, the positions {V.shape[0]} rows")
    f = _Flattener(deck, V)
    out: list[str] = []
    state, kw = "model", ""
    params: dict[str, str] = {}
    part_extra: dict[str, list[tuple[str, list[str]]]] = {}
    own_extra: list[tuple[str, list[str]]] = []
    current: list[str] | None = None
    part_name = ""
    inst: Instance | None = None
    n_inst = 0
    for line in _walk("deck", load):
        text = line.text.decode("latin-1") + "\n"
        s = text.lstrip()
        if s.startswith("**"):
            if state in ("model", "assembly"):
                out.append(text)
            continue
        if s.startswith("*"):
            kw, params = _split_keyword(text.strip())
            current = None
            if kw == "PART":
                state, part_name = "part", (params.get("NAME") or "").upper()
                part_extra[part_name] = []
                continue
            if kw == "END PART":
                state = "model"
                continue
            if kw == "ASSEMBLY":
                state = "assembly"
                continue
            if kw == "END ASSEMBLY":
                state = "model"
                continue
            if kw == "INSTANCE":
                state, inst, own_extra = "instance", deck.instances[n_inst], []
                n_inst += 1
                continue
            if kw == "END INSTANCE":
                assert inst is not None
                out.append(f.instance_text(inst, part_extra[inst.part.upper()] + own_extra))
                state, inst = "assembly", None
                continue
            if state in ("part", "instance"):
                if kw not in _MESH and kw != "INSTANCE":
                    current = []
                    (part_extra[part_name] if state == "part" else own_extra).append((text, current))
                continue
            if state == "assembly" and kw in _SETS:
                name = params.get(kw) or ""
                if name.upper() not in f.done_sets:
                    f.done_sets.add(name.upper())
                    out.append(f.set_text(name, name, kw))
                continue
            out.append(f.rewrite(text, keyword=True))
            continue
        # a data line
        if state in ("part", "instance"):
            if current is not None:
                current.append(text)
            continue
        if state == "assembly" and kw in _SETS:
            continue
        if kw == "NODE" and (line.file, line.row) in f.rowmap:
            row = f.rowmap[(line.file, line.row)]
            out.append(_node_line(text, V[row]))
            continue
        out.append(f.rewrite(text))
    return "".join(out).encode("latin-1")


def _node_line(text: str, x: np.ndarray) -> str:
    label = text.split(",", 1)[0].strip()
    return f"{label}, " + ", ".join(coordinate_text(v).decode() for v in x) + "\n"
