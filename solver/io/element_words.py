"""Element counts in words, for messages: ``1 quadrilateral shell element (quad) and 12 beam/truss elements (line)``.

meshio names cell types (``quad``, ``line``, ``hexahedron20``); a message
that refuses them names what they are in a model, with their counts, and the
type in parentheses for whoever looks it up.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from typing import Any

__all__ = ["ELEMENT_WORDS", "SHELL_TYPES", "element_words", "counted", "cell_counts", "no_volume_words"]

#: meshio cell type -> (singular, plural) words for what it is in a model.
ELEMENT_WORDS: dict[str, tuple[str, str]] = {
    "vertex": ("point element", "point elements"),
    "line": ("beam/truss element", "beam/truss elements"),
    "triangle": ("triangular shell/face element", "triangular shell/face elements"),
    "quad": ("quadrilateral shell element", "quadrilateral shell elements"),
    "polygon": ("polygonal face", "polygonal faces"),
    "tetra": ("tetrahedron", "tetrahedra"),
    "hexahedron": ("hexahedron", "hexahedra"),
    "wedge": ("wedge (prism)", "wedges (prisms)"),
    "pyramid": ("pyramid", "pyramids"),
    "polyhedron": ("polyhedron", "polyhedra"),
}
_NODES = re.compile(r"([a-z_]+?)(\d+)\Z")
#: meshio cell types of shell (surface) elements: faces with no volume inside them.
SHELL_TYPES = {"triangle", "triangle6", "triangle7", "quad", "quad8", "quad9", "polygon"}


def no_volume_words(name: str, shells: bool, words: str, solid_types: str = "") -> str:
    """Why a file with no volume elements is refused, and what to do, in words.

    Parameters
    ----------
    name : str
        The file, as the message names it.
    shells : bool
        Every element is a shell or surface element (else beams, springs and the like are among them).
    words : str
        The elements it has, counted (:func:`element_words`).
    solid_types : str
        The format's own names of tetrahedra, in parentheses after the word.

    Examples
    --------
    >>> no_volume_words("'a.inp'", True, "1 shell element (S4)", "C3D4, C3D10").split("; ")[0]
    "'a.inp' has only shell/surface elements, no volume elements: 1 shell element (S4)"
    >>> no_volume_words("the mesh", False, "2 beam/truss elements (line)").split("; ")[1][:59]
    'tetmorph needs a volume mesh of tetrahedra, or of hexahedra'
    """
    what = "only shell/surface elements, no volume elements:" if shells else "no volume elements, only"
    tets = f"tetrahedra ({solid_types})" if solid_types else "tetrahedra"
    return (f"{name} has {what} {words}; tetmorph needs a volume mesh of {tets}, or of hexahedra, wedges and "
            "pyramids: mesh the part's volume with tetrahedra, or upload its closed surface as STL or OBJ and "
            "tetrahedralize it")


def _words(kind: str, count: int) -> str:
    """The words for ``count`` cells of one meshio type (higher-order types by their node count)."""
    pick = 0 if count == 1 else 1
    if kind in ELEMENT_WORDS:
        return ELEMENT_WORDS[kind][pick]
    m = _NODES.match(kind)
    if m and m[1] in ELEMENT_WORDS:  # hexahedron20, triangle6, line3: a 20-node hexahedron
        return f"{m[2]}-node {ELEMENT_WORDS[m[1]][pick]}"
    return "element" if count == 1 else "elements"


def counted(count: int, kind: str, label: str | None = None) -> str:
    """``count`` cells of meshio type ``kind`` in words, with ``label`` (default: the type) in parentheses.

    Examples
    --------
    >>> counted(1, "quad"), counted(12_345, "line")
    ('1 quadrilateral shell element (quad)', '12,345 beam/truss elements (line)')
    >>> counted(2, "hexahedron20"), counted(1, "tetra10", "TetrahedraP2"), counted(3, "VTK_LAGRANGE_CURVE")
    ('2 20-node hexahedra (hexahedron20)', '1 10-node tetrahedron (TetrahedraP2)', '3 elements (VTK_LAGRANGE_CURVE)')
    """
    return f"{count:,} {_words(kind, count)} ({label or kind})"


def element_words(counts: Mapping[str, int], labels: Mapping[str, str] | None = None) -> str:
    """Cell counts by meshio type in words, joined as a sentence lists them.

    Parameters
    ----------
    counts : mapping of str to int
        meshio cell type -> number of cells.
    labels : mapping of str to str, optional
        The name to give in parentheses instead of the meshio type (a file
        format's own keyword).

    Returns
    -------
    str
        ``"none"`` for no cells.

    Examples
    --------
    >>> element_words({"quad": 1, "line": 12})
    '1 quadrilateral shell element (quad) and 12 beam/truss elements (line)'
    >>> element_words({"vertex": 2, "triangle": 1_200, "tetra": 1})
    '2 point elements (vertex), 1,200 triangular shell/face elements (triangle) and 1 tetrahedron (tetra)'
    >>> element_words({})
    'none'
    """
    parts = [counted(int(n), kind, (labels or {}).get(kind)) for kind, n in counts.items()]
    if not parts:
        return "none"
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def cell_counts(cells: Iterable[Any]) -> dict[str, int]:
    """Cells per meshio type over a mesh's blocks (empty blocks left out), in order of first appearance.

    Examples
    --------
    >>> import meshio, numpy as np
    >>> cell_counts(meshio.Mesh(np.zeros((3, 3)), [("line", [[0, 1]]), ("vertex", np.zeros((0, 1))),
    ...                                             ("line", [[1, 2]])]).cells)
    {'line': 2}
    """
    out: dict[str, int] = {}
    for c in cells:
        if len(c.data):
            out[c.type] = out.get(c.type, 0) + len(c.data)
    return out
