"""The file formats tetmorph reads and writes back in place: one module per format, registered here.

meshio registers each format's reader and writer under its extensions. tetmorph
needs more of a format than that: which file a mesh is read from, how to tell
the format from a file's first bytes, the counts a file declares (checked
before its reader allocates anything), why its reader failed (in the format's
own words), and the in-place writer that changes nothing but the coordinates of
the nodes that moved. Each format that tetmorph writes back in place lives in
one module that builds a :class:`FileFormat` with all of that and calls
:func:`register_format`: the formats read by meshio (Gmsh, VTU, legacy VTK,
Medit) and those read by a reader of tetmorph's own (Abaqus/CAE decks, TetGen,
Nastran, Ansys ``.cdb``, LS-DYNA). :mod:`solver.io.own_formats` imports them.

:mod:`solver.io.formats` (names, sniffing), :mod:`solver.io.read` (the reader),
:mod:`solver.io.bounds` (declared sizes), :mod:`solver.io.diagnose` (a reader's
failure) and :mod:`solver.io.patchers` (the in-place writer) look the format
up here, and the service's format table is a view of the same entries. Formats
that meshio reads and tetmorph does not write back (XDMF, PLY, STL, ...) keep
their rules in those modules.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from typing import Any

from ..errors import UnreadableFileError, UnsupportedElementError

__all__ = ["FileFormat", "FORMATS", "SNIFF_ORDER", "register_format", "own_format", "sniff_registered",
           "sniffers"]

#: Where a registered sniffer is asked when its format names no place (:attr:`FileFormat.sniff_order`):
#: after the signatures of containers, documents and surfaces, before the rules for Abaqus and OBJ.
SNIFF_ORDER = 800


@dataclass(frozen=True)
class FileFormat:
    """Everything tetmorph knows of one file format.

    Attributes
    ----------
    name : str
        The format's name (``"ansys-cdb"``); the ``file_format`` value that selects it.
    title : str
        Its human name, for messages (``"Ansys MAPDL archive (.cdb)"``).
    extensions : tuple of str
        File extensions, lower case, with the dot (``(".cdb",)``); the first is the one it is written with.
    aliases : tuple of str
        Other ``file_format`` values that mean it (``("cdb",)``).
    sniff : callable, optional
        ``sniff(head, size) -> bool``: whether the first 8 kB of a file (``size``
        bytes in all, None where not known) look like this format.
    sniff_order : int
        Where the sniffer is asked among the others, lowest first
        (:func:`solver.io.formats.detect_format` interleaves the rules of the
        formats without a module): a more specific format (LS-DYNA's
        ``*KEYWORD``) before a more general one (Abaqus's ``*NODE``).
    read : callable, optional
        ``read(path, bounds) -> meshio.Mesh``; raises
        :class:`~solver.errors.UnreadableFileError` naming what is wrong. None:
        meshio's reader of the format's name reads it.
    reading : callable, optional
        ``reading(path, bounds)``: a context manager meshio's reader runs in,
        where ``read`` is None (a decompression budget, a correction of
        meshio's reader).
    main_path : callable, optional
        ``main_path(path) -> str``: the file read for a mesh named ``path``
        (TetGen's ``.node`` for its ``.ele``).
    check_sizes : callable, optional
        ``check_sizes(path, name, head, bounds)``: refuse a file that declares
        more nodes, elements or bytes than ``bounds`` (the helpers of
        :mod:`solver.io.read_bounds`), before it is read; ``head`` holds its
        first 4 MiB.
    check_complete : callable, optional
        ``check_complete(path, data)``: refuse a file cut short (or holding
        what the reader would pass over) before it is read; ``data`` is the
        file's tail, or None to read it.
    diagnose : callable, optional
        ``diagnose(path, data, exc) -> error or None``: the typed error that
        names why the reader failed with ``exc`` on the file of bytes ``data``
        (truncated sections, undefined nodes), or None where the format knows
        nothing more than the reader said.
    telling : bool
        The sniffer is sure enough that a file named as another format is refused
        as this one (``wrong_format``).
    signed : bool
        Every file of the format starts with what the sniffer looks for: a file
        named so that the sniffer does not recognise is refused.
    nodes_where : str
        Where the format's nodes are, for a file that defines none
        (``"no Vertices"``).
    patcher : solver.io.patchers.Patcher, optional
        The in-place writer: a zero move writes the file back byte for byte.
    writes : bool
        Whether a mesh of another format can be converted to this one.
    reads : str
        One line: what is read (for the formats page).
    refuses : str
        One line: what is refused, and how.
    """

    name: str
    title: str
    extensions: tuple[str, ...]
    aliases: tuple[str, ...] = ()
    sniff: Callable[[bytes, int | None], bool] | None = None
    read: Callable[[str, Any], Any] | None = None
    patcher: Any = None
    writes: bool = False
    reads: str = ""
    refuses: str = ""
    extra: dict[str, Any] = field(default_factory=dict)
    sniff_order: int = SNIFF_ORDER
    reading: Callable[[str, Any], AbstractContextManager[Any]] | None = None
    main_path: Callable[[str], str] | None = None
    check_sizes: Callable[[str, str, bytes, Any], None] | None = None
    check_complete: Callable[[str, bytes | None], None] | None = None
    diagnose: Callable[[str, bytes, BaseException], UnreadableFileError | UnsupportedElementError | None] | None = None
    telling: bool = False
    signed: bool = False
    nodes_where: str = ""


#: The registered formats by name.
FORMATS: dict[str, FileFormat] = {}


def register_format(f: FileFormat) -> FileFormat:
    """Add ``f`` to :data:`FORMATS` (and its in-place writer to :data:`solver.io.patchers.PATCHERS`)."""
    FORMATS[f.name] = f
    if f.patcher is not None:
        from .patchers import register

        register(f.patcher)
    return f


def own_format(key: str | None) -> FileFormat | None:
    """The registered format a name, alias or extension means, or None.

    Examples
    --------
    >>> import solver.io
    >>> own_format("inp").name, own_format(".INP").name, own_format("vtu").name, own_format("xdmf")
    ('abaqus', 'abaqus', 'vtu', None)
    """
    if not key:
        return None
    k = key.strip().lower()
    ext = k if k.startswith(".") else "." + k
    for f in FORMATS.values():
        if k == f.name or k in f.aliases or ext in f.extensions:
            return f
    return None


def by_extension(name: str) -> FileFormat | None:
    """The registered format whose extension ends the file name ``name``, longest first."""
    low = name.lower()
    best: tuple[int, FileFormat] | None = None
    for f in FORMATS.values():
        for ext in f.extensions:
            if low.endswith(ext) and (best is None or len(ext) > best[0]):
                best = (len(ext), f)
    return best[1] if best else None


def sniffers() -> list[FileFormat]:
    """The registered formats that sniff, in the order they are asked (:attr:`FileFormat.sniff_order`)."""
    return sorted((f for f in FORMATS.values() if f.sniff is not None), key=lambda f: f.sniff_order)


def sniff_registered(head: bytes, size: int | None = None) -> str | None:
    """The first registered format whose sniffer accepts ``head``, or None."""
    for f in sniffers():
        assert f.sniff is not None
        if f.sniff(head, size):
            return f.name
    return None


def keyword_sniffer(pattern: bytes) -> Callable[[bytes, int | None], bool]:
    """A sniffer that looks for a line-start regular expression (case-blind) in the head of a file."""
    rx = re.compile(pattern, re.IGNORECASE | re.MULTILINE)

    def sniff(head: bytes, size: int | None = None) -> bool:
        return rx.search(head) is not None

    return sniff
