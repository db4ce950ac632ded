"""Reads of uploaded files, run in the parse workers (:mod:`service.state.parse_pool`), never in the server.

Each function takes and returns plain data (bytes, paths, arrays, a
:class:`~solver.mesh.Mesh`), so that it can be called by name in a spawned
process; nothing of the web service is imported here.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from solver.errors import MAX_IDS, InvalidMeshError, SolverError, format_ids
from solver.io.bounds import ReadBounds
from solver.io.read import read_surface
from solver.limits import COORD_MAX
from solver.mesh import Mesh

from ..errors import ServiceError
from ..formats import scrubbed
from .store import read_mesh_files

__all__ = ["read_stored", "read_upload", "read_surface_upload", "UNUSED_POINTS"]

#: Unused nodes an upload may hold beyond ten times the used ones (a deck's reference points are a few).
UNUSED_POINTS = 100_000


def read_stored(root: str, meta: dict[str, Any], bounds: ReadBounds | None = None) -> Mesh:
    """A stored mesh's files read back (:func:`service.state.store.read_mesh_files`), server paths cut."""
    try:
        return read_mesh_files(Path(root), meta, bounds)
    except SolverError as e:
        raise scrubbed(e, root) from None


def read_upload(root: str, meta: dict[str, Any], bounds: ReadBounds | None = None) -> tuple[Mesh, dict[str, Any]]:
    """An uploaded mesh read, held to what a mesh to morph is, and summarised (:meth:`Mesh.info`), here.

    The summary is made in the worker, not in the server; a file whose nodes are mostly unused by
    its elements (millions of points around one tetrahedron, within every declared bound) is refused
    before it reaches the server.

    Raises
    ------
    ServiceError
        422 ``unused_points``.
    """
    mesh = read_stored(root, meta, bounds)
    used = int(np.count_nonzero(mesh.referenced))
    unused = mesh.n - used
    if unused > max(UNUSED_POINTS, 10 * used):
        raise ServiceError("unused_points", f"the file defines {mesh.n:,} nodes and its elements use {used:,}: "
                           f"{unused:,} nodes belong to no element. tetmorph morphs meshes; export the part's "
                           "mesh without the unused nodes", nodes=int(mesh.n), used=used)
    return mesh, mesh.info()


def read_surface_upload(data: bytes, fmt: str, ext: str, max_triangles: int, bounds: ReadBounds
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The surface's points and triangles, read with the same checks and bounds as an uploaded mesh."""
    with tempfile.TemporaryDirectory(prefix="tetmorph-surface-") as tmp:
        path = os.path.join(tmp, "surface" + ext)
        with open(path, "wb") as f:
            f.write(data)
        try:
            V, F = read_surface(path, fmt, bounds=bounds)
        except SolverError as e:
            raise scrubbed(e, tmp) from None
    if V.ndim != 2 or V.shape[1] != 3:
        raise InvalidMeshError(f"surface points have shape {V.shape}; need (n, 3)", code="bad_shape")
    if len(F) > max_triangles:
        raise ServiceError("too_many_triangles", f"the surface has {len(F)} triangles; this service "
                           f"tetrahedralizes at most {max_triangles}", triangles=int(len(F)), limit=max_triangles)
    if not np.isfinite(V).all():
        raise InvalidMeshError("surface has non-finite coordinates", code="non_finite")
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise InvalidMeshError(f"triangle indices span [{F.min()}, {F.max()}] but there are {len(V)} vertices",
                               code="index_out_of_range")
    used = np.unique(F)
    huge = used[(np.abs(V[used]) > COORD_MAX).any(1)]
    if huge.size:  # the bound of meshes and documents; fTetWild's envelope would overflow long before
        raise InvalidMeshError(f"{huge.size} surface vertices have a coordinate beyond +-{COORD_MAX:g}; first "
                               f"vertices {format_ids(huge)}, e.g. vertex {huge[0]} = {V[huge[0]].tolist()}",
                               code="coordinates_out_of_range", vertices=huge[:MAX_IDS].tolist(), bound=COORD_MAX)
    return V, F
