"""Generate ``ccx_bracket.inp``: a CalculiX static deck of a cantilever bar with a bolt hole, tet10.

A 100 x 20 x 10 bar with a 10 mm hole at x = 60, meshed by gmsh with
quadratic tetrahedra and written as an Abaqus/CalculiX deck: C3D10 elements
(gmsh's tet10 node order turned into Abaqus's), node sets NALL, FIXED (x = 0),
LOAD (x = 100) and HOLE (the bore), element set EALL, a steel material, and
one *STATIC step: FIXED clamped, 1000 N in -z spread over LOAD, with
displacements, stresses and the total mass printed to the .dat file. Run from
this folder::

    python make_ccx_bracket.py 4.0 ccx_bracket.inp
    python make_ccx_bracket.py 4.0 two_holes.inp 30:5 65:5    # two bores, sets HOLE1 and HOLE2
"""

from __future__ import annotations

import sys

import numpy as np

#: gmsh's tet10 mid-side order is (01, 12, 20, 30, 32, 31); Abaqus's is (01, 12, 20, 30, 31, 32).
GMSH_TO_ABAQUS = [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]


def _nset(name: str, ids: np.ndarray) -> list[str]:
    out = [f"*NSET, NSET={name}"]
    ids = np.sort(ids)
    out += [", ".join(str(int(i)) for i in ids[k:k + 16]) for k in range(0, ids.size, 16)]
    return out


def make_ccx_bracket(size: float, path: str, holes: tuple[tuple[float, float], ...] = ((60.0, 5.0),)) -> None:
    """Mesh the bar with gmsh's MeshSizeMax = ``size`` (second order) and write the deck to ``path``.

    ``holes`` are ``(x, radius)`` of vertical bores through the bar at y = 10. With
    one (the default: the checked-in deck), its nodes are the set HOLE; with
    several, HOLE holds them all and HOLE1, HOLE2, ... each one.
    """
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("ccx_bracket")
        occ = gmsh.model.occ
        box = occ.addBox(0, 0, 0, 100, 20, 10)
        occ.cut([(3, box)], [(3, occ.addCylinder(x, 10, -1, 0, 0, 12, r)) for x, r in holes])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.ElementOrder", 2)
        gmsh.option.setNumber("Mesh.HighOrderOptimize", 0)
        gmsh.model.mesh.generate(3)
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        V = np.asarray(xyz).reshape(-1, 3)
        types, _, enodes = gmsh.model.mesh.getElements(3)
        k = list(types).index(11)  # 10-node tetrahedron
        T = np.asarray(enodes[k], np.int64).reshape(-1, 10)
    finally:
        gmsh.finalize()
    order = np.argsort(tags)
    tags = np.asarray(tags, np.int64)[order]
    V = V[order]
    used = np.unique(T)
    new = np.zeros(tags.max() + 1, np.int64)
    new[used] = np.arange(1, used.size + 1)
    pos = np.searchsorted(tags, used)
    X = V[pos]
    E = new[T][:, GMSH_TO_ABAQUS]
    mids = {4: (0, 1), 5: (1, 2), 6: (2, 0), 7: (0, 3), 8: (1, 3), 9: (2, 3)}
    for m, (a, b) in mids.items():  # the Abaqus order: each mid-side node near its edge's midpoint (the bore's
        pa, pb = X[E[:, a] - 1], X[E[:, b] - 1]  # are on the cylinder, off the chord)
        off = np.linalg.norm(X[E[:, m] - 1] - 0.5 * (pa + pb), axis=1) / np.linalg.norm(pb - pa, axis=1)
        assert off.max() < 0.25, (m, off.max())  # a wrong pairing is off by 0.5 or more
    ids = np.arange(1, X.shape[0] + 1)
    on = [np.abs(np.hypot(X[:, 0] - x, X[:, 1] - 10.0) - r) < 1e-6 for x, r in holes]
    what = "a bolt hole" if len(holes) == 1 else f"{len(holes)} bolt holes"
    lines = ["*HEADING", f"Cantilever bar with {what}, tet10 (tetmorph tests/data/make_ccx_bracket.py)",
             "*NODE, NSET=NALL"]
    lines += [f"{i}, {x!r}, {y!r}, {z!r}" for i, (x, y, z) in zip(ids, X.tolist(), strict=True)]
    lines.append("*ELEMENT, TYPE=C3D10, ELSET=EALL")
    lines += [f"{e}, " + ", ".join(str(int(v)) for v in row) for e, row in enumerate(E.tolist(), start=1)]
    lines += _nset("FIXED", ids[np.abs(X[:, 0]) < 1e-9])
    load = ids[np.abs(X[:, 0] - 100.0) < 1e-9]
    lines += _nset("LOAD", load)
    lines += _nset("HOLE", ids[np.any(on, axis=0)])
    if len(holes) > 1:
        for k, mask in enumerate(on, start=1):
            lines += _nset(f"HOLE{k}", ids[mask])
    lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", "210000., 0.3", "*DENSITY", "7.85e-9",
              "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL", "*STEP", "*STATIC",
              "*BOUNDARY", "FIXED, 1, 3", "*CLOAD"]
    lines += [f"{i}, 3, {-1000.0 / load.size!r}" for i in load]
    lines += ["*NODE PRINT, NSET=NALL", "U", "*EL PRINT, ELSET=EALL", "S",
              "*EL PRINT, ELSET=EALL, TOTALS=ONLY", "EMAS", "*NODE FILE", "U", "*EL FILE", "S", "*END STEP"]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":  # python make_ccx_bracket.py SIZE PATH [X:RADIUS ...]
    bores = tuple(tuple(float(v) for v in a.split(":")) for a in sys.argv[3:]) or ((60.0, 5.0),)
    make_ccx_bracket(float(sys.argv[1]), sys.argv[2], bores)  # type: ignore[arg-type]
