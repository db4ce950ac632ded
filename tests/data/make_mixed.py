"""Generate ``mixed.msh``: a bar of hexahedra, tetrahedra, pyramids and wedges, meshed by gmsh.

Three volumes share faces: a block of structured hexahedra (x in [0, 20]), a
block of tetrahedra (x in [20, 40]) that gmsh joins to the hexahedra's quad
faces with pyramids, and a layer of wedges extruded from the tetrahedral
block's top face (z in [10, 14]). Physical groups: FIXED (x = 0 face), LOAD
(x = 40 face of the tet block), and one per volume (HEX, TET, WEDGE). Written
as ASCII Gmsh 4.1. Run from this folder::

    python make_mixed.py mixed.msh            # the test deck
    python make_mixed.py big.msh --size 1.0   # finer
"""

from __future__ import annotations

import argparse


def make_mixed(path: str, size: float = 4.0) -> None:
    """Mesh the bar with element size ``size`` (mm) and write ``path``."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("mixed")
        occ = gmsh.model.occ
        hexa = occ.addBox(0, 0, 0, 20, 10, 10)
        tet = occ.addBox(20, 0, 0, 20, 10, 10)
        occ.fragment([(3, hexa)], [(3, tet)])
        occ.synchronize()
        top = [t for d, t in gmsh.model.getEntities(2)
               if abs(occ.getCenterOfMass(d, t)[2] - 10) < 1e-9 and occ.getCenterOfMass(d, t)[0] > 20]
        n = max(2, round(10 / size))
        ext = occ.extrude([(2, top[0])], 0, 0, 4, numElements=[max(1, round(4 / size))], recombine=True)
        occ.synchronize()
        wedge = [t for d, t in ext if d == 3]
        # structured hexahedra in the first block: transfinite curves, surfaces and volume
        for d, t in gmsh.model.getBoundary([(3, hexa)], combined=False, oriented=False, recursive=True):
            if d == 1:
                gmsh.model.mesh.setTransfiniteCurve(t, 2 * n + 1 if _along_x(t) else n + 1)
        for _, t in gmsh.model.getBoundary([(3, hexa)], combined=False, oriented=False):
            gmsh.model.mesh.setTransfiniteSurface(t)
            gmsh.model.mesh.setRecombine(2, t)
        gmsh.model.mesh.setTransfiniteVolume(hexa)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        groups = {"FIXED": [], "LOAD": []}
        for d, t in gmsh.model.getEntities(2):
            x = occ.getCenterOfMass(d, t)[0]
            if abs(x) < 1e-9:
                groups["FIXED"].append(t)
            elif abs(x - 40) < 1e-9:
                groups["LOAD"].append(t)
        for name, tags in groups.items():
            gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, tags), name)
        for name, tags in (("HEX", [hexa]), ("TET", [tet]), ("WEDGE", wedge)):
            gmsh.model.setPhysicalName(3, gmsh.model.addPhysicalGroup(3, tags), name)
        gmsh.model.mesh.generate(3)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.Binary", 0)
        gmsh.write(path)
    finally:
        gmsh.finalize()


def _along_x(curve: int) -> bool:
    import gmsh

    lo = gmsh.model.getBoundingBox(1, curve)
    return (lo[3] - lo[0]) > max(lo[4] - lo[1], lo[5] - lo[2])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path")
    ap.add_argument("--size", type=float, default=4.0)
    a = ap.parse_args()
    make_mixed(a.path, a.size)


if __name__ == "__main__":
    main()
