"""File formats: what a file name means, and what a file's content looks like.

meshio maps an extension to several readers (``.msh`` is both ANSYS and Gmsh);
:func:`format_of` resolves each extension to one format, Gmsh for ``.msh``, so
that reading and writing agree. :func:`detect_format` sniffs the first bytes of
a file, so that an unreadable file can be reported as "this is a Gmsh file
named .vtu" rather than with the reader's own error.
"""

from __future__ import annotations

import os
import re

import meshio

from .registry import FORMATS, by_extension, own_format, sniff_registered

__all__ = ["format_of", "detect_format", "describe", "a_format", "FORMAT_NAMES", "SURFACE_FORMATS"]

#: Human names of the formats, for messages.
FORMAT_NAMES = {
    "abaqus": "Abaqus/CalculiX deck (.inp)",
    "gmsh": "Gmsh mesh (.msh)",
    "gmsh22": "Gmsh 2.2 mesh (.msh)",
    "vtu": "VTK XML unstructured grid (.vtu)",
    "vtk": "legacy VTK file (.vtk)",
    "vtk-xml": "VTK XML file of another kind than an unstructured grid",
    "medit": "Medit mesh (.mesh)",
    "tetgen": "TetGen mesh (.node + .ele)",
    "nastran": "Nastran bulk data deck (.bdf/.nas)",
    "stl": "STL triangle surface (.stl)",
    "obj": "Wavefront OBJ surface (.obj)",
    "off": "OFF surface (.off)",
    "ply": "PLY surface (.ply)",
    "ansys": "ANSYS/Fluent mesh",
    "hdf5": "HDF5 container (XDMF, MED, CGNS or H5M)",
    "netcdf": "netCDF container (Exodus)",
    "xdmf": "XDMF file (.xdmf)",
    "zip": "zip archive",
    "gzip": "gzip-compressed file",
    "json": "JSON document",
    "html": "HTML page",
    "pdf": "PDF document",
}

#: Triangle-surface formats: meshes in them are surfaces, never volumes.
SURFACE_FORMATS = {"stl", "obj", "off", "ply"}

#: The format each extension means where meshio knows several.
_PREFERRED = {".msh": "gmsh"}
_EXTRA = {".nas": "nastran", ".bdf": "nastran", ".fem": "nastran", ".ele": "tetgen", ".node": "tetgen"}


def format_of(path: str | os.PathLike[str], file_format: str | None = None) -> str | None:
    """The meshio format name a file name (or an explicit format name) means.

    Parameters
    ----------
    path : str or path
    file_format : str, optional
        A meshio format name or an extension (``"inp"``, ``".msh"``); wins over the path.

    Returns
    -------
    str or None
        ``None`` when the extension means no format.

    Examples
    --------
    >>> format_of("part.msh"), format_of("DECK.INP"), format_of("x.dat", "bdf"), format_of("a.xyz")
    ('gmsh', 'abaqus', 'nastran', None)
    """
    if file_format:
        key = file_format.strip().lower()
        own = own_format(key)
        if own is not None:
            return own.name
        if key in meshio._helpers.reader_map or key in meshio._helpers._writer_map:
            return key
        ext = key if key.startswith(".") else "." + key
        return _by_extension(ext) or key
    name = os.fspath(path).lower()
    own = by_extension(name)
    if own is not None:
        return own.name
    for ext in sorted({*meshio.extension_to_filetypes, *_EXTRA}, key=len, reverse=True):
        if name.endswith(ext):
            return _by_extension(ext)
    return None


def _by_extension(ext: str) -> str | None:
    if ext in _PREFERRED:
        return _PREFERRED[ext]
    if ext in _EXTRA:
        return _EXTRA[ext]
    names = meshio.extension_to_filetypes.get(ext)
    return names[0] if names else None


_ABAQUS = re.compile(rb"^\s*\*\s*(heading|node|element|part|assembly|nset|elset|include|material|step)\b",
                     re.IGNORECASE | re.MULTILINE)
