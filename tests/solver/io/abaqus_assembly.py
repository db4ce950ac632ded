"""Abaqus/CAE-style decks built from tests/data/ccx_bracket.inp, and a few-line reader to check them with.

:func:`assembly_deck` places two parts (the bracket, and the bracket at half size as a "lug") with
``*Part``/``*Assembly``/``*Instance``, part-local numbering from 1 in each part, a translation and a
rotation line; :func:`flat_deck` writes the same shape as a plain deck. :func:`place` is the test's
own reading of the instance lines (translation first, then the rotation about the axis a-b).
"""

from __future__ import annotations

import re

import numpy as np

from tests.conftest import DATA

#: Lug-1's placement: translation, then the rotation about a-b (degrees).
LUG_T = np.array([160.0, 40.0, 5.0])
LUG_A, LUG_B, LUG_ANGLE = np.array([160.0, 40.0, 5.0]), np.array([160.0, 40.0, 25.0]), 30.0
LUG_SCALE = 0.5


def bracket() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, list[int]]]:
    """Node labels, positions, element labels, connectivity (labels) and node sets of ccx_bracket.inp."""
    text = (DATA / "ccx_bracket.inp").read_text().splitlines()
    labels, X, elabels, conn, sets = [], [], [], [], {}
    block, name = None, None
    for ln in text:
        if ln.startswith("*"):
            key = ln.upper().replace(" ", "")
            block = "node" if key.startswith("*NODE,") else "elem" if key.startswith("*ELEMENT") else \
                "nset" if key.startswith("*NSET") else None
            m = re.search(r"NSET=(\w+)", key)
            name = m.group(1) if (m and block == "nset") else None
            continue
        f = [x for x in ln.split(",") if x.strip()]
        if block == "node":
            labels.append(int(f[0]))
            X.append([float(v) for v in f[1:4]])
        elif block == "elem":
            elabels.append(int(f[0]))
            conn.append([int(v) for v in f[1:]])
        elif block == "nset" and name:
            sets.setdefault(name, []).extend(int(v) for v in f)
    return np.array(labels), np.array(X), np.array(elabels), np.array(conn), sets


def rotation(a: np.ndarray, b: np.ndarray, deg: float) -> np.ndarray:
    u = (b - a) / np.linalg.norm(b - a)
    th = np.deg2rad(deg)
    c, s = np.cos(th), np.sin(th)
    return np.array([[c + u[0] ** 2 * (1 - c), u[0] * u[1] * (1 - c) - u[2] * s, u[0] * u[2] * (1 - c) + u[1] * s],
                     [u[1] * u[0] * (1 - c) + u[2] * s, c + u[1] ** 2 * (1 - c), u[1] * u[2] * (1 - c) - u[0] * s],
                     [u[2] * u[0] * (1 - c) - u[1] * s, u[2] * u[1] * (1 - c) + u[0] * s, c + u[2] ** 2 * (1 - c)]])


def place(X: np.ndarray) -> np.ndarray:
    """Lug-1's part-local positions in assembly coordinates."""
    return (X + LUG_T - LUG_A) @ rotation(LUG_A, LUG_B, LUG_ANGLE).T + LUG_A


def _rows(ids, per=16) -> str:
    ids = list(ids)
    return "".join(", ".join(str(i) for i in ids[k:k + per]) + "\n" for k in range(0, len(ids), per))


def _nodes(labels, X) -> str:
    return "".join(f"{k}, {x!r}, {y!r}, {z!r}\n" for k, (x, y, z) in zip(labels, X.tolist(), strict=True))


def _elements(elabels, conn) -> str:
    return "".join(f"{e}, " + ", ".join(str(i) for i in row) + "\n" for e, row in zip(elabels, conn, strict=True))


MATERIAL = "*Material, name=STEEL\n*Elastic\n210000., 0.3\n*Density\n7.85e-09\n"
STEP = "*Step\n*Frequency\n8\n*Boundary\n{clamp}, 1, 3\n{lugclamp}, 1, 3\n*End Step\n"


