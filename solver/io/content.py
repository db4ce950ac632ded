"""What a mesh carries besides its coordinates, in one neutral form.

A file's named node sets, element sets, Gmsh physical groups, material
regions (integer labels of elements) and data arrays are spread over meshio's
``point_sets``, ``cell_sets``, ``cell_data`` and ``field_data`` in ways that
differ per format. :func:`content` gathers them so that
:mod:`solver.io.conversion` can put each where a target format holds it, or
list it as lost.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..mesh.mesh import Mesh
from ..ops.unique import union, unique
from .read import REGION_KEYS, SET_PREFIX, integral

__all__ = ["Content", "content", "BOOKKEEPING"]

#: meshio's Gmsh bookkeeping (entity tags): written back to Gmsh files only.
BOOKKEEPING = {"gmsh:geometrical", "gmsh:dim_tags", "gmsh:physical"}
#: Integer point data that label nodes (Medit vertex references, TetGen boundary markers).
NODE_LABEL_KEYS = ("medit:ref", "tetgen:ref")
VOLUME = {"tetra", "tetra10", "hexahedron", "wedge", "pyramid", "hexahedron20", "wedge15", "pyramid13"}


@dataclass
class Content:
    """A mesh's elements and everything attached to them, format-neutral.

    Attributes
    ----------
    blocks : list of (str, (k, c) int array)
        Cell blocks (meshio types and node order), empty blocks and vertex
        cells left out (sets of vertex cells are node sets).
    node_sets : dict of str to (j,) int array
        Named node sets.
    element_sets : dict of str to list of (j,) int arrays
        Named element sets: per block, indices into the block.
    labels : dict of str to list of (k,) int arrays
        Integer labels of elements per block (material regions, property
        ids: the cell data of :data:`solver.io.read.REGION_KEYS`).
    node_labels : dict of str to (n,) int array
        Integer labels of nodes with more than one value.
    point_data : dict of str to array
        Other point arrays.
    cell_data : dict of str to list of arrays
        Other cell arrays, per block.
    """

    blocks: list[tuple[str, np.ndarray]]
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)
    element_sets: dict[str, list[np.ndarray]] = field(default_factory=dict)
    labels: dict[str, list[np.ndarray]] = field(default_factory=dict)
    node_labels: dict[str, np.ndarray] = field(default_factory=dict)
    point_data: dict[str, np.ndarray] = field(default_factory=dict)
    cell_data: dict[str, list[np.ndarray]] = field(default_factory=dict)

    def element_count(self, kind: str | None = None) -> int:
        """Number of cells (of one type)."""
        return int(sum(len(b) for t, b in self.blocks if kind is None or t == kind))


def content(mesh: Mesh, point_sets: dict[str, np.ndarray] | None = None) -> Content:
    """Gather what ``mesh`` carries (see :class:`Content`).

    Parameters
    ----------
    mesh : Mesh
        Read from a file (its ``source``) or built from arrays (its ``sets``
        are then node sets).
    point_sets : dict, optional
        Extra node sets (e.g. detected features).

    Returns
    -------
    Content
    """
    m = mesh.source
    if m is None:
        blocks = [("triangle", mesh.surface)] if mesh.is_surface else [("tetra", mesh.T)]
        blocks += [(k, v) for k, v in mesh.cells.items()]
        out = Content(blocks=[(t, np.asarray(b, np.int64)) for t, b in blocks if len(b)])
        out.node_sets = {k: np.asarray(v, np.int64) for k, v in mesh.sets.items()}
        out.node_sets.update({k: np.asarray(v, np.int64) for k, v in (point_sets or {}).items()})
        return out
    keep = [b for b, c in enumerate(m.cells) if len(c.data) and c.type != "vertex"]
    vertex = [b for b, c in enumerate(m.cells) if len(c.data) and c.type == "vertex"]
    out = Content(blocks=[(m.cells[b].type, np.asarray(m.cells[b].data, np.int64)) for b in keep])
    nb = len(m.cells)

    def per_block(ix: list) -> list[np.ndarray]:
        return [np.asarray(ix[b] if b < len(ix) and ix[b] is not None else [], np.int64).ravel()
                for b in range(nb)]

    def add_set(name: str, full: list[np.ndarray]) -> None:
        on_vertices = [np.asarray(m.cells[b].data).ravel()[full[b]] for b in vertex if full[b].size]
        if on_vertices:
            nodes = unique(np.concatenate(on_vertices)).astype(np.int64)
            out.node_sets[name] = union(out.node_sets.get(name, np.zeros(0, np.int64)), nodes)
        if any(full[b].size for b in keep):
            out.element_sets[name] = [full[b] for b in keep]

    for name, ids in (m.point_sets or {}).items():
        out.node_sets[name] = unique(np.asarray(ids, np.int64))
    for name, ix in (m.cell_sets or {}).items():
        if not name.startswith("gmsh:"):
            add_set(name, per_block(ix))
    for key, v in m.point_data.items():
        a = np.asarray(v)
        if key.startswith(SET_PREFIX) and a.ndim == 1 and np.isin(a, (0, 1)).all():
            out.node_sets.setdefault(key[len(SET_PREFIX):], np.flatnonzero(a).astype(np.int64))
        elif key in NODE_LABEL_KEYS and a.ndim == 1 and integral(a):
            if unique(a).size > 1:  # one value everywhere labels nothing
                out.node_labels[key] = a.astype(np.int64)
        elif key not in BOOKKEEPING:
            out.point_data[key] = a
    phys = m.cell_data.get("gmsh:physical")
    if phys is not None:  # physical groups: meshio names them as cell sets; unnamed tags get "physical:k"
        names = {int(v[0]): k for k, v in (m.field_data or {}).items() if np.ndim(v) == 1 and len(v) >= 1}
        tags = unique(np.concatenate([np.asarray(t).ravel() for t in phys]))
        for tag in tags:
            if tag == 0 and 0 not in names:
                continue  # Gmsh's tag 0: in no physical group
            name = names.get(int(tag), f"physical:{int(tag)}")
            if name in out.element_sets or name in out.node_sets:
                continue
            add_set(name, [np.flatnonzero(np.asarray(t).ravel() == tag) for t in phys])
    for key, per in m.cell_data.items():
        if key in BOOKKEEPING:
            continue
        arrays = [np.asarray(a) for a in per]
        if key.startswith(SET_PREFIX) and all(np.isin(a, (0, 1)).all() for a in arrays):
            add_set(key[len(SET_PREFIX):], [np.flatnonzero(a.ravel() == 1) for a in arrays])
        elif key in REGION_KEYS and all(integral(a) for a in arrays):
            out.labels[key] = [arrays[b].ravel().astype(np.int64) for b in keep]
        else:
            out.cell_data[key] = [arrays[b] for b in keep]
    if point_sets:
        out.node_sets.update({k: np.asarray(v, np.int64) for k, v in point_sets.items()})
    return out
