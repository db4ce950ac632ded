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
from collections.abc import Callable

import meshio

from .registry import FORMATS, FileFormat, by_extension, own_format, sniffers

__all__ = ["format_of", "detect_format", "describe", "a_format", "FORMAT_NAMES", "SURFACE_FORMATS"]

#: Human names of the formats without a module of their own, for messages (a registered format has its
#: :attr:`~solver.io.registry.FileFormat.title`).
FORMAT_NAMES = {
    "gmsh22": "Gmsh 2.2 mesh (.msh)",
    "vtk-xml": "VTK XML file of another kind than an unstructured grid",
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


def format_of(path: str | os.PathLike[str], file_format: str | None = None) -> str | None:
    """The meshio format name a file name (or an explicit format name) means.

    The registered formats' names, aliases and extensions come first
    (:mod:`solver.io.registry`: ``.msh`` is Gmsh, never ANSYS), then meshio's.

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
    for ext in sorted(meshio.extension_to_filetypes, key=len, reverse=True):
        if name.endswith(ext):
            return _by_extension(ext)
    return None


def _by_extension(ext: str) -> str | None:
    names = meshio.extension_to_filetypes.get(ext)
    return names[0] if names else None


# ------------------------------------------------------------------ sniffing

_OBJ, _FACE = re.compile(rb"^\s*v\s+[-+.\d]", re.MULTILINE), re.compile(rb"^\s*f\s+\d", re.MULTILINE)
_MAGIC = ((b"\x89HDF", "hdf5"), (b"CDF\x01", "netcdf"), (b"CDF\x02", "netcdf"), (b"PK\x03\x04", "zip"),
          (b"\x1f\x8b", "gzip"), (b"%PDF", "pdf"))


def _documents(head: bytes, data: bytes, size: int | None) -> str | None:
    """Containers and documents, by their first bytes."""
    text = head.lstrip()
    found = next((fmt for magic, fmt in _MAGIC if head.startswith(magic)), None)
    if found is None and text[:1] in (b"{", b"[") and b'"' in text[:200]:
        return "json"
    return "html" if found is None and text[:15].lower().startswith((b"<!doctype html", b"<html")) else found


def _surfaces(head: bytes, data: bytes, size: int | None) -> str | None:
    """PLY, OFF and STL (binary STL by its length)."""
    text = head.lstrip()
    if text.startswith(b"ply") or re.match(rb"[CN]?OFF\b", text):
        return "ply" if text.startswith(b"ply") else "off"
    if size is not None and len(data) >= 84 and size == 84 + 50 * int.from_bytes(data[80:84], "little"):
        return "stl"
    return "stl" if text[:5].lower() == b"solid" and b"facet" in head else None


#: The sniffing rules of the formats without a module, each at its place among the registered sniffers
#: (:attr:`~solver.io.registry.FileFormat.sniff_order`: Gmsh 100, VTU 200, legacy VTK 400, Medit 600,
#: LS-DYNA and Ansys .cdb 800, Abaqus 900, Nastran 1000, TetGen 1200), lowest first.
_RULES: tuple[tuple[int, Callable[[bytes, bytes, int | None], str | None]], ...] = (
    (210, lambda head, data, size: "vtk-xml" if b"<VTKFile" in head[:1024] else None),  # not the VTU sniffer's
    (300, lambda head, data, size: "xdmf" if b"<Xdmf" in head[:1024] else None),
    (500, _documents), (700, _surfaces),
    (1100, lambda head, data, size: "obj" if _OBJ.search(head) and _FACE.search(data) else None),
    (1300, lambda head, data, size: "ansys" if head.lstrip().startswith(b"(") else None))


def detect_format(data: bytes, size: int | None = None) -> str | None:
    r"""The format a file's first bytes look like, or None.

    The registered formats' sniffers and the rules of the formats without a module are asked in
    the order of their places (:attr:`~solver.io.registry.FileFormat.sniff_order`); the first answer wins.

    Parameters
    ----------
    data : bytes
        The start of the file (a few kilobytes are enough).
    size : int, optional
        The file's size in bytes (recognises binary STL and binary Medit by it).

    Returns
    -------
    str or None
        A registered format's name or a key of :data:`FORMAT_NAMES`.

    Examples
    --------
    >>> detect_format(b"$MeshFormat\n4.1 0 8\n"), detect_format(b"*Heading\n*Node\n1, 0, 0, 0\n")
    ('gmsh', 'abaqus')
    >>> detect_format(b"\x00\x01garbage") is None
    True
    """
    head = data[:8192]
    asked: list[tuple[int, FileFormat | Callable[[bytes, bytes, int | None], str | None]]] = [
        *_RULES, *((f.sniff_order, f) for f in sniffers())]
    for _, rule in sorted(asked, key=lambda r: r[0]):
        if isinstance(rule, FileFormat):
            if rule.sniff is not None and rule.sniff(head, size):
                return rule.name
        elif (found := rule(head, data, size)) is not None:
            return found
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