_NASTRAN = re.compile(rb"^(BEGIN\s+BULK|GRID[*,\s]|CTETRA|CHEXA|SOL\s|CEND)", re.IGNORECASE | re.MULTILINE)
_OBJ = re.compile(rb"^\s*v\s+[-+.\d]", re.MULTILINE)
_TETGEN_HEAD = re.compile(rb"^\s*\d+\s+3\s+\d+\s+\d+\s*$")


def detect_format(data: bytes, size: int | None = None) -> str | None:
    r"""The format a file's first bytes look like, or None.

    Parameters
    ----------
    data : bytes
        The start of the file (a few kilobytes are enough).
    size : int, optional
        The file's size in bytes (recognises binary STL by its length).

    Returns
    -------
    str or None
        A key of :data:`FORMAT_NAMES`.

    Examples
    --------
    >>> detect_format(b"$MeshFormat\n4.1 0 8\n"), detect_format(b"*Heading\n*Node\n1, 0, 0, 0\n")
    ('gmsh', 'abaqus')
    >>> detect_format(b"\x00\x01garbage") is None
    True
    """
    head = data[:8192]
    text = head.lstrip()
    if text.startswith(b"$MeshFormat") or text.startswith(b"$NOD"):
        return "gmsh"
    if b"<VTKFile" in head[:1024]:
        return "vtu" if b"UnstructuredGrid" in head[:2048] else "vtk-xml"
    if b"<Xdmf" in head[:1024]:
        return "xdmf"
    if text.startswith(b"# vtk DataFile"):
        return "vtk"
    if head.startswith(b"\x89HDF"):
        return "hdf5"
    if head.startswith(b"CDF\x01") or head.startswith(b"CDF\x02"):
        return "netcdf"
    if head.startswith(b"PK\x03\x04"):
        return "zip"
    if head.startswith(b"\x1f\x8b"):
        return "gzip"
    if head.startswith(b"%PDF"):
        return "pdf"
    if text[:1] in (b"{", b"[") and b'"' in text[:200]:
        return "json"
    if text[:15].lower().startswith((b"<!doctype html", b"<html")):
        return "html"
    if re.search(rb"^\s*MeshVersionFormatted", head, re.MULTILINE):
        return "medit"
    if head[:4] in (b"\x01\x00\x00\x00", b"\x00\x00\x00\x01") and size is not None and size > 8:
        return "medit"  # binary Medit (.meshb): code 1, then the version
    if text.startswith(b"ply"):
        return "ply"
    if re.match(rb"[CN]?OFF\b", text):
        return "off"
    if size is not None and len(data) >= 84 and size == 84 + 50 * int.from_bytes(data[80:84], "little"):
        return "stl"
    if text[:5].lower() == b"solid" and b"facet" in head:
        return "stl"
    own = sniff_registered(head)
    if own is not None:
        return own
    if _ABAQUS.search(head):
        return "abaqus"
    if _NASTRAN.search(head):
        return "nastran"
    if _OBJ.search(head) and re.search(rb"^\s*f\s+\d", data, re.MULTILINE):
        return "obj"
    first = next((ln for ln in head.splitlines() if ln.strip() and not ln.lstrip().startswith(b"#")), b"")
    if _TETGEN_HEAD.match(first):
        return "tetgen"
    if text.startswith(b"("):
        return "ansys"
    return None


def a_format(fmt: str | None) -> str:
    """The human name of a format with its article.

    Examples
    --------
    >>> a_format("abaqus"), a_format("gmsh")
    ('an Abaqus/CalculiX deck (.inp)', 'a Gmsh mesh (.msh)')
    """
    name = describe(fmt)
    if fmt is None:
        return name
    return ("an " if name[:1].lower() in "aeiou" else "a ") + name


def describe(fmt: str | None) -> str:
    """The human name of a format.

    Examples
    --------
    >>> describe("vtu"), describe(None)
    ('VTK XML unstructured grid (.vtu)', 'no known mesh format')
    """
    if fmt is None:
        return "no known mesh format"
    if fmt in FORMATS:
        return FORMATS[fmt].title
    return FORMAT_NAMES.get(fmt, fmt)
