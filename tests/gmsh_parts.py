"""Parts meshed by gmsh for the tests: a mirror-symmetric bar, a periodic sector, two blocks, a sheet panel,
a filleted L bracket.

The volume parts return ``(V, T)`` arrays (positively oriented tets);
:func:`sheet_panel` writes a triangle mesh. Each is deterministic for a given
gmsh version and size.
"""

from __future__ import annotations

import math

import numpy as np


def _arrays(gmsh) -> tuple[np.ndarray, np.ndarray]:
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    V = xyz.reshape(-1, 3)
    _, en = gmsh.model.mesh.getElementsByType(4)
    idx = np.zeros(int(tags.max()) + 1, np.int64)
    idx[tags.astype(np.int64)] = np.arange(len(tags))
    T = idx[en.reshape(-1, 4).astype(np.int64)]
    used = np.unique(T)
    comp = np.full(len(V), -1, np.int64)
    comp[used] = np.arange(used.size)
    return V[used], comp[T]


def symmetric_bar(size: float = 4.0) -> tuple[np.ndarray, np.ndarray]:
    """A 100 x 20 x 10 bar with two bolt holes, exactly mirror-symmetric about x = 50.

    The half x <= 50 is meshed by gmsh and mirrored; nodes on the plane are shared.
    """
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        box = occ.addBox(0, 0, 0, 50, 20, 10)
        hole = occ.addCylinder(30, 10, -1, 0, 0, 12, 5)
        occ.cut([(3, box)], [(3, hole)])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        V, T = _arrays(gmsh)
    finally:
        gmsh.finalize()
    Vm = V.copy()
    Vm[:, 0] = 100.0 - Vm[:, 0]
    on = np.abs(V[:, 0] - 50.0) < 1e-9
    n = len(V)
    remap = np.arange(n) + n
    remap[on] = np.flatnonzero(on)
    VV = np.vstack([V, Vm])
    TT = np.vstack([T, remap[T][:, [0, 2, 1, 3]]])  # mirrored tets change orientation
    used = np.unique(TT)
    comp = np.full(len(VV), -1, np.int64)
    comp[used] = np.arange(used.size)
    return VV[used], comp[TT]


