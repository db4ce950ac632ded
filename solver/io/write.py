"""Writing meshes: the original file patched in place where its format allows.

To other formats, everything the target can hold goes through, and a typed
refusal lists what it cannot.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from typing import Any

import meshio
import numpy as np

from ..errors import MAX_IDS, InvalidMeshError, LossyWriteError
from ..mesh import Mesh
from .content import content
from .conversion import CELL_DATA_FORMATS, Conversion, Loss, abaqus_name, convert
from .formats import a_format, describe, format_of
from .nastran_coords import grid_rounding
from .patch_bdf import patch_bdf
from .patchers import patcher_for

__all__ = ["write_mesh", "tet_cell_data", "Written"]


@dataclass
class Written:
    """What :func:`write_mesh` wrote.

    Attributes
    ----------
    path : str
        The file written (TetGen: the ``.node``).
    format : str
        meshio format name.
    files : list of str
        Every file written (TetGen: ``.node`` and ``.ele``).
    patched : bool
        The mesh's own file was patched in place (only coordinates changed).
    dropped : list of dict
        What the target could not hold (:class:`~solver.io.conversion.Loss`
        as dicts), written anyway because ``lossy=True``.
    renamed : dict of str to str
        Set names changed to fit the format (old -> new).
    skipped : list of str
        Requested extras the format does not store (per-element quality in an
        Abaqus deck, ...).
    write_rounding : float or None
        Nastran decks: the largest difference, over every coordinate of every
        GRID card, between the value written and the position given (length
        units; 8-column small fields round to about seven digits). None for
        the other formats.
    """

    path: str
    format: str
    files: list[str]
    patched: bool
    dropped: list[dict[str, Any]] = field(default_factory=list)
    renamed: dict[str, str] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)
    write_rounding: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """The record as a JSON-ready dict."""
        return {"path": self.path, "format": self.format, "files": self.files, "patched": self.patched,
                "dropped": self.dropped, "renamed": self.renamed, "skipped": self.skipped,
                "write_rounding": self.write_rounding}


def write_mesh(mesh: Mesh, V: np.ndarray, path: str | os.PathLike[str],
               file_format: str | None = None, point_data: dict[str, np.ndarray] | None = None,
               cell_data: dict[str, list[np.ndarray]] | None = None,
               point_sets: dict[str, np.ndarray] | None = None, quality: bool = False,
               lossy: bool = False, nastran_large: bool = False, flatten: bool = False) -> Written:
    """Write ``mesh`` with new coordinates ``V``, changing nothing else.

    Written in the format of the file the mesh was read from, the file is
    patched in place: every byte but the coordinates of the nodes that moved
    is kept (Abaqus ``.inp``, ASCII Gmsh ``.msh``, ``.vtu``, Nastran
    ``.bdf``/``.nas`` in its own field format, TetGen ``.node`` in its own
    numbering with the ``.ele`` copied). Written to another format, named node
    sets, element sets, physical groups and material regions go wherever the
    format holds them (:mod:`solver.io.conversion`); what it cannot hold is
    refused with :class:`~solver.errors.LossyWriteError`, unless ``lossy``.

    Parameters
    ----------
    mesh : Mesh
    V : (n, 3) float array
        New positions, in file order.
    path : str or path
    file_format : str, optional
        meshio format name or extension; defaults to the extension (``.msh``
        is Gmsh).
    point_data : dict of str to (n,) array, optional
        Extra point arrays.
    cell_data : dict of str to list of arrays, optional
        Extra cell arrays, one per cell block of the written mesh (the file's
        non-empty blocks, vertex cells left out).
    point_sets : dict of str to int array, optional
        Extra node sets (vertex ids), e.g. detected features; in a patched
        Abaqus deck they are inserted as ``*NSET`` before the first ``*STEP``.
    quality : bool
        Add the per-element metrics of :func:`solver.validity.quality.element_quality`
        at ``V`` as cell data (``quality:scaled_jacobian`` ...; NaN on
        non-volume cells) where the format stores cell data (VTU, VTK, Gmsh);
        listed in ``skipped`` elsewhere.
    lossy : bool
        Write even when the format cannot hold everything; the losses are
        listed in the result's ``dropped``.
    nastran_large : bool
        Patching a Nastran deck, write each moved node whose coordinates do
        not fit its 8-column small-field card exactly as a large-field
        ``GRID*`` card (16-column fields); other cards keep their text
        (:func:`~solver.io.patch_bdf.patch_bdf`). Listed in ``skipped`` for
        other formats. A deck written from another format is large field
        throughout.
    flatten : bool
        Writing an Abaqus/CAE assembly deck (``*Part``/``*Instance``) as an
        Abaqus deck: write one flat deck instead of patching the parts
        (:mod:`solver.io.abaqus_flat`): every instance's nodes and elements
        numbered apart, sets named ``Instance_Set``, includes spliced in. For
        instances of one part morphed apart, and for solvers that read no
        assemblies (CalculiX).

    Returns
    -------
    Written

    Raises
    ------
    LossyWriteError
        The target cannot hold everything and ``lossy`` is False; nothing is written.
    InvalidMeshError
        ``V`` has the wrong shape, the format is unknown, or writing failed;
        ``unwritable_folder`` when the target's folder (created when missing)
        cannot be created.
    """
    V = np.asarray(V, dtype=np.float64)
    if V.shape != mesh.V.shape:
        raise InvalidMeshError(f"positions have shape {V.shape}, mesh has {mesh.V.shape}",
                               code="bad_shape")
    if not np.isfinite(V[mesh.referenced]).all():
        bad = np.flatnonzero(~np.isfinite(V).all(1) & mesh.referenced)
        raise InvalidMeshError(f"{bad.size} positions are not finite (first vertices {bad[:10].tolist()})",
                               code="non_finite_coordinates", vertices=bad[:MAX_IDS].tolist())
    target = os.fspath(path)
    fmt = format_of(target, file_format)
    if fmt is None:
        raise InvalidMeshError(f"cannot tell the format to write {os.path.basename(target)!r} in from its "
                               "extension; pass a format name", code="unknown_format", path=target)
    skipped: list[str] = []
    holds_cells = fmt in CELL_DATA_FORMATS
    if quality and not holds_cells:
        skipped.append(f"quality: {describe(fmt)} holds no per-element data")
    if nastran_large and fmt != "nastran":
        skipped.append(f"nastran_large: {describe(fmt)} is not a Nastran deck")
    _make_folder(target)
    if flatten:
        flat = _flatten(mesh, V, target, fmt)
        if flat is not None:
            flat.skipped = skipped
            return flat
        skipped.append("flatten: the mesh was not read from an Abaqus deck, or is written to another format")
    losses: list[Loss] = []
    patched = _patch_in_place(mesh, V, target, fmt, point_sets, point_data, cell_data, quality and holds_cells,
                              losses, nastran_large)
    if patched is not None:
        patched.skipped = skipped
        return patched
    c = content(mesh, point_sets)
    probe = meshio.Mesh(V, [(t, b) for t, b in c.blocks])
    if quality and holds_cells and not mesh.is_surface:
        from ..validity.quality import element_quality

        q = element_quality(V, mesh.T, mesh.cells)
        c.cell_data.update({f"quality:{k}": tet_cell_data(mesh, v, probe) for k, v in q.items()})
    if point_data:
        c.point_data.update(point_data)
    if cell_data:
        for k, per in cell_data.items():
            if len(per) != len(c.blocks):
                raise InvalidMeshError(f"cell data {k!r} has {len(per)} blocks, the written mesh "
                                       f"{len(c.blocks)}", code="bad_shape")
            c.cell_data[k] = list(per)
    src = mesh.source
    P = V[:, : np.asarray(src.points).shape[1]] if src is not None else V
    P = np.c_[P, np.zeros((len(P), 3 - P.shape[1]))] if P.shape[1] < 3 else P
    conv = convert(c, P, fmt)
    losses += conv.losses
    if losses and not lossy:
        raise _lossy_error(target, fmt, losses)
    files = _write(conv, target)
    rounding = None
    if fmt == "nastran":
        with open(target, "rb") as fh:
            rounding = _rounding(fh.read(), np.asarray(conv.mesh.points, dtype=np.float64), target)
    return Written(target, fmt, files, False, [x.to_dict() for x in losses], conv.renamed, skipped, rounding)


def _lossy_error(target: str, fmt: str, losses: list[Loss]) -> LossyWriteError:
    shown = "; ".join(str(x) for x in losses[:12]) + (f"; ... ({len(losses)} in all)" if len(losses) > 12 else "")
    return LossyWriteError(
        f"writing {os.path.basename(target)!r} as {a_format(fmt)} would lose {shown}. Nothing was written. "
        "Write to a format that holds them (.inp, .msh and .vtu keep sets and regions), or pass lossy=True "
        "(CLI --lossy) to write without them.", format=fmt, path=target, losses=[x.to_dict() for x in losses])


def _patch_in_place(mesh: Mesh, V: np.ndarray, target: str, fmt: str, point_sets: dict[str, np.ndarray] | None,
                    point_data: dict[str, np.ndarray] | None, cell_data: dict[str, list[np.ndarray]] | None,
                    cell_extras: bool, losses: list[Loss], nastran_large: bool = False) -> Written | None:
    """Write the mesh's own file with new coordinates when ``target`` has its format.

    Returns None otherwise, after adding a ``file_content`` loss when the patch failed.
    """
    p = patcher_for(target, fmt)
    source_fmt = mesh.file_format or (format_of(mesh.path) if mesh.path else None)
    if p is None or mesh.raw is None or source_fmt != fmt:
        return None
    if p.name == "medit" and (mesh.path or "").endswith("b") != target.endswith("b"):
        return None  # Medit text (.mesh) and binary (.meshb): the other kind is written, not patched
    if point_data or cell_data or cell_extras or (point_sets and p.name != "abaqus"):
        return None  # extras the format holds: written through the conversion
    reason = None
    data: bytes | None = None
    tree: dict[str, bytes] | None = None
    included = {k: v for k, v in mesh.companions.items() if k not in p.companions}
    if not (included and p.patch_tree is not None) and not p.accepts(mesh.raw, mesh.n):
        reason = f"its node definitions no longer match the mesh's {mesh.n} points"
    else:
        try:
            if included and p.patch_tree is not None:
                tree = p.patch_tree(mesh.raw, included, V)
                data = None if tree is None else tree.pop("")
            else:
                data = patch_bdf(mesh.raw, V, large=True) if nastran_large and p.name == "nastran" else \
                    p.patch(mesh.raw, V)
        except ValueError as e:
            reason = str(e)
        if data is None and reason is None:
            reason = "the file's layout is one the in-place writer does not handle (binary, or parametric nodes)"
    if data is None:
        losses.append(Loss("file_content", os.path.basename(mesh.path or "the original file"), len(mesh.raw),
                           f"the original file cannot be patched in place ({reason}); a rewrite keeps the "
                           "mesh, its sets and regions, but not the rest of the file"))
        return None
    if point_sets:
        data = _insert_nsets(data, point_sets)
    main, companions = p.files(target)
    with open(main, "wb") as fh:
        fh.write(data)
    files = [main]
    for ext, cp in companions.items():
        with open(cp, "wb") as fh:
            fh.write(mesh.companions[ext])
        files.append(cp)
    for rel, body in (tree or {}).items():  # the included files, at the same place relative to the deck
        out = os.path.join(os.path.dirname(os.path.abspath(main)), rel)
        os.makedirs(os.path.dirname(out), exist_ok=True)
        with open(out, "wb") as fh:
            fh.write(body)
        files.append(out)
    rounding = _rounding(data, V, main) if p.name == "nastran" else None
    return Written(main, fmt, files, True, write_rounding=rounding)


def _make_folder(target: str) -> None:
    """Create the folder ``target`` is written in; a typed error naming it when that fails."""
    folder = os.path.dirname(os.path.abspath(target))
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as e:
        raise InvalidMeshError(f"cannot create the folder {folder!r} to write {os.path.basename(target)!r} in: "
                               f"{e.strerror or e}", code="unwritable_folder", folder=folder) from None


def _flatten(mesh: Mesh, V: np.ndarray, target: str, fmt: str) -> Written | None:
    """An Abaqus assembly deck written flat (:func:`solver.io.abaqus_flat.flatten`), or None."""
    if fmt != "abaqus" or mesh.raw is None or mesh.file_format != "abaqus":
        return None
    from .abaqus_flat import flatten

    included = dict(mesh.companions)
    try:
        data = flatten(mesh.raw, V, included)
    except ValueError as e:
        raise InvalidMeshError(f"cannot write {os.path.basename(target)!r} flat: {e}", code="unwritable_format",
                               format=fmt) from e
    with open(target, "wb") as fh:
        fh.write(data)
    return Written(target, fmt, [target], False)


def _rounding(deck: bytes, V: np.ndarray, path: str) -> float:
    """:func:`~solver.io.nastran_coords.grid_rounding` of a deck just written."""
    try:
        return grid_rounding(deck, V[:, :3] if V.shape[1] >= 3 else np.c_[V, np.zeros((len(V), 3 - V.shape[1]))])
    except ValueError as e:
        raise InvalidMeshError(f"cannot read back the GRID cards of {os.path.basename(path)!r}: {e}",
                               code="unwritable_format", format="nastran") from e


_STEP = re.compile(rb"^\s*\*\s*step\b", re.IGNORECASE | re.MULTILINE)


def _insert_nsets(deck: bytes, point_sets: dict[str, np.ndarray]) -> bytes:
    """Node sets added to an Abaqus deck's model data, before its first ``*STEP``."""
    taken: set[str] = set()
    text = "".join(f"*NSET, NSET={abaqus_name(k, taken)}\n"
                   + "".join(", ".join(str(int(i) + 1) for i in ids[j:j + 16]) + "\n"
                             for j in range(0, len(ids), 16))
                   for k, ids in ((k, np.asarray(v, np.int64)) for k, v in point_sets.items()))
    m = _STEP.search(deck)
    at = m.start() if m else len(deck)
    head = deck[:at]
    if head and not head.endswith(b"\n"):
        head += b"\n"
    return head + text.encode() + deck[at:]


