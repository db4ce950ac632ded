"""Ansys MAPDL element types in archives (``.cdb``): which are read, as which cells, and the rest in words.

An ``ET,itype,ename`` line names the element of each element type (``ET,3,187``:
type 3 is SOLID187). 4- and 10-node tetrahedra (SOLID285; SOLID187, SOLID92,
...) are read as ``tetra`` and ``tetra10``; 8-node bricks (SOLID185, SOLID45,
...) by the form their repeated corners give: hexahedron, wedge (K=L, O=P),
pyramid (M=N=O=P) or tetrahedron (K=L, M=N=O=P); 20-node bricks (SOLID186,
SOLID95, ...) in the same forms, the tetrahedron with its mid-side nodes as a
ten-node tetrahedron, and any form without its mid-side nodes as the linear
cell. Every other element is refused, each kind in words with its count
(``12 shell elements (SHELL181, type 3)``).
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import UnsupportedElementError
from .cdb_fields import _count, _error

#: Most nodes an element may list (MAPDL's largest solids have 20).
MAX_ELEMENT_NODES = 64

# element numbers by how their node lists read (MAPDL Element Reference)
_TET4 = frozenset({285})
_TET10 = frozenset({87, 92, 98, 123, 168, 187, 221, 227, 232, 237})
_BRICK8 = frozenset({5, 30, 45, 46, 64, 65, 69, 70, 96, 97, 164, 185, 190, 278})
_BRICK20 = frozenset({90, 95, 122, 186, 220, 226, 231, 236, 279})

#: Element name prefixes by element number (for messages: ``181`` -> ``SHELL181``).
_PREFIX = {
    "SOLID": (5, 45, 46, 64, 65, 69, 70, 87, 90, 92, 95, 96, 97, 98, 122, 123, 164, 168, 185, 186, 187, 226, 227,
              231, 232, 236, 237, 278, 279, 285),
    "SOLSH": (190,),
    "FLUID": (29, 30, 38, 79, 80, 81, 116, 129, 130, 136, 220, 221),
    "SHELL": (28, 41, 43, 57, 61, 63, 91, 93, 99, 131, 132, 157, 163, 181, 208, 209, 281),
    "BEAM": (3, 4, 23, 24, 44, 54, 161, 188, 189),
    "LINK": (1, 8, 10, 11, 31, 32, 33, 34, 68, 160, 180),
    "PIPE": (16, 17, 18, 20, 59, 60, 288, 289),
    "ELBOW": (290,),
    "CABLE": (280,),
    "PLANE": (2, 13, 25, 35, 42, 53, 55, 67, 75, 77, 78, 82, 83, 121, 162, 182, 183, 222, 223, 230, 233, 238, 292,
              293),
    "MASS": (21, 71, 166),
    "COMBIN": (7, 14, 37, 39, 40),
    "COMBI": (165, 214, 250),
    "CONTAC": (12, 52),
    "CONTA": (171, 172, 173, 174, 175, 176, 177, 178),
    "TARGE": (169, 170),
    "SURF": (19, 22, 151, 152, 153, 154, 155, 156, 159, 251, 252),
    "MPC": (184,),
    "PRETS": (179,),
    "FOLLW": (201,),
    "MESH": (200,),
    "MATRIX": (27, 50),
    "INFIN": (9, 47, 110, 111, 257),
    "INTER": (192, 193, 194, 195, 202, 203, 204, 205),
    "REINF": (263, 264, 265),
}
_NAMES = {number: f"{prefix}{number}" for prefix, numbers in _PREFIX.items() for number in numbers}

#: What each element name prefix is, in words (singular, plural).
_WORDS = {
    "SHELL": ("shell element", "shell elements"), "BEAM": ("beam element", "beam elements"),
    "LINK": ("link element", "link elements"), "PIPE": ("pipe element", "pipe elements"),
    "ELBOW": ("elbow element", "elbow elements"), "CABLE": ("cable element", "cable elements"),
    "PLANE": ("2-D plane element", "2-D plane elements"), "MASS": ("point mass", "point masses"),
    "COMBIN": ("spring-damper", "spring-dampers"), "COMBI": ("spring-damper", "spring-dampers"),
    "CONTAC": ("contact element", "contact elements"), "CONTA": ("contact element", "contact elements"),
    "TARGE": ("contact target element", "contact target elements"),
    "SURF": ("surface effect element", "surface effect elements"),
    "MPC": ("multipoint constraint element", "multipoint constraint elements"),
    "PRETS": ("pretension element", "pretension elements"),
    "FOLLW": ("follower load element", "follower load elements"),
    "MESH": ("mesh-only element", "mesh-only elements"), "MATRIX": ("matrix element", "matrix elements"),
    "INFIN": ("infinite element", "infinite elements"), "INTER": ("interface element", "interface elements"),
    "REINF": ("reinforcing element", "reinforcing elements"),
}

#: Corner positions (in the 8- or 20-node brick's list I..P, Q..B) of each form of a brick, in meshio's
#: order: a wedge's triangles K-J-I and O-N-M, the first one's normal pointing away from the second.
_BRICK_CORNERS = {"hexahedron": [0, 1, 2, 3, 4, 5, 6, 7], "wedge": [2, 1, 0, 6, 5, 4], "pyramid": [0, 1, 2, 3, 4],
                  "tetra": [0, 1, 2, 4]}
#: Mid-side positions of each form of a 20-node brick (Q=8 on I-J ... B=19 on L-P), in meshio's order.
_BRICK_MIDS = {"hexahedron": list(range(8, 20)), "wedge": [9, 8, 11, 13, 12, 15, 18, 17, 16],
               "pyramid": [8, 9, 10, 11, 16, 17, 18, 19], "tetra": [8, 9, 11, 16, 17, 18]}
#: The quadratic cell type of each linear one.
_QUADRATIC = {"tetra": "tetra10", "hexahedron": "hexahedron20", "wedge": "wedge15", "pyramid": "pyramid13"}
#: The cell types read, in the order of the mesh's cell blocks.
_READ_TYPES = ("tetra", "tetra10", "hexahedron", "wedge", "pyramid")
#: Refused cell types, in words (singular, plural).
_OTHER = ("element of a kind tetmorph does not read", "elements of a kind tetmorph does not read")
_SHAPE_WORDS = {"hexahedron20": ("quadratic (20-node) hexahedron", "quadratic (20-node) hexahedra"),
                "wedge15": ("quadratic (15-node) wedge", "quadratic (15-node) wedges"),
                "pyramid13": ("quadratic (13-node) pyramid", "quadratic (13-node) pyramids")}
_ENAME = re.compile(r"^([A-Za-z]*)\s*(\d+)$")


def _et_line(fields: tuple[str, ...], types: dict[int, tuple[int | None, str]]) -> None:
    """``ET,itype,ename``: type ``itype`` is element ``ename`` (``187`` or ``SOLID187``); parameters skipped."""
    if len(fields) < 2 or not fields[0].isdigit():
        return
    m = _ENAME.match(fields[1])
    types[int(fields[0])] = (int(m.group(2)) if m else None, fields[1].upper())


# ------------------------------------------------------------------ elements -> cells


def _element_name(types: dict[int, tuple[int | None, str]], itype: int) -> str:
    number, written = types[itype]
    if number is None:
        return written
    return _NAMES.get(number, written if not written.isdigit() else f"element {number}")


def _forms(C: np.ndarray) -> np.ndarray:
    """The form of each 8-node brick's corner list ``C`` (m, 8): hexahedron, wedge, pyramid or tetra.

    Examples
    --------
    >>> _forms(np.array([[1, 2, 3, 4, 5, 6, 7, 8], [1, 2, 3, 3, 4, 4, 4, 4], [1, 2, 3, 3, 4, 5, 6, 6],
    ...                  [1, 2, 3, 4, 5, 5, 5, 5]])).tolist()
    ['hexahedron', 'tetra', 'wedge', 'pyramid']
    """
    kl = C[:, 2] == C[:, 3]
    top = (C[:, 4] == C[:, 5]) & (C[:, 5] == C[:, 6]) & (C[:, 6] == C[:, 7])
    op = C[:, 6] == C[:, 7]
    form = np.full(len(C), "hexahedron", dtype=object)
    form[kl & op & ~top] = "wedge"
    form[top & ~kl] = "pyramid"
    form[top & kl] = "tetra"
    return form


def _take(N: np.ndarray, cols: list[int]) -> np.ndarray:
    """Columns ``cols`` of ``N``, 0 past its width."""
    out = np.zeros((N.shape[0], len(cols)), np.int64)
    for k, c in enumerate(cols):
        if c < N.shape[1]:
            out[:, k] = N[:, c]
    return out


def _shapes(number: int, N: np.ndarray) -> list[tuple[str, np.ndarray, list[int]]]:
    """The cells of the elements of element number ``number`` whose node lists are ``N`` (m, k).

    Returns
    -------
    list of (str, (r,) int array, list of int)
        A cell type, the elements (rows of ``N``) of that type and the positions of the cell's nodes
        in their node lists (meshio's order). The type is ``""`` for elements that give some but
        not all of their mid-side nodes.
    """
    if number in _TET4 or number in _TET10:
        linear = np.full(len(N), "tetra", dtype=object)
        corners, mids = {"tetra": [0, 1, 2, 3]}, {"tetra": [4, 5, 6, 7, 8, 9] if number in _TET10 else []}
    else:
        linear = _forms(_take(N, list(range(8))))
        corners = _BRICK_CORNERS
        mids = _BRICK_MIDS if number in _BRICK20 else {k: [] for k in _BRICK_CORNERS}
    out = []
    for form in np.unique(linear).tolist():
        rows = np.flatnonzero(linear == form)
        given = (_take(N[rows], mids[form]) != 0).sum(axis=1)
        out.append((form, rows[given == 0], corners[form]))
        if mids[form]:
            out.append((_QUADRATIC[form], rows[given == len(mids[form])], corners[form] + mids[form]))
            out.append(("", rows[(given > 0) & (given < len(mids[form]))], []))
    return [(kind, rows, cols) for kind, rows, cols in out if rows.size]


def _cells(name: str, F: np.ndarray, N: np.ndarray, where: np.ndarray, types: dict[int, tuple[int | None, str]]
           ) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], dict[tuple[str, str, str], int]]:
    """The elements as cells, and the refused ones counted.

    Parameters
    ----------
    name : str
        The file's name, for messages.
    F : (m, 11) int64 array
        The elements' ``EBLOCK`` fields (type in column 1, node count in 8, element number in 10).
    N : (m, k) int64 array
        Their node numbers, 0 past each element's count.
    where : (m,) int64 array
        Line number of each element.
    types : dict of int to (int or None, str)
        Element type number -> (element number, element name as written), from the ``ET`` lines.

    Returns
    -------
    cells : dict of str to (positions (k,), node numbers (k, c))
        By cell type: the elements (positions in ``F``, in file order) and their nodes.
    refused : dict of (str, str, str) to int
        ``(words, element, key) -> count``: ``("shell elements", "SHELL181, type 3", "SHELL181") -> 12``.
    """
    itypes = F[:, 1]
    undefined = np.flatnonzero(~np.isin(itypes, np.fromiter(types, np.int64, len(types))))
    if undefined.size:
        r = int(undefined[0])
        raise _error(name, int(where[r]), f"element {int(F[r, 10])} has type {int(itypes[r])}, which no ET line "
                     f"defines ({_count(undefined.size, 'element')} of undefined types)", element=int(F[r, 10]),
                     type=int(itypes[r]))
    parts: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    refused: dict[tuple[str, str, str], int] = {}
    for itype in np.unique(itypes).tolist():
        rows = np.flatnonzero(itypes == itype)
        number = types[itype][0]
        ename = _element_name(types, itype)
        label = f"{ename}, type {itype}"
        if number not in _TET4 | _TET10 | _BRICK8 | _BRICK20:
            prefix = _ENAME.match(ename)
            words = _WORDS.get(prefix.group(1) if prefix else "", _OTHER)
            refused[(words[1], label, ename)] = rows.size
            continue
        _check_count(name, F[rows], where[rows], number, label)
        for kind, sub, cols in _shapes(number, N[rows]):
            at = rows[sub]
            if kind == "":
                r = int(at[0])
                raise _error(name, int(where[r]), f"element {int(F[r, 10])} ({label}) gives some of its mid-side "
                             f"nodes but not all ({_count(at.size, 'such element')}): tetmorph reads quadratic "
                             "elements with every mid-side node, or linear ones with none", element=int(F[r, 10]))
            if kind in _SHAPE_WORDS:
                refused[(_SHAPE_WORDS[kind][1], label, kind)] = at.size
                continue
            parts.setdefault(kind, []).append((at, _take(N[at], cols)))
    cells = {}
    for kind in _READ_TYPES:
        if kind in parts:
            at = np.concatenate([p[0] for p in parts[kind]])
            conn = np.concatenate([p[1] for p in parts[kind]])
            order = np.argsort(at, kind="stable")
            cells[kind] = (at[order], conn[order])
    return cells, refused


def _check_count(name: str, F: np.ndarray, where: np.ndarray, number: int, label: str) -> None:
    """Refuse elements that list more nodes than their element has."""
    cap = 4 if number in _TET4 else 10 if number in _TET10 else 8 if number in _BRICK8 else 20
    over = np.flatnonzero(F[:, 8] > cap)
    if over.size:
        r = int(over[0])
        raise _error(name, int(where[r]), f"element {int(F[r, 10])} ({label}) lists {int(F[r, 8])} nodes; the "
                     f"element has {cap}", element=int(F[r, 10]))


def _refuse(name: str, refused: dict[tuple[str, str, str], int]) -> UnsupportedElementError:
    """The refusal of the elements tetmorph does not read, each kind in words with its count."""
    singular = {many: one for one, many in (*_WORDS.values(), *_SHAPE_WORDS.values(), _OTHER)}
    items = sorted(refused.items(), key=lambda kv: -kv[1])
    parts = [f"{count} {singular[words] if count == 1 else words} ({label})" for (words, label, _), count in items]
    said = parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
    types: dict[str, int] = {}
    for (_, _, key), count in items:
        types[key] = types.get(key, 0) + count
    return UnsupportedElementError(
        f"{name!r} holds {said}: tetmorph deforms solid elements (tetrahedra, hexahedra, wedges and pyramids; "
        "ten-node tetrahedra alone) and refuses the others rather than move part of a model", types=types, file=name)