def periodic_sector(size: float = 2.0, angle_deg: float = 30.0) -> tuple[np.ndarray, np.ndarray]:
    """A sector of an annulus (radii 8 and 20, height 8) whose two cut faces are meshed alike
    (gmsh periodic meshing): face B (at ``angle_deg``) is face A (y = 0) turned about z."""
    import gmsh

    a = math.radians(angle_deg)
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        outer = occ.addCylinder(0, 0, 0, 0, 0, 8, 20, angle=a)
        inner = occ.addCylinder(0, 0, -1, 0, 0, 10, 8, angle=a)
        occ.cut([(3, outer)], [(3, inner)])
        occ.synchronize()
        fa = fb = None
        for _, tag in gmsh.model.getEntities(2):
            c = occ.getCenterOfMass(2, tag)
            if abs(c[1]) < 1e-6:
                fa = tag
            elif abs(c[1] * math.cos(a) - c[0] * math.sin(a)) < 1e-6:
                fb = tag
        R = [math.cos(a), -math.sin(a), 0, 0, math.sin(a), math.cos(a), 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
        gmsh.model.mesh.setPeriodic(2, [fb], [fa], R)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        return _arrays(gmsh)
    finally:
        gmsh.finalize()


def two_blocks(size_low: float = 3.0, size_high: float = 2.3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two 40 x 20 x 10 blocks stacked at z = 10, meshed independently (non-matching interface).

    Returns ``(V, T, body)`` with ``body`` (n,) 0 for the lower block's nodes, 1 for the upper's.
    """
    import gmsh

    parts = []
    for z0, size in ((0.0, size_low), (10.0, size_high)):
        gmsh.initialize()
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.model.occ.addBox(0, 0, z0, 40, 20, 10)
            gmsh.model.occ.synchronize()
            gmsh.option.setNumber("Mesh.MeshSizeMax", size)
            gmsh.model.mesh.generate(3)
            parts.append(_arrays(gmsh))
        finally:
            gmsh.finalize()
    (V1, T1), (V2, T2) = parts
    V = np.vstack([V1, V2])
    T = np.vstack([T1, T2 + len(V1)])
    body = np.r_[np.zeros(len(V1), np.int64), np.ones(len(V2), np.int64)]
    return V, T, body


def sheet_panel(path, size: float) -> int:
    """A 100 x 50 plate face with two holes of radius 8, meshed in triangles, written to ``path`` (.msh).

    Returns the number of gmsh's line elements on its curves (the outer rim and
    the holes' edges), which are the sheet's open boundary edges.
    """
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        plate = occ.addRectangle(0, 0, 0, 100, 50)
        holes = [occ.addDisk(30, 25, 0, 8, 8), occ.addDisk(70, 25, 0, 8, 8)]
        occ.cut([(2, plate)], [(2, h) for h in holes])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(2)
        rim_lines = sum(len(gmsh.model.mesh.getElements(1, t)[1][0]) for _, t in gmsh.model.getEntities(1))
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return rim_lines


def block_with_faces(path, size: float = 4.0, order: int = 1) -> None:
    """A 40 x 20 x 10 block meshed in tets, with physical surfaces FIXED (x = 0) and LOAD (x = 40) and a
    physical volume SOLID, written to ``path`` (.msh 4.1): the layout of a Gmsh deck for a solver."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        box = occ.addBox(0, 0, 0, 40, 20, 10)
        occ.synchronize()
        faces = {}
        for dim, tag in gmsh.model.getBoundary([(3, box)], oriented=False):
            x = gmsh.model.occ.getCenterOfMass(dim, tag)[0]
            if abs(x) < 1e-9:
                faces["FIXED"] = tag
            elif abs(x - 40) < 1e-9:
                faces["LOAD"] = tag
        for name, tag in faces.items():
            gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, [tag]), name)
        gmsh.model.setPhysicalName(3, gmsh.model.addPhysicalGroup(3, [box]), "SOLID")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def filleted_bracket(path, size: float = 3.0, order: int = 1, radius: float = 5.0) -> None:
    """An L-shaped bracket with a filleted inner corner, written to ``path`` (.msh 4.1).

    In the xy profile: a horizontal flange 60 x 6 (y from 0 to 6) and a vertical one 6 x 50 (x from 0
    to 6), extruded 20 along z. The inner corner has a fillet of ``radius`` about the axis
    x = y = 6 + radius, the outer corner a fillet of 6 + ``radius`` about the same axis. A bore of
    radius 3 runs along x through the vertical flange at y = 35, z = 10. Physical surfaces: FIXED
    (x = 60), LOAD (y = 50), FILLET and OUTER_FILLET, INNER_H (y = 6), INNER_V (x = 6), OUTER_H
    (y = 0), OUTER_V (x = 0), BORE; physical volume SOLID.
    """
    import gmsh

    t, length, height, width = 6.0, 60.0, 50.0, 20.0
    c = t + radius
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        xy = [(c, 0), (length, 0), (length, t), (c, t), (t, c), (t, height), (0, height), (0, c)]
        pts = [occ.addPoint(x, y, 0) for x, y in xy]
        center = occ.addPoint(c, c, 0)
        curves = [occ.addLine(pts[0], pts[1]), occ.addLine(pts[1], pts[2]), occ.addLine(pts[2], pts[3]),
                  occ.addCircleArc(pts[3], center, pts[4]), occ.addLine(pts[4], pts[5]),
                  occ.addLine(pts[5], pts[6]), occ.addLine(pts[6], pts[7]), occ.addCircleArc(pts[7], center, pts[0])]
        face = occ.addPlaneSurface([occ.addCurveLoop(curves)])
        solid = [tag for dim, tag in occ.extrude([(2, face)], 0, 0, width) if dim == 3][0]
        bore = occ.addCylinder(-1, 35, width / 2, t + 2, 0, 0, 3.0)
        occ.cut([(3, solid)], [(3, bore)])
        occ.synchronize()
        groups: dict[str, list[int]] = {k: [] for k in ("FIXED", "LOAD", "FILLET", "OUTER_FILLET", "INNER_H",
                                                        "INNER_V", "OUTER_H", "OUTER_V", "BORE")}
        for dim, tag in gmsh.model.getEntities(2):
            x, y, z = occ.getCenterOfMass(dim, tag)
            r = math.hypot(x - c, y - c)
            if abs(x - length) < 1e-6:
                groups["FIXED"].append(tag)
            elif abs(y - height) < 1e-6:
                groups["LOAD"].append(tag)
            elif abs(y - t) < 1e-6:
                groups["INNER_H"].append(tag)
            elif abs(x - t) < 1e-6:
                groups["INNER_V"].append(tag)
            elif abs(y) < 1e-6:
                groups["OUTER_H"].append(tag)
            elif abs(x) < 1e-6:
                groups["OUTER_V"].append(tag)
            elif x < c and y < c and 0.1 < z < width - 0.1 and r < radius:
                groups["FILLET"].append(tag)
            elif x < c and y < c and 0.1 < z < width - 0.1:
                groups["OUTER_FILLET"].append(tag)
            elif 0.1 < z < width - 0.1:
                groups["BORE"].append(tag)
        for name, tags in groups.items():
            gmsh.model.addPhysicalGroup(2, tags, name=name)
        gmsh.model.addPhysicalGroup(3, [tag for _, tag in gmsh.model.getEntities(3)], name="SOLID")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def cube_with_core(path, size: float = 4.0) -> None:
    """A 40 mm cube with an inner cylinder (radius 6, z 12..28, about x = y = 20) meshed conformingly
    with it, written to ``path`` as an Abaqus deck with node sets SKIN (the six faces) and CORE (every
    node of the cylinder, its inside included): a morph the boundary never shows."""
    import gmsh
    import meshio

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        box = occ.addBox(0, 0, 0, 40, 40, 40)
        core = occ.addCylinder(20, 20, 12, 0, 0, 16, 6)
        occ.fragment([(3, box)], [(3, core)])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
        V, T = _arrays(gmsh)
    finally:
        gmsh.finalize()
    eps = 1e-6
    skin = np.flatnonzero(((V < eps) | (V > 40 - eps)).any(axis=1))
    r = np.hypot(V[:, 0] - 20, V[:, 1] - 20)
    inside = np.flatnonzero((r < 6 + eps) & (V[:, 2] > 12 - eps) & (V[:, 2] < 28 + eps))
    meshio.write(str(path), meshio.Mesh(V, [("tetra", T)], point_sets={"SKIN": skin, "CORE": inside}),
                 file_format="abaqus")
