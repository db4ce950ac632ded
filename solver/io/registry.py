"""The formats tetmorph reads with readers of its own: one module per format, registered here.

meshio registers each format's reader and writer under its extensions. The
formats that CAE decks come in (Abaqus/CAE assemblies, Ansys ``.cdb``, LS-DYNA
keyword files, Nastran with local coordinate systems) need more than meshio
offers: part-local numbering, the tool's own field widths, and an in-place
writer. Each such format lives in one module that builds a :class:`FileFormat`
and calls :func:`register_format`; :mod:`solver.io.formats` (names, sniffing),
:mod:`solver.io.read` (the reader) and :mod:`solver.io.patchers` (the in-place
writer) look the format up here, and the service's format table is a view of
the same entries.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

__all__ = ["FileFormat", "FORMATS", "register_format", "own_format", "sniff_registered"]


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
        File extensions, lower case, with the dot (``(".cdb",)``).
    aliases : tuple of str
        Other ``file_format`` values that mean it (``("cdb",)``).
    sniff : callable, optional
        ``sniff(head) -> bool``: whether the first 8 kB of a file look like this
        format. Registered sniffers are asked before the built-in ones, so a
        more specific format (LS-DYNA's ``*KEYWORD``) wins over a general one
        (Abaqus's ``*NODE``).
    read : callable, optional
        ``read(path, bounds) -> meshio.Mesh``; raises
        :class:`~solver.errors.UnreadableFileError` naming what is wrong.
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
    sniff: Callable[[bytes], bool] | None = None
    read: Callable[[str, Any], Any] | None = None
    patcher: Any = None
    writes: bool = False
    reads: str = ""
    refuses: str = ""
    extra: dict[str, Any] = field(default_factory=dict)


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
    >>> own_format("inp").name, own_format(".INP").name, own_format("vtu")
    ('abaqus', 'abaqus', None)
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


def sniff_registered(head: bytes) -> str | None:
    """The first registered format whose sniffer accepts ``head``, or None."""
    for f in FORMATS.values():
        if f.sniff is not None and f.sniff(head):
            return f.name
    return None


def keyword_sniffer(pattern: bytes) -> Callable[[bytes], bool]:
    """A sniffer that looks for a line-start regular expression (case-blind) in the head of a file."""
    rx = re.compile(pattern, re.IGNORECASE | re.MULTILINE)
    return lambda head: rx.search(head) is not None
