"""Why a mesh file cannot be read, in the words of the file's format.

A reader's own exception rarely says what is wrong with the file (meshio
answers a truncated VTU with ``1`` and a deck naming an undefined node with
``np.int64(100)``). :func:`check_file` refuses what can be told from the bytes
before reading (an empty file, another format than the name says);
:func:`diagnose` turns a reader's exception into an
:class:`~solver.errors.UnreadableFileError` that names the defect (a truncated
file, the element and the node of an undefined reference), and
:func:`check_complete` catches a file cut short before it is read. What each
registered format knows of its own defects is its entry's
(:attr:`~solver.io.registry.FileFormat.diagnose`,
:attr:`~solver.io.registry.FileFormat.check_complete`); what is common to all
formats is here.
"""

from __future__ import annotations

import os
import re

from ..errors import UnreadableFileError, UnsupportedElementError
from .formats import a_format, detect_format
from .registry import FORMATS

__all__ = ["check_file", "diagnose", "check_complete", "check_last_line", "undefined_node_error"]

#: Formats without a module whose signature is strong enough to tell that a file is something else
#: (a registered format says so itself: :attr:`~solver.io.registry.FileFormat.telling`).
_STRONG = {"vtk-xml", "xdmf", "hdf5", "netcdf", "zip", "gzip", "pdf", "json", "html", "ply", "off", "stl", "ansys"}
#: Formats without a module whose files always carry their signature near the start
#: (:attr:`~solver.io.registry.FileFormat.signed`).
_SIGNED = {"ply", "off", "stl"}
#: The extension to rename a file to, for the formats without a module that are told by their signature.
_EXTENSIONS = {"stl": ".stl", "off": ".off", "ply": ".ply", "obj": ".obj"}


#: Container formats and the meshio formats stored in them (netCDF-4, meshio's Exodus default, is HDF5).
_CONTAINERS = {"hdf5": {"med", "cgns", "h5m", "xdmf", "hmf", "exodus"}, "netcdf": {"exodus"}, "vtk-xml": set()}


def _telling(fmt: str) -> bool:
    own = FORMATS.get(fmt)
    return own.telling if own is not None else fmt in _STRONG


def _signed(fmt: str) -> bool:
    own = FORMATS.get(fmt)
    return own.signed if own is not None else fmt in _SIGNED


def _expected_ok(expected: str, detected: str | None) -> bool:
    if detected is None or detected == expected or expected in _CONTAINERS.get(detected, set()):
        return True
    if expected == "gmsh22" and detected == "gmsh":
        return True
    return not _telling(detected)


def check_file(path: str, fmt: str | None) -> bytes:
    """Refuse an empty file or one whose content is another format than ``fmt``.

    Parameters
    ----------
    path : str
    fmt : str or None
        The meshio format the name (or the caller) says.

    Returns
    -------
    bytes
        The first 8 kB of the file.

    Raises
    ------
    UnreadableFileError
        ``empty_file``, ``wrong_format`` (details ``expected``, ``detected``) or
        ``unknown_format`` (an extension that names no format).
    """
    name = os.path.basename(path)
    size = os.path.getsize(path)
    if size == 0:
        raise UnreadableFileError(f"{name!r} is empty (0 bytes): there is nothing to read. Check that the "
                                  "upload or the export that wrote it finished.", code="empty_file", file=name)
    with open(path, "rb") as fh:
        head = fh.read(8192)
    if not head.strip():
        raise UnreadableFileError(f"{name!r} holds only blanks ({size} bytes): there is nothing to read.",
                                  code="empty_file", file=name)
    detected = detect_format(head, size)
    if fmt is None:
        seen = f"; its content looks like {a_format(detected)}: pass its format" if detected else ""
        raise UnreadableFileError(f"cannot tell the format of {name!r} from its extension{seen}",
                                  code="unknown_format", file=name, detected=detected)
    if not _expected_ok(fmt, detected):
        raise UnreadableFileError(
            f"{name!r} is named as {a_format(fmt)} but its content is {a_format(detected)}"
            f"{_hint(detected)}", code="wrong_format", file=name, expected=fmt, detected=detected)
    if fmt == "stl" and detected is None and size >= 84 and head[:5].lower() != b"solid":
        n = int.from_bytes(head[80:84], "little")
        raise UnreadableFileError(
            f"{name!r} is a binary STL declaring {n:,} triangles, which take {84 + 50 * n:,} bytes; the file has "
            f"{size:,}: it is truncated or its count is wrong", code="truncated_file", file=name, declared=n,
            size=size)
    if _signed(fmt) and detected is None:
        raise UnreadableFileError(
            f"{name!r} is named as {a_format(fmt)} but does not start like one (first bytes "
            f"{head[:40]!r}); it is no mesh format tetmorph recognises", code="wrong_format", file=name,
            expected=fmt, detected=None)
    return head