def _write(conv: Conversion, target: str) -> list[str]:
    """Write a conversion with the format's writer; the files written."""
    fmt, m = conv.fmt, conv.mesh
    try:
        if fmt == "abaqus":
            from .abaqus import write_abaqus

            write_abaqus(target, m)
        elif fmt in ("gmsh", "gmsh22"):
            _write_gmsh22(target, m)
        elif fmt == "obj":
            from .obj import write_obj

            write_obj(target, m)
        elif fmt == "nastran":
            from .nastran import write_nastran

            write_nastran(target, m, conv.options.get("pid"))
        elif fmt == "tetgen":
            from .tetgen import tetgen_paths, write_tetgen

            write_tetgen(target, m, 1, conv.options.get("node_marker"), conv.options.get("region"))
            return list(tetgen_paths(target))
        else:
            import warnings

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                meshio.write(target, m, file_format=fmt)
    except (Exception, SystemExit) as e:
        raise InvalidMeshError(f"cannot write {os.path.basename(target)!r} as {a_format(fmt)}: "
                               f"{type(e).__name__}: {e}", code="unwritable_format", format=fmt) from e
    return [target]


def _write_gmsh22(target: str, m: meshio.Mesh) -> None:
    """Write ASCII Gmsh 2.2 through meshio, with the data sections written here.

    meshio's ASCII data writer prints numpy scalars as ``np.float64(1.0)`` under numpy 2.
    """
    tags = {k: v for k, v in m.cell_data.items() if k in ("gmsh:physical", "gmsh:geometrical")}
    bare = meshio.Mesh(m.points, m.cells, cell_data=tags, field_data=m.field_data)
    meshio.gmsh.write(target, bare, fmt_version="2.2", binary=False)
    with open(target, "a", encoding="ascii") as fh:
        for tag, arrays in (("NodeData", {k: np.asarray(v) for k, v in m.point_data.items()}),
                            ("ElementData", {k: np.concatenate([np.asarray(a) for a in v])
                                             for k, v in m.cell_data.items() if k not in tags})):
            for name, data in arrays.items():
                data = data.reshape(len(data), -1).astype(np.float64)
                fh.write(f'${tag}\n1\n"{name}"\n1\n0.0\n3\n0\n{data.shape[1]}\n{len(data)}\n')
                fh.write("".join(f"{k + 1} " + " ".join(repr(float(x)) for x in row) + "\n"
                                 for k, row in enumerate(data)))
                fh.write(f"$End{tag}\n")


def tet_cell_data(mesh: Mesh, values: np.ndarray, out: meshio.Mesh | None = None) -> list[np.ndarray]:
    """Per-element ``values`` spread over the cell blocks of the written mesh (NaN elsewhere).

    Elements are numbered as :attr:`Mesh.blocks`: the file's tetra blocks in
    order, then its hexahedron, wedge and pyramid blocks, each type in order.
    """
    blocks = out.cells if out is not None else (mesh.source.cells if mesh.source is not None else None)
    if blocks is None:
        return [np.asarray(values, float)]
    start, k = {}, 0
    for kind, b in mesh.blocks:
        start[kind] = k
        k += len(b)
    parts = []
    for c in blocks:
        nc = len(c.data)
        kind = "tetra" if c.type == "tetra10" and mesh.T10 is not None else c.type
        if kind in start:
            parts.append(np.asarray(values[start[kind]:start[kind] + nc], float))
            start[kind] += nc
        else:
            parts.append(np.full(nc, np.nan))
    return parts
