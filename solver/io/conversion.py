"""Cross-format writes: what the target format can hold of a mesh, and what it would lose.

:func:`convert` puts each thing a mesh carries (:mod:`solver.io.content`) where
the target holds it:

============  ===============================  ================================  =========================
target        node sets                        element sets                      material regions
============  ===============================  ================================  =========================
Abaqus        ``*NSET``                        ``*ELSET``                        ``*ELSET`` per value
Gmsh          physical groups of point cells   physical groups (``set:NAME``     physical groups and
                                               element data where an element     element data
                                               is in several)
VTU, VTK      ``set:NAME`` point data (0/1)    ``set:NAME`` cell data (0/1)      cell data, as is
Medit         vertex references (no names)     element references (no names)     element references
TetGen        boundary markers (no names)      --                                region attribute
Nastran       --                               --                                property ids (PID)
============  ===============================  ================================  =========================

Anything that does not fit (an element type, set names, data arrays, a second
label) is a :class:`Loss`; :func:`solver.io.write.write_mesh` refuses the write
when there are losses unless ``lossy=True``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import meshio
import numpy as np

from ..ops.unique import unique
from .content import VOLUME, Content
from .nastran import NASTRAN_TYPES

__all__ = ["Loss", "Conversion", "convert", "abaqus_name", "ABAQUS_TYPES", "CELL_DATA_FORMATS"]

#: meshio cell type -> Abaqus element type written (Gmsh's choice for surface and line cells).
ABAQUS_TYPES = {"tetra": "C3D4", "tetra10": "C3D10", "hexahedron": "C3D8",
                "wedge": "C3D6", "triangle": "CPS3", "triangle6": "CPE6", "quad": "CPS4",
                "quad8": "S8R", "line": "T3D2", "line3": "T3D3"}
MEDIT_TYPES = {"line", "triangle", "quad", "tetra", "wedge", "pyramid", "hexahedron"}
SURFACE_TYPES = {"stl": {"triangle"}, "obj": {"triangle", "quad"}, "off": {"triangle"}, "ply": {"triangle", "quad"}}
#: Formats that store per-element data arrays (per-element quality goes there).
CELL_DATA_FORMATS = {"vtu", "vtk", "gmsh", "gmsh22", "xdmf"}


@dataclass(frozen=True)
class Loss:
    """One thing a write would drop.

    Attributes
    ----------
    kind : str
        ``element_type``, ``quadratic_nodes``, ``node_set``, ``element_set``,
        ``set_names``, ``label``, ``node_label``, ``point_data``, ``cell_data``
        or ``file_content``.
    name : str
        The element type, set, label or array.
    count : int
        How many elements, nodes or values it covers.
    reason : str
        Why the target format cannot hold it.
    """

    kind: str
    name: str
    count: int
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """``{"kind", "name", "count", "reason"}``."""
        return {"kind": self.kind, "name": self.name, "count": self.count, "reason": self.reason}

    def __str__(self) -> str:
        return f"{self.kind.replace('_', ' ')} {self.name!r} ({self.count}): {self.reason}"


@dataclass
class Conversion:
    """A mesh ready for a target format's writer.

    Attributes
    ----------
    fmt : str
        meshio format name.
    mesh : meshio.Mesh
        What the writer writes.
    losses : list of Loss
        What the format cannot hold (not in ``mesh``).
    renamed : dict of str to str
        Set names changed to fit the format (old -> new).
    options : dict
        Writer options (TetGen ``node_marker``/``region``, Nastran ``pid``).
    """

    fmt: str
    mesh: meshio.Mesh
    losses: list[Loss] = field(default_factory=list)
    renamed: dict[str, str] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)


def abaqus_name(name: str, taken: set[str]) -> str:
    """A legal Abaqus set name for ``name`` (letters, digits, underscores; a letter first), unique in ``taken``.

    Examples
    --------
    >>> abaqus_name("medit:ref=2", set()), abaqus_name("FIXED", set()), abaqus_name("1st", set())
    ('medit_ref_2', 'FIXED', 'S_1st')
    """
    out = re.sub(r"[^A-Za-z0-9_]", "_", name)[:70] or "SET"
    if not out[0].isalpha():
        out = "S_" + out
    base, k = out, 2
    while out.upper() in {t.upper() for t in taken}:
        out = f"{base}_{k}"
        k += 1
    taken.add(out)
    return out


def _restrict(c: Content, allowed: set[str], fmt: str, what: str, losses: list[Loss],
              corners: bool = False) -> Content:
    """``c`` without the blocks of types outside ``allowed``, listed as losses.

    With ``corners`` tetra10 become tetra (the mid-side connectivity listed as lost).
    """
    keep, blocks = [], []
    for b, (t, data) in enumerate(c.blocks):
        if t == "tetra10" and corners and "tetra" in allowed:
            losses.append(Loss("quadratic_nodes", "tetra10", len(data),
                               f"{what} holds linear tetrahedra only; the corners are kept, the mid-side nodes "
                               "stay as unreferenced points"))
            keep.append(b)
            blocks.append(("tetra", data[:, :4]))
        elif t in allowed:
            keep.append(b)
            blocks.append((t, data))
        else:
            losses.append(Loss("element_type", t, len(data), f"{what} has no {t} elements"))
    if len(keep) == len(c.blocks):
        c.blocks = blocks
        return c
    out = Content(blocks=blocks, node_sets=c.node_sets, node_labels=c.node_labels, point_data=c.point_data)
    for name, per in c.element_sets.items():
        kept = [per[b] for b in keep]
        if any(x.size for x in kept):
            out.element_sets[name] = kept
        else:
            losses.append(Loss("element_set", name, int(sum(x.size for x in per)),
                               f"all its elements are of types {what} does not hold"))
    out.labels = {k: [v[b] for b in keep] for k, v in c.labels.items()}
    out.cell_data = {k: [v[b] for b in keep] for k, v in c.cell_data.items()}
    return out


def _merged(c: Content) -> Content:
    """``c`` with the blocks of each cell type joined, in order of first appearance.

    Gmsh readers join them, so data written per block would not line up.
    """
    types = list(dict.fromkeys(t for t, _ in c.blocks))
    if len(types) == len(c.blocks):
        return c
    groups = [[b for b, (t, _) in enumerate(c.blocks) if t == kind] for kind in types]
    offsets = {}
    for g in groups:
        k = 0
        for b in g:
            offsets[b] = k
            k += len(c.blocks[b][1])

    def join(per: list[np.ndarray], shift: bool) -> list[np.ndarray]:
        return [np.concatenate([np.asarray(per[b]) + (offsets[b] if shift else 0) for b in g]) for g in groups]

    out = Content(blocks=[(c.blocks[g[0]][0], np.concatenate([c.blocks[b][1] for b in g])) for g in groups],
                  node_sets=c.node_sets, node_labels=c.node_labels, point_data=c.point_data)
    out.element_sets = {k: join(v, True) for k, v in c.element_sets.items()}
    out.labels = {k: join(v, False) for k, v in c.labels.items()}
    out.cell_data = {k: join(v, False) for k, v in c.cell_data.items()}
    return out


def _label_classes(per: list[np.ndarray]) -> list[int]:
    vals = [unique(v) for v in per if v.size]
    return unique(np.concatenate(vals)).astype(int).tolist() if vals else []


def _data_losses(c: Content, what: str, losses: list[Loss], labels: bool = True) -> None:
    for k, a in c.point_data.items():
        losses.append(Loss("point_data", k, int(len(a)), f"{what} holds no point data arrays"))
    for k, per in c.cell_data.items():
        losses.append(Loss("cell_data", k, int(sum(len(a) for a in per)), f"{what} holds no cell data arrays"))
    if labels:
        for k, per in c.labels.items():
            losses.append(Loss("label", k, int(sum(len(a) for a in per)), f"{what} holds one element label"))
        for k, a in c.node_labels.items():
            losses.append(Loss("node_label", k, int(len(a)), f"{what} holds one node label"))


def _set_losses(c: Content, what: str, losses: list[Loss], node: bool = True, element: bool = True) -> None:
    if node:
        for k, ids in c.node_sets.items():
            losses.append(Loss("node_set", k, int(len(ids)), f"{what} has no named node sets"))
    if element:
        for k, per in c.element_sets.items():
            losses.append(Loss("element_set", k, int(sum(len(x) for x in per)), f"{what} has no named element sets"))


def convert(c: Content, P: np.ndarray, fmt: str) -> Conversion:
    """Put the content ``c`` with points ``P`` where format ``fmt`` holds it.

    Parameters
    ----------
    c : Content
    P : (n, 3) float array
    fmt : str
        meshio format name (:func:`solver.io.formats.format_of`).

    Returns
    -------
    Conversion
    """
    enc = _ENCODERS.get(fmt, _generic)
    return enc(c, np.asarray(P, dtype=np.float64), fmt)


def _faces_as_node_sets(c: Content) -> Content:
    """A volume mesh's surface and line cells as node sets, for a deck a solver reads.

    Gmsh keeps the faces of a named surface (a physical group) as triangle
    cells; written to a deck they would be CPS3 / CPE6 / T3D2 elements, which a
    solver takes for plane-stress, plane-strain or truss elements of the model
    and refuses or solves wrongly. So, where the mesh has volume elements,
    every set and label class with members among those cells becomes a node set
    of their nodes, under its own name, and the cells are left out. A mesh of
    surface cells alone keeps them.
    """
    vol = [b for b, (t, _) in enumerate(c.blocks) if t in VOLUME]
    low = [b for b, (t, _) in enumerate(c.blocks) if t not in VOLUME]
    if not vol or not low:
        return c

    def nodes(per: list[np.ndarray]) -> np.ndarray:
        parts = [c.blocks[b][1][per[b]].ravel() for b in low if per[b].size]
        return unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)

    out = Content(blocks=[c.blocks[b] for b in vol], node_sets=dict(c.node_sets), node_labels=c.node_labels,
                  point_data=c.point_data)
    for name, per in c.element_sets.items():
        if any(per[b].size for b in low):
            out.node_sets[name] = unique(np.concatenate([out.node_sets.get(name, np.zeros(0, np.int64)),
                                                         nodes(per)]))
        if any(per[b].size for b in vol):
            out.element_sets[name] = [per[b] for b in vol]
    for key, per in c.labels.items():
        for v in _label_classes([per[b] for b in low]):
            out.node_sets[f"{key}={v}"] = nodes([np.flatnonzero(x == v) for x in per])
        out.labels[key] = [per[b] for b in vol]
    out.cell_data = {k: [v[b] for b in vol] for k, v in c.cell_data.items()}
    return out


def _abaqus(c: Content, P: np.ndarray, fmt: str) -> Conversion:
    losses: list[Loss] = []
    c = _restrict(_faces_as_node_sets(c), set(ABAQUS_TYPES), fmt, "an Abaqus deck", losses)
    taken: set[str] = set()
    renamed: dict[str, str] = {}

    def name(n: str, pool: set[str]) -> str:
        new = abaqus_name(n, pool)
        if new != n:
            renamed[n] = new
        return new

    nsets: dict[str, np.ndarray] = {}
    elsets: dict[str, list[np.ndarray]] = {}
    node_names: set[str] = set()
    for k, ids in c.node_sets.items():
        nsets[name(k, node_names)] = ids
    for k, a in c.node_labels.items():
        for v in unique(a):
            nsets[name(f"{k}={v}", node_names)] = np.flatnonzero(a == v)
    for k, per in c.element_sets.items():
        elsets[name(k, taken)] = per
    for k, per in c.labels.items():
        for v in _label_classes(per):
            elsets[name(f"{k}={v}", taken)] = [np.flatnonzero(x == v) for x in per]
    _data_losses(c, "an Abaqus deck", losses, labels=False)
    m = meshio.Mesh(P, [(t, b) for t, b in c.blocks], point_sets=nsets, cell_sets=elsets)
    return Conversion(fmt, m, losses, renamed)


def _gmsh(c: Content, P: np.ndarray, fmt: str) -> Conversion:
    from meshio.gmsh.common import _meshio_to_gmsh_type

    losses: list[Loss] = []
    c = _merged(_restrict(c, set(_meshio_to_gmsh_type), fmt, "a Gmsh file", losses))
    dims = [3 if t in VOLUME else 2 if t in ("triangle", "triangle6", "quad", "quad8", "quad9") else 1
            for t, _ in c.blocks]
    phys = [np.zeros(len(b), np.int64) for _, b in c.blocks]
    field_data: dict[str, np.ndarray] = {}
    cell_data: dict[str, list[np.ndarray]] = {}
    renamed: dict[str, str] = {}
    groups = [(k, per, False) for k, per in c.element_sets.items()]
    if c.labels:  # the classes of the first label of volume elements, where no set took their elements
        key = next(iter(c.labels))
        vol = [x if dims[b] == 3 else np.full(len(x), -1) for b, x in enumerate(c.labels[key])]
        groups += [(f"{key}={v}", [np.flatnonzero(x == v) for x in vol], True) for v in _label_classes(vol)
                   if v != -1]
    tag = 0
    for name, per, is_label in groups:
        holding = [b for b, x in enumerate(per) if x.size]
        one_dim = len({dims[b] for b in holding}) == 1
        free = all(not phys[b][per[b]].any() for b in holding)
        if one_dim and free and name not in field_data:
            tag += 1
            for b in holding:
                phys[b][per[b]] = tag
            field_data[name] = np.array([tag, dims[holding[0]]])
        elif not is_label:  # an element in two groups: a 0/1 element data array holds the set
            cell_data[f"set:{name}"] = [np.isin(np.arange(len(bl)), x).astype(np.float64)
                                        for (_, bl), x in zip(c.blocks, per, strict=True)]
    for k, per in c.labels.items():
        cell_data[k] = [x.astype(np.float64) for x in per]
    for k, per in c.cell_data.items():
        cell_data[k] = [np.asarray(x, np.float64) for x in per]
    blocks = [(t, b) for t, b in c.blocks]
    vert_rows, vert_tags = [], []
    for name, ids in c.node_sets.items():
        implied = [(t, bl, x) for (t, bl), x in zip(c.blocks, c.element_sets.get(name, []), strict=False)]
        nodes_of_elements = (unique(np.concatenate([bl[x].ravel() for _, bl, x in implied]))
                             if implied else np.zeros(0, np.int64))
        if name in c.element_sets and np.array_equal(unique(ids), nodes_of_elements):
            continue  # the element group's nodes are the node set already
        label = name if name not in field_data else f"{name}:nodes"
        if label != name:
            renamed[name] = label
        tag += 1
        field_data[label] = np.array([tag, 0])
        vert_rows.append(np.asarray(ids, np.int64))
        vert_tags.append(np.full(len(ids), tag))
    if vert_rows:
        blocks.append(("vertex", np.concatenate(vert_rows)[:, None]))
        phys.append(np.concatenate(vert_tags))
        for k in cell_data:
            cell_data[k].append(np.zeros(len(blocks[-1][1])))
    point_data = {k: np.asarray(v, np.float64) for k, v in {**c.point_data, **c.node_labels}.items()}
    # Gmsh puts physical groups on elementary entities: one entity per group (its tag), and one per
    # block for the elements in no group
    geo = [np.where(p > 0, p, tag + 1 + i) for i, p in enumerate(phys)]
    cd = {"gmsh:physical": phys, "gmsh:geometrical": geo, **cell_data}
    m = meshio.Mesh(P, blocks, point_data=point_data, cell_data=cd, field_data=field_data)
    return Conversion(fmt, m, losses, renamed)


def _vtk(c: Content, P: np.ndarray, fmt: str) -> Conversion:
    losses: list[Loss] = []
    point_data: dict[str, np.ndarray] = {k: np.asarray(v) for k, v in c.point_data.items()}
    point_data.update(c.node_labels)
    cell_data: dict[str, list[np.ndarray]] = {k: list(v) for k, v in c.cell_data.items()}
    cell_data.update({k: list(v) for k, v in c.labels.items()})
    for k, ids in c.node_sets.items():
        mask = np.zeros(len(P), np.uint8)
        mask[ids] = 1
        point_data[f"set:{k}"] = mask
    for k, per in c.element_sets.items():
        cell_data[f"set:{k}"] = [np.isin(np.arange(len(bl)), x).astype(np.uint8)
                                 for (_, bl), x in zip(c.blocks, per, strict=True)]
    m = meshio.Mesh(P, [(t, b) for t, b in c.blocks], point_data=point_data, cell_data=cell_data)
    return Conversion(fmt, m, losses)


def _disjoint(sets: list[np.ndarray]) -> bool:
    allv = np.concatenate(sets) if sets else np.zeros(0)
    return unique(allv).size == allv.size


def _refs(c: Content, P: np.ndarray, what: str, losses: list[Loss], prefer: str,
          renamed: dict[str, str]) -> tuple[np.ndarray | None, list[np.ndarray] | None]:
    """One node label and one element label for a format that holds one of each, without names."""
    node_ref = None
    if c.node_labels:
        key = prefer if prefer in c.node_labels else next(iter(c.node_labels))
        node_ref = c.node_labels.pop(key)
    elif c.node_sets and _disjoint(list(c.node_sets.values())):
        node_ref = np.zeros(len(P), np.int64)
        for i, (k, ids) in enumerate(c.node_sets.items()):
            node_ref[ids] = i + 1
            losses.append(Loss("set_names", k, int(len(ids)), f"{what} keeps node set {k!r} as node reference "
                               f"{i + 1} but has no set names"))
        c.node_sets = {}
    cell_ref = None
    if c.labels:
        key = prefer if prefer in c.labels else next(iter(c.labels))
        cell_ref = c.labels.pop(key)
        if key != prefer:
            renamed.update({f"{key}={v}": f"{prefer}={v}" for v in _label_classes(cell_ref)})
    elif c.element_sets and all(_disjoint([per[b] for per in c.element_sets.values()])
                                for b in range(len(c.blocks))):
        cell_ref = [np.zeros(len(bl), np.int64) for _, bl in c.blocks]
        for i, (k, per) in enumerate(c.element_sets.items()):
            for b, x in enumerate(per):
                cell_ref[b][x] = i + 1
            losses.append(Loss("set_names", k, int(sum(len(x) for x in per)), f"{what} keeps element set {k!r} "
                               f"as element reference {i + 1} but has no set names"))
        c.element_sets = {}
    return node_ref, cell_ref


def _medit(c: Content, P: np.ndarray, fmt: str) -> Conversion:
    losses: list[Loss] = []
    renamed: dict[str, str] = {}
    c = _restrict(c, MEDIT_TYPES, fmt, "a Medit file", losses, corners=True)
    node_ref, cell_ref = _refs(c, P, "a Medit file", losses, "medit:ref", renamed)
    _set_losses(c, "a Medit file", losses)
    _data_losses(c, "a Medit file", losses)
    pd = {"medit:ref": node_ref if node_ref is not None else np.zeros(len(P), np.int64)}
    cd = {"medit:ref": cell_ref if cell_ref is not None else [np.zeros(len(b), np.int64) for _, b in c.blocks]}
    m = meshio.Mesh(P, [(t, b) for t, b in c.blocks], point_data=pd, cell_data=cd)
    return Conversion(fmt, m, losses, renamed)


def _tetgen(c: Content, P: np.ndarray, fmt: str) -> Conversion:
    losses: list[Loss] = []
    renamed: dict[str, str] = {}
    c = _restrict(c, {"tetra"}, fmt, "a TetGen .ele file", losses, corners=True)
    node_ref, cell_ref = _refs(c, P, "a TetGen mesh", losses, "tetgen:ref", renamed)
    _set_losses(c, "a TetGen mesh", losses)
    _data_losses(c, "a TetGen mesh", losses)
    m = meshio.Mesh(P, [(t, b) for t, b in c.blocks])
    region = np.concatenate(cell_ref) if cell_ref is not None and cell_ref else None
    return Conversion(fmt, m, losses, renamed, {"node_marker": node_ref, "region": region})


def _nastran(c: Content, P: np.ndarray, fmt: str) -> Conversion:
    losses: list[Loss] = []
    renamed: dict[str, str] = {}
    c = _restrict(c, set(NASTRAN_TYPES), fmt, "a Nastran deck", losses)
    pid = None
    keys = sorted(c.labels, key=lambda k: k != "nastran:ref")
    for k in keys:
        if all((x >= 1).all() for x in c.labels[k]):
            pid = c.labels.pop(k)
            if k != "nastran:ref":
                renamed.update({f"{k}={v}": f"nastran:ref={v}" for v in _label_classes(pid)})
            break
    for k, per in c.labels.items():
        losses.append(Loss("label", k, int(sum(len(x) for x in per)), "a Nastran deck holds one element label "
                           "(the property id), and property ids are positive"))
    c.labels = {}
    _set_losses(c, "a Nastran bulk data deck", losses)
    _data_losses(c, "a Nastran deck", losses)
    m = meshio.Mesh(P, [(t, b) for t, b in c.blocks])
    return Conversion(fmt, m, losses, renamed, {"pid": pid})


def _surface(c: Content, P: np.ndarray, fmt: str) -> Conversion:
    losses: list[Loss] = []
    what = {"stl": "an STL file", "obj": "an OBJ file", "off": "an OFF file", "ply": "a PLY file"}[fmt]
    c = _restrict(c, SURFACE_TYPES[fmt], fmt, what + " (a surface)", losses)
    c.cell_data = dict(c.cell_data)
    if fmt == "stl":  # the writer computes every facet's normal from the new positions: nothing is lost
        c.cell_data.pop("facet_normals", None)
    kept: dict[str, list[np.ndarray]] = {}
    groups = c.cell_data.pop("obj:group_ids", None)
    if groups is not None and len(_label_classes([np.asarray(g).ravel() for g in groups])) > 1:
        if fmt == "obj":  # an OBJ holds its face groups (solver/io/obj.py writes them)
            kept["obj:group_ids"] = [np.asarray(g).ravel() for g in groups]
        else:
            c.cell_data["obj:group_ids"] = groups
    # one group everywhere (an OBJ without g lines) labels nothing: nothing to keep
    _set_losses(c, what, losses)
    _data_losses(c, what, losses)
    return Conversion(fmt, meshio.Mesh(P, [(t, b) for t, b in c.blocks], cell_data=kept or None), losses)


def _generic(c: Content, P: np.ndarray, fmt: str) -> Conversion:
    losses: list[Loss] = []
    _set_losses(c, f"tetmorph's writing of {fmt}", losses)
    cell_data = {**{k: list(v) for k, v in c.cell_data.items()}, **{k: list(v) for k, v in c.labels.items()}}
    m = meshio.Mesh(P, [(t, b) for t, b in c.blocks], point_data={**c.point_data, **c.node_labels},
                    cell_data=cell_data)
    return Conversion(fmt, m, losses)


_ENCODERS = {"abaqus": _abaqus, "gmsh": _gmsh, "gmsh22": _gmsh, "vtu": _vtk, "vtk": _vtk, "medit": _medit,
             "tetgen": _tetgen, "nastran": _nastran, "stl": _surface, "obj": _surface, "off": _surface,
             "ply": _surface}
