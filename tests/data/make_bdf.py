"""Generate small Nastran decks of a bar with a bolt hole, meshed by gmsh.

Each deck has executive control (``SOL 101``), case control (``CEND``, a
subcase with SPC, LOAD and output requests) and bulk data: ``PARAM``, ``MAT1``,
``PSOLID`` (PID 1), ``PSHELL`` (PID 2, shell triangles on the loaded end face),
``GRID``, ``CTETRA`` (4 or 10 nodes), ``CTRIA3``, ``SPC1`` on the x = 0 face and
a ``FORCE`` on one node of the loaded end. Run from this folder::

    python make_bdf.py bar_small.bdf --field small
    python make_bdf.py bar_large.bdf --field large
    python make_bdf.py bar_free.bdf --field free
    python make_bdf.py bar10_small.bdf --field small --order 2
"""

from __future__ import annotations

import argparse

import numpy as np

#: Bar length, width, height and hole radius (mm).
LENGTH, WIDTH, HEIGHT, RADIUS = 100.0, 20.0, 10.0, 5.0


def mesh_bar(size: float, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, tets (4 or 10 nodes, gmsh order) and the end-face triangles of the bar."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        bar = occ.addBox(0, 0, 0, LENGTH, WIDTH, HEIGHT)
        hole = occ.addCylinder(0.75 * LENGTH, WIDTH / 2, -1, 0, 0, HEIGHT + 2, RADIUS)
        occ.cut([(3, bar)], [(3, hole)])
        occ.synchronize()
        end = [t for d, t in gmsh.model.getEntities(2) if abs(occ.getCenterOfMass(d, t)[0] - LENGTH) < 1e-6]
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        index = np.zeros(int(tags.max()) + 1, np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        P = xyz.reshape(-1, 3)
        etype = 11 if order == 2 else 4
        _, enodes = gmsh.model.mesh.getElementsByType(etype)
        T = index[enodes.astype(np.int64)].reshape(-1, 10 if order == 2 else 4)
        tris = [index[gmsh.model.mesh.getElementsByType(2, t)[1].astype(np.int64)].reshape(-1, 3) for t in end]
        return P, T, np.concatenate(tris) if order == 1 else np.zeros((0, 3), np.int64)
    finally:
        gmsh.finalize()


def real(x: float, width: int | None) -> str:
    """A Nastran real in ``width`` characters (free field: None)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from solver.io.nastran import nastran_real

    return nastran_real(x, width)


def card(fields: list[str], field: str) -> str:
    """One card (with continuations) in small, large or free field."""
    if field == "free":
        head, rest = fields[:9], fields[9:]
        text = ",".join(head)
        while rest:
            text += ",+\n+," + ",".join(rest[:8])
            rest = rest[8:]
        return text + "\n"
    head, rest = fields[:9], fields[9:]
    text = "".join(f"{f:<8}" for f in head)
    while rest:
        text += "+\n+       " + "".join(f"{f:<8}" for f in rest[:8])
        rest = rest[8:]
    return text.rstrip() + "\n"


def write_deck(path: str, field: str, order: int, size: float) -> None:
    """Mesh the bar and write the deck."""
    P, T, F = mesh_bar(size, order)
    P = np.round(P, 4)
    fixed = np.flatnonzero(np.abs(P[:, 0]) < 1e-9) + 1
    tip = int(np.argmin(np.linalg.norm(P - [LENGTH, WIDTH / 2, HEIGHT], axis=1))) + 1
    out = ["$ tetmorph test deck: a bar with a bolt hole, fixed at x = 0, loaded at the far end\n",
           "SOL 101\n", "CEND\n", "TITLE = BAR UNDER TIP LOAD\n", "SUBCASE 1\n", "  SPC = 1\n", "  LOAD = 2\n",
           "  DISPLACEMENT = ALL\n", "  STRESS = ALL\n", "BEGIN BULK\n", "$ parameters, material, properties\n"]
    out.append(card(["PARAM", "POST", "-1"], field))
    out.append(card(["MAT1", "1", "210000.", "", "0.3", "7.85-9"], field))
    out.append(card(["PSOLID", "1", "1"], field))
    out.append(card(["PSHELL", "2", "1", "0.5", "1"], field))
    out.append("$ nodes\n")
    for k, x in enumerate(P):
        gid = k + 1
        if field == "large":
            r = [real(v, 16) for v in x]
            out.append(f"GRID*   {gid:<16d}{'':16}{r[0]:>16}{r[1]:>16}*N{gid:<6d}\n*N{gid:<6d}{r[2]:>16}\n")
        elif field == "free":
            out.append(f"GRID,{gid},," + ",".join(real(v, None) for v in x) + "\n")
        else:
            out.append(f"GRID    {gid:<8d}{'':8}" + "".join(f"{real(v, 8):>8}" for v in x) + "\n")
    out.append("$ elements\n")
    eid = 0
    for t in T + 1:
        eid += 1
        out.append(card(["CTETRA", str(eid), "1", *map(str, t)], field))
    for t in F + 1:
        eid += 1
        out.append(card(["CTRIA3", str(eid), "2", *map(str, t)], field))
    out.append("$ constraints and loads\n")
    out.append(card(["SPC1", "1", "123456", *map(str, fixed)], field))
    out.append(card(["FORCE", "2", str(tip), "0", "1.", "0.", "0.", "-1."], field))
    out.append("ENDDATA\n")
    with open(path, "w", encoding="ascii") as fh:
        fh.writelines(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("path")
    ap.add_argument("--field", choices=["small", "large", "free"], default="small")
    ap.add_argument("--order", type=int, choices=[1, 2], default=1)
    ap.add_argument("--size", type=float, default=5.0)
    a = ap.parse_args()
    write_deck(a.path, a.field, a.order, a.size)


if __name__ == "__main__":
    main()