def _hint(detected: str | None) -> str:
    own = FORMATS.get(detected or "")
    ext = own.extensions[0] if own is not None else _EXTENSIONS.get(detected or "")
    if ext:
        return f": rename it to {ext} or pass its format"
    if detected == "ansys":
        return ": tetmorph reads Gmsh .msh files, not ANSYS/Fluent ones"
    if detected == "vtk-xml":
        return " (PolyData, ImageData...): save the mesh as an unstructured grid (.vtu)"
    return ": it is not a mesh"


def diagnose(path: str, fmt: str, exc: BaseException) -> UnreadableFileError | UnsupportedElementError:
    """The error to raise when the reader of ``fmt`` failed on ``path`` with ``exc``.

    Parameters
    ----------
    path : str
    fmt : str
        The meshio format that was read.
    exc : BaseException
        What the reader raised.

    Returns
    -------
    UnreadableFileError or UnsupportedElementError
        What the format's entry names (:attr:`~solver.io.registry.FileFormat.diagnose`:
        ``truncated_file``, ``no_nodes``, ``no_elements``, ``undefined_node``;
        ``unsupported_element`` for a Medit file with quadratic or higher-order
        elements, which meshio's reader stops at) or, when nothing more
        specific is known, ``unreadable_file`` quoting the reader.
    """
    name = os.path.basename(path)
    own = FORMATS.get("gmsh" if fmt == "gmsh22" else fmt)  # meshio writes Gmsh 2.2 as "gmsh22"
    if own is not None and own.diagnose is not None:
        with open(path, "rb") as fh:
            data = fh.read()
        found = own.diagnose(path, data, exc)
        if found is not None:
            return found
    return UnreadableFileError(f"cannot read {name!r} as {a_format(fmt)}: {_reason(exc)}",
                               code="unreadable_file", file=name, reader_error=type(exc).__name__)


def _reason(exc: BaseException) -> str:
    text = str(exc).strip()
    if isinstance(exc, SystemExit) or not text or text.isdigit():
        return f"the reader stopped ({type(exc).__name__}) without saying why; the file is corrupt or truncated"
    return f"{type(exc).__name__}: {text[:300]}"


def undefined_node_error(name: str, element: int, node: int, line: int, kind: str, count: int) -> UnreadableFileError:
    """``undefined_node``: the element of file ``name`` at ``line`` names ``node``, which the file does not define.

    ``count`` is the number of element lines that name undefined nodes.
    """
    more = f"; {count} element lines name undefined nodes" if count > 1 else ""
    return UnreadableFileError(
        f"{name!r} line {line}: element {element} ({kind}) refers to node {node}, which no node "
        f"definition in the file defines{more}", code="undefined_node", file=name, element=element, node=node,
        line=line, count=count)


def check_complete(path: str, fmt: str, data: bytes | None = None) -> None:
    """Refuse a file of format ``fmt`` cut short, as the format's entry tells.

    The entry's :attr:`~solver.io.registry.FileFormat.check_complete` does (a
    text format's is :func:`check_last_line`); other formats pass.

    Raises
    ------
    UnreadableFileError
        ``truncated_file``.
    UnsupportedElementError
        Elements the reader would pass over (a binary Medit file's quadratic ones).
    """
    own = FORMATS.get(fmt)
    if own is not None and own.check_complete is not None:
        own.check_complete(path, data)


def check_last_line(path: str, data: bytes | None = None) -> None:
    """Refuse a text mesh whose last line stops in the middle.

    No line end, and fewer fields than the line before it: a file cut short
    that a reader would take as complete. ``data`` is the file's tail (read
    here when None).

    Raises
    ------
    UnreadableFileError
        ``truncated_file``.
    """
    if data is None:
        with open(path, "rb") as fh:
            fh.seek(max(0, os.path.getsize(path) - 4096))
            data = fh.read()
    if not data or data.endswith((b"\n", b"\r")):
        return
    tail = data.splitlines()[-2:]
    if len(tail) < 2:
        return
    prev, last = tail
    sep = re.compile(rb"[,\s]+")
    nprev = len([f for f in sep.split(prev.strip()) if f])
    nlast = len([f for f in sep.split(last.strip()) if f])
    if re.match(rb"^\s*[-+.\d]", last) and re.match(rb"^\s*[-+.\d]", prev) and nlast < nprev:
        raise UnreadableFileError(
            f"{os.path.basename(path)!r} ends in the middle of a line ({nlast} fields where the line before "
            f"has {nprev}, and no line end): the file is truncated", code="truncated_file",
            file=os.path.basename(path))