def assembly_deck(second_bracket: bool = False, node_blocks: int = 1) -> str:
    """A two-part Abaqus/CAE deck: part Bracket (instance Bracket-1, in place) and part Lug (Lug-1, placed).

    ``second_bracket`` adds Bracket-2, a second instance of Bracket, moved 100 along -y. ``node_blocks``
    splits each part's nodes into that many ``*Node`` blocks.
    """
    labels, X, elabels, conn, sets = bracket()
    chunks = np.array_split(np.arange(len(labels)), node_blocks)
    nodes = "".join("*Node\n" + _nodes(labels[c], X[c]) for c in chunks)
    nodes_lug = "".join("*Node\n" + _nodes(labels[c], LUG_SCALE * X[c]) for c in chunks)
    part = ("*Element, type=C3D10, elset=EALL\n" + _elements(elabels, conn)
            + "*Nset, nset=FIXED\n" + _rows(sets["FIXED"]) + "*Nset, nset=HOLE\n" + _rows(sets["HOLE"])
            + "*Nset, nset=ENDS, generate\n 1, 9, 4\n"
            + "*Solid Section, elset=EALL, material=STEEL\n")
    second = ("*Instance, name=Bracket-2, part=Bracket\n 0., -100., 0.\n*End Instance\n" if second_bracket else "")
    return ("*Heading\n two parts, two instances\n** PARTS\n"
            f"*Part, name=Bracket\n{nodes}{part}*End Part\n"
            f"*Part, name=Lug\n{nodes_lug}{part}*End Part\n"
            "** ASSEMBLY\n*Assembly, name=Assembly\n"
            "*Instance, name=Bracket-1, part=Bracket\n*End Instance\n"
            "*Instance, name=Lug-1, part=Lug\n"
            f" {LUG_T[0]}, {LUG_T[1]}, {LUG_T[2]}\n"
            f" {LUG_A[0]}, {LUG_A[1]}, {LUG_A[2]}, {LUG_B[0]}, {LUG_B[1]}, {LUG_B[2]}, {LUG_ANGLE}\n"
            "*End Instance\n" + second
            + "*Nset, nset=CLAMP, instance=Bracket-1\n FIXED\n"
            + "*Nset, nset=LUGCLAMP, instance=Lug-1\n FIXED\n"
            + "*Elset, elset=LUGFEW, instance=Lug-1, internal\n 1, 2, 3\n"
            + "*End Assembly\n" + MATERIAL + STEP.format(clamp="CLAMP", lugclamp="LUGCLAMP"))


def flat_deck(Xb: np.ndarray, Xl: np.ndarray) -> str:
    """The same two parts as one plain deck: the bracket at ``Xb``, the lug at ``Xl`` (assembly positions)."""
    labels, _, elabels, conn, sets = bracket()
    off = 10000
    return ("*Heading\n the flat deck\n*Node\n" + _nodes(labels, Xb) + _nodes(labels + off, Xl)
            + "*Element, type=C3D10, elset=EALL\n" + _elements(elabels, conn) + _elements(elabels + off, conn + off)
            + "*Nset, nset=CLAMP\n" + _rows(sets["FIXED"]) + "*Nset, nset=LUGCLAMP\n"
            + _rows(np.array(sets["FIXED"]) + off) + MATERIAL
            + "*Solid Section, elset=EALL, material=STEEL\n" + STEP.format(clamp="CLAMP", lugclamp="LUGCLAMP"))


def node_lines(text: str) -> dict[tuple[str, int], list[float]]:
    """(part, label) -> coordinates of every node line of a deck: a few-line independent reader."""
    out: dict[tuple[str, int], list[float]] = {}
    part, inside = "", False
    for ln in text.splitlines():
        if ln.startswith("**"):
            continue
        if ln.startswith("*"):
            key = ln.upper().replace(" ", "")
            if key.startswith("*PART,"):
                part = key.split("NAME=")[1].split(",")[0]
            elif key.startswith("*ENDPART"):
                part = ""
            inside = key == "*NODE" or key.startswith("*NODE,")
            continue
        if inside and ln.strip():
            f = ln.split(",")
            out[(part, int(f[0]))] = [float(v) for v in f[1:4]]
    return out
