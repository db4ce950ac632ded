"""Generate ``bracket.inp``: a 100 x 20 x 10 bar with a bolt hole, meshed by gmsh.

Abaqus deck with C3D4 elements, CPS3 end faces, and node and element sets
FIXED (x = 0 face), LOAD (x = 100 face) and SOLID. Run from this folder::

    python make_bracket.py 3.0 bracket.inp     # the test deck (4228 tets)
    python make_bracket.py 0.9 big.inp         # ~100k tets (benchmarks)
"""

from __future__ import annotations

import sys


def make_bracket(size: float, path: str) -> None:
    """Mesh the bracket with gmsh's MeshSizeMax = ``size`` and write ``path``."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("bracket")
        occ = gmsh.model.occ
        box = occ.addBox(0, 0, 0, 100, 20, 10)
        hole = occ.addCylinder(60, 10, -1, 0, 0, 12, 5)
        occ.cut([(3, box)], [(3, hole)])
        occ.synchronize()
        fixed, load = [], []
        for dim, tag in gmsh.model.getEntities(2):
            x = occ.getCenterOfMass(dim, tag)[0]
            if abs(x) < 1e-6:
                fixed.append(tag)
            if abs(x - 100) < 1e-6:
                load.append(tag)
        gmsh.model.addPhysicalGroup(2, fixed, name="FIXED")
        gmsh.model.addPhysicalGroup(2, load, name="LOAD")
        gmsh.model.addPhysicalGroup(3, [t for _, t in gmsh.model.getEntities(3)], name="SOLID")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.SaveGroupsOfNodes", 1)
        gmsh.model.mesh.generate(3)
        gmsh.write(path)
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    make_bracket(float(sys.argv[1]), sys.argv[2])
