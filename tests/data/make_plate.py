"""Generate ``plate.inp``: a plate with a grid of round holes, meshed by gmsh.

Abaqus deck with C3D4 elements and node/element sets FIXED (x = 0 face), LOAD
(x = length face), BOTTOM (z = 0 face), TOP (z = thickness face) and HOLE1 ...
HOLEk (the cylindrical wall of each hole, numbered row by row). Run from this
folder::

    python make_plate.py plate.inp                       # the test deck: 2 x 2 holes
    python make_plate.py big.inp --holes 4 --size 1.6    # 16 holes (benchmarks)
"""

from __future__ import annotations

import argparse

#: Plate length, width and thickness, and hole radius (mm).
LENGTH, WIDTH, THICKNESS, RADIUS = 160.0, 80.0, 4.0, 6.0


def hole_centres(holes: int) -> list[tuple[float, float]]:
    """(x, y) centres of the ``holes`` x ``holes`` grid, row by row."""
    xs = [LENGTH * (i + 1) / (holes + 1) for i in range(holes)]
    ys = [WIDTH * (j + 1) / (holes + 1) for j in range(holes)]
    return [(x, y) for y in ys for x in xs]


def make_plate(path: str, holes: int = 2, size: float = 4.0) -> None:
    """Mesh the plate with gmsh's MeshSizeMax = ``size`` and write ``path``."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("plate")
        occ = gmsh.model.occ
        plate = occ.addBox(0, 0, 0, LENGTH, WIDTH, THICKNESS)
        cyl = [occ.addCylinder(x, y, -1, 0, 0, THICKNESS + 2, RADIUS) for x, y in hole_centres(holes)]
        occ.cut([(3, plate)], [(3, c) for c in cyl])
        occ.synchronize()
        groups: dict[str, list[int]] = {"FIXED": [], "LOAD": [], "BOTTOM": [], "TOP": []}
        centres = hole_centres(holes)
        hole_faces: dict[int, list[int]] = {}
        for dim, tag in gmsh.model.getEntities(2):
            x, y, z = occ.getCenterOfMass(dim, tag)
            if abs(x) < 1e-6:
                groups["FIXED"].append(tag)
            elif abs(x - LENGTH) < 1e-6:
                groups["LOAD"].append(tag)
            elif abs(z) < 1e-6:
                groups["BOTTOM"].append(tag)
            elif abs(z - THICKNESS) < 1e-6:
                groups["TOP"].append(tag)
            else:
                for k, (cx, cy) in enumerate(centres):
                    if (x - cx) ** 2 + (y - cy) ** 2 < (1.5 * RADIUS) ** 2:
                        hole_faces.setdefault(k, []).append(tag)
        for name, tags in groups.items():
            gmsh.model.addPhysicalGroup(2, tags, name=name)
        for k in sorted(hole_faces):
            gmsh.model.addPhysicalGroup(2, hole_faces[k], name=f"HOLE{k + 1}")
        gmsh.model.addPhysicalGroup(3, [t for _, t in gmsh.model.getEntities(3)], name="SOLID")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.SaveGroupsOfNodes", 1)
        gmsh.model.mesh.generate(3)
        gmsh.write(path)
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path")
    ap.add_argument("--holes", type=int, default=2, help="holes per row and column")
    ap.add_argument("--size", type=float, default=4.0, help="gmsh Mesh.MeshSizeMax")
    a = ap.parse_args()
    make_plate(a.path, a.holes, a.size)
