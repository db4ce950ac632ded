"""Registry of in-place patchers: formats whose files are written back byte for byte.

A patcher takes the bytes of the file a mesh was read from and new positions,
and returns the same file with only the coordinates changed, or ``None`` when
it cannot (the caller then writes through meshio). Each format's module builds
its patcher and registers it with the format (:func:`solver.io.registry.register_format`),
as meshio registers its readers and writers, so :func:`solver.io.read.read_mesh`
knows which files to keep and :func:`solver.io.write.write_mesh` which to
patch.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["Patcher", "PATCHERS", "register", "patcher_for"]


@dataclass(frozen=True)
class Patcher:
    """One format's in-place writer.

    Attributes
    ----------
    name : str
        meshio's format name.
    aliases : tuple of str
        Other names (``file_format`` values) of the format.
    extensions : tuple of str
        File extensions, lower case, without the dot.
    accepts : callable
        ``accepts(raw, n) -> bool``: whether the original bytes can be patched
        for a mesh of ``n`` points (sniffs the header, counts node lines).
    patch : callable
        ``patch(raw, V) -> bytes | None``; raises ValueError or returns None
        when the file cannot be patched.
    main : str, optional
        For a format spread over several files, the extension of the one that
        holds the coordinates and is patched (TetGen: ``"node"``).
    companions : tuple of str
        Extensions of the other files, kept byte for byte (TetGen: ``("ele",)``).
    includes : callable, optional
        ``includes(path) -> list of str``: the files a deck includes (Abaqus and
        LS-DYNA ``*INCLUDE``), as paths relative to the deck's folder, in the
        order they are read; :func:`solver.io.read.read_mesh` keeps their bytes
        in :attr:`Mesh.companions` under those paths.
    patch_tree : callable, optional
        ``patch_tree(raw, included, V) -> dict of str to bytes``: the deck and its
        included files (``included`` by relative path) with new coordinates;
        the key ``""`` is the deck itself. Used instead of ``patch`` when the
        deck includes files.
    """

    name: str
    aliases: tuple[str, ...]
    extensions: tuple[str, ...]
    accepts: Callable[[bytes, int], bool]
    patch: Callable[[bytes, np.ndarray], bytes | None]
    main: str | None = None
    companions: tuple[str, ...] = ()
    includes: Callable[[str], list[str]] | None = None
    patch_tree: Callable[[bytes, dict[str, bytes], np.ndarray], dict[str, bytes] | None] | None = None

    def files(self, path: str) -> tuple[str, dict[str, str]]:
        """The patched file and the companion files (by extension) of a mesh named ``path``.

        Examples
        --------
        >>> PATCHERS["tetgen"].files("out/beam.ele")
        ('out/beam.node', {'ele': 'out/beam.ele'})
        >>> PATCHERS["abaqus"].files("deck.inp")
        ('deck.inp', {})
        """
        if self.main is None:
            return path, {}
        stem = path.rsplit(".", 1)[0] if "." in path.rsplit("/", 1)[-1] else path
        return f"{stem}.{self.main}", {ext: f"{stem}.{ext}" for ext in self.companions}


#: Patchers by meshio format name.
PATCHERS: dict[str, Patcher] = {}


def register(p: Patcher) -> Patcher:
    """Add a patcher to :data:`PATCHERS`."""
    PATCHERS[p.name] = p
    return p


def patcher_for(path: str, file_format: str | None = None) -> Patcher | None:
    """The patcher for a file name or an explicit format name, or None.

    Examples
    --------
    >>> patcher_for("deck.INP").name, patcher_for("x.bin", "gmsh").name, patcher_for("a.stl")
    ('abaqus', 'gmsh', None)
    >>> patcher_for("m.bdf").name, patcher_for("beam.ele").name
    ('nastran', 'tetgen')
    """
    if file_format is not None:
        fmt = file_format.lower()
        return next((p for p in PATCHERS.values() if fmt == p.name or fmt in p.aliases), None)
    ext = path.lower().rsplit(".", 1)[-1] if "." in path else ""
    return next((p for p in PATCHERS.values() if ext in p.extensions), None)
