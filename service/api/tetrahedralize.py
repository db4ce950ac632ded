"""``/v1/tetrahedralize``: a closed surface in, a stored tet mesh out (fTetWild)."""

from __future__ import annotations

import os
import tempfile
from typing import Annotated, Any

import meshio
import numpy as np
from fastapi import APIRouter, File, Form, UploadFile

from solver.errors import InvalidMeshError
from solver.io.tetrahedralize import tetrahedralize as tetwild

from ..formats import SURFACE_FORMATS, resolve_format
from ..registry import Registry
from .deps import Owner, Reg, safe_name
from .meshes import public

router = APIRouter(tags=["meshes"])


def _read_surface(data: bytes, fmt: str, ext: str) -> tuple[np.ndarray, np.ndarray]:
    with tempfile.TemporaryDirectory(prefix="tetmorph-surface-") as tmp:
        path = os.path.join(tmp, "surface" + ext)
        with open(path, "wb") as f:
            f.write(data)
        try:
            m = meshio.read(path, file_format=fmt)
        except (Exception, SystemExit) as e:
            raise InvalidMeshError(f"cannot read the surface as {fmt}: {e}",
                                   code="unreadable_file") from e
    tris = [np.asarray(c.data) for c in m.cells if c.type == "triangle"]
    if not tris:
        raise InvalidMeshError(f"the {fmt} file has no triangles (cells: "
                               f"{sorted({c.type for c in m.cells})})", code="no_triangles")
    V = np.asarray(m.points, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise InvalidMeshError(f"surface points have shape {V.shape}; need (n, 3)", code="bad_shape")
    return V, np.concatenate(tris)


@router.post("/tetrahedralize", status_code=201,
             summary="Tetrahedralize a closed surface (STL / OBJ / PLY / OFF)")
async def tetrahedralize(
    file: Annotated[UploadFile, File(description="closed triangle surface")],
    format: Annotated[str | None, Form(description="stl, obj, ply or off; default from the "
                                                   "file name")] = None,
    edge_length: Annotated[float | None, Form(gt=0, description="absolute target edge length")
                           ] = None,
    edge_length_fac: Annotated[float, Form(gt=0, le=1, description="target edge length / "
                                           "bounding-box diagonal")] = 0.05,
    epsilon: Annotated[float, Form(gt=0, le=0.1, description="envelope / bounding-box diagonal")
                       ] = 1e-3,
    optimize: Annotated[bool, Form()] = True,
    allow_open: Annotated[bool, Form(description="accept border edges")] = False,
    name: Annotated[str | None, Form()] = None,
    owner: str = Owner, reg: Registry = Reg,
) -> dict[str, Any]:
    """Fill the surface with tetrahedra, orient them positively, store the mesh."""
    fname = safe_name(file.filename, "surface")
    fmt, ext = resolve_format(format, fname, allowed=SURFACE_FORMATS)
    data = await file.read()  # bounded by the BodyLimit middleware
    V, F = await reg.run(_read_surface, data, fmt, ext)
    mesh, info = await reg.run(lambda: tetwild(V, F, edge_length=edge_length,
                                               edge_length_fac=edge_length_fac, epsilon=epsilon,
                                               optimize=optimize, allow_open=allow_open))
    info.update({"edge_length": edge_length, "edge_length_fac": edge_length_fac,
                 "epsilon": epsilon, "source": fname})
    meta = await reg.add_mesh_arrays(owner, name or fname.rsplit(".", 1)[0] + ".tet", mesh,
                                     {"tetrahedralization": info})
    return public(meta)
