"""TetGen ``.node`` + ``.ele`` files: reading with the file's own numbering, and writing.

meshio's TetGen reader loops forever on a file that holds only comments, and
its writer numbers nodes from 0. TetGen numbers from 1 unless run with ``-z``;
:func:`read_tetgen` accepts either base (and any unique node numbers), names the
line of every defect, and keeps the base so that :func:`write_tetgen` and the
``.node`` patcher (:mod:`solver.io.patch_node`) write what the file had.

Format (https://wias-berlin.de/software/tetgen/fformats.html): ``.node`` starts
with ``<points> 3 <attributes> <boundary markers 0|1>``, then one line per point
``<id> <x> <y> <z> [attributes] [marker]``; ``.ele`` starts with ``<tets> <4|10>
<attributes>``, then ``<id> <n1> .. <n4> [attributes]``. ``#`` starts a comment.
"""

from __future__ import annotations

import os

import meshio
import numpy as np

from ..errors import UnreadableFileError, UnsupportedElementError

__all__ = ["read_tetgen", "write_tetgen", "tetgen_paths", "data_lines"]


def tetgen_paths(path: str | os.PathLike[str]) -> tuple[str, str]:
    """The ``.node`` and ``.ele`` paths of a TetGen mesh named by either.

    Examples
    --------
    >>> tetgen_paths("out/beam.ele")
    ('out/beam.node', 'out/beam.ele')
    """
    p = os.fspath(path)
    stem = p[:-5] if p.lower().endswith(".node") else p[:-4] if p.lower().endswith(".ele") else p
    return stem + ".node", stem + ".ele"


def data_lines(data: bytes) -> list[tuple[int, list[bytes]]]:
    r"""``(line index, tokens)`` of every line that holds data (comments and blanks dropped).

    Examples
    --------
    >>> data_lines(b"# c\n2 3 0 0\n\n1 0 0 0  # first\n")
    [(1, [b'2', b'3', b'0', b'0']), (3, [b'1', b'0', b'0', b'0'])]
    """
    out = []
    for k, line in enumerate(data.splitlines()):
        tokens = line.split(b"#", 1)[0].split()
        if tokens:
            out.append((k, tokens))
    return out


def _header(rows: list[tuple[int, list[bytes]]], name: str, what: str, width: int) -> list[int]:
    if not rows:
        raise UnreadableFileError(f"{name!r} holds no {what} header (only comments or blank lines)",
                                  code="no_nodes" if what == "node" else "no_elements", file=name)
    k, tokens = rows[0]
    try:
        head = [int(t) for t in tokens[:width]]
    except ValueError:
        raise UnreadableFileError(f"{name!r} line {k + 1}: the {what} header must be {width} integers, "
                                  f"got {b' '.join(tokens).decode(errors='replace')!r}",
                                  code="unreadable_file", file=name, line=k + 1) from None
    if len(head) < width:
        head += [0] * (width - len(head))
    return head


def _table(rows: list[tuple[int, list[bytes]]], count: int, ncols: int, name: str, what: str,
           dtype: type) -> tuple[np.ndarray, np.ndarray]:
    """``count`` data rows of ``ncols`` numbers after the header, and their line numbers."""
    body = rows[1:1 + count]
    if len(body) < count:
        last = rows[-1][0] + 1 if rows else 0
        raise UnreadableFileError(
            f"{name!r} announces {count} {what}s but holds {len(body)} (the last data is on line "
            f"{last}): the file looks truncated", code="truncated_file", file=name,
            expected=count, found=len(body))
    out: np.ndarray = np.empty((count, ncols), dtype=dtype)
    lines = np.empty(count, np.int64)
    for i, (k, tokens) in enumerate(body):
        if len(tokens) < ncols:
            raise UnreadableFileError(
                f"{name!r} line {k + 1}: a {what} line needs {ncols} numbers, got {len(tokens)}"
                + (" (the file looks truncated)" if i == count - 1 else ""),
                code="truncated_file" if i == count - 1 else "unreadable_file", file=name, line=k + 1)
        try:
            out[i] = [dtype(t) for t in tokens[:ncols]]
        except ValueError:
            raise UnreadableFileError(
                f"{name!r} line {k + 1}: {what} line {b' '.join(tokens).decode(errors='replace')!r} "
                "is not numeric", code="unreadable_file", file=name, line=k + 1) from None
        lines[i] = k + 1
    return out, lines


