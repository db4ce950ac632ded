"""File formats the service reads and writes, by extension or meshio name.

Examples
--------
>>> resolve_format("inp")
('abaqus', '.inp')
>>> resolve_format(None, "part.msh")
('gmsh', '.msh')
"""

from __future__ import annotations

import io
import os
import tempfile
import zipfile
from pathlib import Path

import meshio
import numpy as np

from solver.io import write_mesh
from solver.mesh import Mesh

from .errors import ServiceError

__all__ = ["resolve_format", "export_mesh", "MESH_FORMATS", "SURFACE_FORMATS"]

#: Preferred extension of each meshio format the service offers.
MESH_FORMATS = {
    "abaqus": ".inp", "gmsh": ".msh", "gmsh22": ".msh", "vtu": ".vtu", "vtk": ".vtk",
    "medit": ".mesh", "tetgen": ".node", "nastran": ".bdf", "xdmf": ".xdmf", "ansys": ".msh",
    "avsucd": ".avs", "dolfin-xml": ".xml", "exodus": ".e", "flac3d": ".f3grid", "mdpa": ".mdpa",
    "med": ".med", "netgen": ".vol", "permas": ".dato", "su2": ".su2", "ugrid": ".ugrid",
    "cgns": ".cgns", "h5m": ".h5m", "hmf": ".hmf", "tecplot": ".dat",
}
#: Closed-surface formats accepted by the tetrahedralize resource.
SURFACE_FORMATS = {"stl": ".stl", "obj": ".obj", "ply": ".ply", "off": ".off"}
#: Preferred format of an ambiguous extension.
_PREFERRED = {".msh": "gmsh"}


def resolve_format(fmt: str | None, filename: str | None = None,
                   allowed: dict[str, str] | None = None) -> tuple[str, str]:
    """Resolve a format given by name or extension, or from a file name.

    Parameters
    ----------
    fmt : str, optional
        meshio format name (``"abaqus"``) or extension (``"inp"``, ``".inp"``).
    filename : str, optional
        Used when ``fmt`` is not given.
    allowed : dict, optional
        Format name to extension; defaults to :data:`MESH_FORMATS`.

    Returns
    -------
    (format, extension)

    Raises
    ------
    ServiceError
        422 ``unknown_format`` naming the accepted formats.
    """
    allowed = allowed or MESH_FORMATS
    known = ", ".join(sorted(set(allowed) | {e.lstrip(".") for e in allowed.values()}))
    if fmt:
        key = fmt.strip().lower()
        if key in allowed:
            return key, allowed[key]
        ext = key if key.startswith(".") else "." + key
        names = [n for n in meshio.extension_to_filetypes.get(ext, []) if n in allowed]
        if names:
            name = _PREFERRED.get(ext, names[0])
            return name, ext
        raise ServiceError(422, f"unknown format {fmt!r}; accepted: {known}", code="unknown_format",
                           format=fmt)
    if filename:
        name_l = filename.lower()
        for ext in sorted(meshio.extension_to_filetypes, key=len, reverse=True):
            if name_l.endswith(ext):
                names = [n for n in meshio.extension_to_filetypes[ext] if n in allowed]
                if names:
                    return _PREFERRED.get(ext, names[0]), ext
        raise ServiceError(422, f"cannot tell the format of {filename!r} from its extension; pass "
                           f"format= (accepted: {known})", code="unknown_format", filename=filename)
    raise ServiceError(422, "no file name and no format given", code="unknown_format")


def export_mesh(mesh: Mesh, V: np.ndarray, fmt: str, stem: str, quality: bool = False
                ) -> tuple[bytes, str, str]:
    """Write ``mesh`` with positions ``V`` in a format, as bytes.

    With ``quality`` the per-element metrics are written as cell data where
    the format stores it.

    Formats that write several files (TetGen ``.node`` + ``.ele``) come back
    as one zip archive.

    Returns
    -------
    (body, filename, media_type)

    Raises
    ------
    InvalidMeshError
        meshio cannot write the mesh in that format.
    """
    name, ext = resolve_format(fmt)
    with tempfile.TemporaryDirectory(prefix="tetmorph-export-") as tmp:
        path = Path(tmp) / f"{stem}{ext}"
        write_mesh(mesh, V, path, file_format=name, quality=quality)
        files = sorted(p for p in Path(tmp).iterdir() if p.is_file())
        if len(files) == 1:
            return files[0].read_bytes(), files[0].name, "application/octet-stream"
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
            for p in files:
                z.write(p, arcname=os.path.basename(p))
        return buf.getvalue(), f"{stem}.{name}.zip", "application/zip"