def read_tetgen(path: str | os.PathLike[str]) -> meshio.Mesh:
    """Read a TetGen mesh (``.node`` with its ``.ele``) into a :class:`meshio.Mesh`.

    Parameters
    ----------
    path : str or path
        The ``.node`` or the ``.ele`` file.

    Returns
    -------
    meshio.Mesh
        Points in file order, one ``tetra`` block; node attributes as point data
        ``tetgen:attr1``.., the boundary marker as ``tetgen:ref``, element
        attributes as cell data ``tetgen:ref``, ``tetgen:ref2``.. (meshio's names).
        ``info["tetgen:base"]`` holds the first node number (0 or 1).

    Raises
    ------
    UnreadableFileError
        A missing ``.ele``, a truncated table, non-numeric data, duplicate node
        numbers or an element that names an undefined node (the element, the
        node and the line).
    UnsupportedElementError
        Ten-node elements (TetGen ``-o2``).
    """
    node_path, ele_path = tetgen_paths(path)
    nname, ename = os.path.basename(node_path), os.path.basename(ele_path)
    for p in (node_path, ele_path):
        if not os.path.isfile(p):
            raise UnreadableFileError(f"a TetGen mesh needs {os.path.basename(p)!r} next to "
                                      f"{os.path.basename(os.fspath(path))!r}", code="missing_companion",
                                      missing=os.path.basename(p))
    with open(node_path, "rb") as fh:
        nodes = data_lines(fh.read())
    npts, dim, nattr, nmark = _header(nodes, nname, "node", 4)
    if dim != 3:
        raise UnreadableFileError(f"{nname!r}: points of dimension {dim}; tetmorph reads 3D meshes",
                                  code="unreadable_file", dimension=dim)
    if npts == 0:
        raise UnreadableFileError(f"{nname!r} defines no nodes (its header says 0 points; TetGen then "
                                  "expects them in a .poly file, which tetmorph does not read)",
                                  code="no_nodes", file=nname)
    table, _ = _table(nodes, npts, 4 + nattr + min(nmark, 1), nname, "node", float)
    ids = table[:, 0].astype(np.int64)
    if not np.array_equal(ids, table[:, 0]):
        raise UnreadableFileError(f"{nname!r}: node numbers must be integers", code="unreadable_file")
    uniq, first = np.unique(ids, return_index=True)
    if uniq.size != ids.size:
        dup = np.setdiff1d(np.arange(ids.size), first)[0]
        raise UnreadableFileError(f"{nname!r}: node number {ids[dup]} is defined twice",
                                  code="duplicate_node_number", node=int(ids[dup]))
    with open(ele_path, "rb") as fh:
        eles = data_lines(fh.read())
    ntet, per, eattr = _header(eles, ename, "element", 3)
    if per == 10:
        raise UnsupportedElementError(
            f"{ename!r} holds 10-node tetrahedra (TetGen -o2); tetmorph reads quadratic tets from "
            "Abaqus, Gmsh, VTK, Nastran and Medit files, not from TetGen", types={"tetra10": ntet})
    if per != 4:
        raise UnreadableFileError(f"{ename!r}: {per} nodes per tetrahedron; TetGen writes 4 or 10",
                                  code="unreadable_file", nodes_per_element=per)
    if ntet == 0:
        raise UnreadableFileError(f"{ename!r} defines no tetrahedra", code="no_elements", file=ename)
    cells, lines = _table(eles, ntet, 5 + eattr, ename, "element", int)
    order = np.argsort(ids)
    pos = np.searchsorted(ids, cells[:, 1:5], sorter=order)
    pos = np.minimum(pos, ids.size - 1)
    idx = order[pos]
    bad = ids[idx] != cells[:, 1:5]
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise UnreadableFileError(
            f"{ename!r} line {lines[r]}: element {cells[r, 0]} refers to node {cells[r, 1 + c]}, which "
            f"{nname!r} does not define (its nodes are numbered {ids.min()}..{ids.max()}); "
            f"{int(bad.any(1).sum())} elements refer to undefined nodes",
            code="undefined_node", element=int(cells[r, 0]), node=int(cells[r, 1 + c]), line=int(lines[r]),
            count=int(bad.any(1).sum()))
    point_data = {f"tetgen:attr{k + 1}": table[:, 4 + k] for k in range(nattr)}
    if nmark:
        point_data["tetgen:ref"] = table[:, 4 + nattr].astype(np.int64)
    cell_data = {"tetgen:ref" + ("" if k == 0 else str(k + 1)): [cells[:, 5 + k]] for k in range(eattr)}
    m = meshio.Mesh(table[:, 1:4], [("tetra", idx)], point_data=point_data, cell_data=cell_data)
    m.info = {"tetgen:base": int(ids.min())}
    return m


def write_tetgen(path: str | os.PathLike[str], m: meshio.Mesh, base: int = 1,
                 node_marker: np.ndarray | None = None, region: np.ndarray | None = None) -> None:
    """Write the ``tetra`` cells of ``m`` as ``.node`` + ``.ele`` (17 significant digits).

    Parameters
    ----------
    path : str or path
        The ``.node`` or ``.ele`` name; both files are written.
    m : meshio.Mesh
        Only its points and ``tetra`` blocks are written.
    base : int
        Number of the first node and element (TetGen's default is 1; 0 as with ``-z``).
    node_marker : (n,) int array, optional
        A boundary marker per node.
    region : (m,) int array, optional
        A region attribute per tetrahedron, in block order.
    """
    node_path, ele_path = tetgen_paths(path)
    P = np.asarray(m.points, dtype=np.float64)
    T = np.concatenate([np.asarray(c.data, np.int64) for c in m.cells if c.type == "tetra"] or
                       [np.zeros((0, 4), np.int64)])
    with open(node_path, "w", encoding="ascii") as fh:
        fh.write(f"{len(P)} 3 0 {1 if node_marker is not None else 0}\n")
        for k, x in enumerate(P):
            tail = f" {int(node_marker[k])}" if node_marker is not None else ""
            fh.write(f"{k + base} {x[0]:.17g} {x[1]:.17g} {x[2]:.17g}{tail}\n")
    with open(ele_path, "w", encoding="ascii") as fh:
        fh.write(f"{len(T)} 4 {1 if region is not None else 0}\n")
        for k, t in enumerate(T + base):
            tail = f" {int(region[k])}" if region is not None else ""
            fh.write(f"{k + base} {t[0]} {t[1]} {t[2]} {t[3]}{tail}\n")
