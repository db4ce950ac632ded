"""The radius edit proved in a solver: a plate with a hole in tension, its hole resized, run in CalculiX.

A 100 x 40 x 4 mm plate with a central through hole of radius 6 mm is meshed once by gmsh (linear
tets, refined at the hole) and written as an Abaqus deck. tetmorph's ``radius`` edit (SPEC entry
plus MOVE value) sets the hole's radius to each of :data:`RADII`; each morphed deck, with steel, a
uniform traction on the end x = 100 and the end x = 0 held in x, runs in ``ccx``. Everything is
checked from what the morphed decks hold and what ccx wrote, parsed here, not from tetmorph's
REPORT.

What the theory says (Howland 1930, Peterson's charts; Heywood's fit ``Kt_net = 2 + (1 - d/W)^3``):
in a finite-width plate in tension, the peak hoop stress at the hole's edge, at 90 degrees from
the load, referred to the gross stress, rises as the hole grows relative to the width (3.14 at
d/W = 0.2 to 3.69 at d/W = 0.4), while the factor referred to the net-section stress
``F / ((W - d) t)`` falls (2.51 to 2.22). The test expects both, strictly, over the five radii, and
the net-section factor within a band around Heywood's values (see :data:`BAND`). Two variants are
checked against the plate meshed afresh by gmsh at their radius: the edit makes the part it names.
The same edit on the plate meshed in tet10 (C3D10) puts the hole's mid-side nodes on the new
cylinder too.

The edit holds the two ends and the two long sides (y = 0 and y = W) fixed. With the ends alone
held, the morph pushes the free sides outward with the hole (about 3 mm at r = 8): the width grows
with the radius, and ccx's peak then falls with r, the variant no longer the plate of the theory.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from solver import precompute, read_mesh, write_mesh
from tests.solver.constraints.test_daily_edits import about, turn
from tests.solver.io.test_calculix import complaints, dat_block, node_lines_differ, run_ccx

pytestmark = pytest.mark.ccx  # runs CalculiX: make test, not make check

#: Plate length, width, thickness, rest hole radius (mm), and the hole's centre.
L, W, THICK, R0 = 100.0, 40.0, 4.0, 6.0
CENTRE = np.array([50.0, 20.0, 0.0])
Z = np.array([0.0, 0.0, 1.0])
#: The five radii (mm) the edit sets: d / W from 0.2 to 0.4.
RADII = (4.0, 5.0, 6.0, 7.0, 8.0)
#: The gross traction on the end x = L (MPa) and the force it makes (N).
SIGMA = 100.0
FORCE = SIGMA * W * THICK
#: Element sizes (mm) at the hole and far from it: about 12,000 tets, each ccx run under a second.
FINE, COARSE = 0.6, 4.0
#: The peak's net-section factor over Heywood's, allowed. Measured on this mesh: 1.08 (r = 8) to
#: 1.14 (r = 4). Above 1, as we read it: the stress at mid-thickness of a 4 mm plate exceeds the
#: plane-stress value by a few percent (a 3D effect, nu = 0.3), and a tet4's constant stress in the
#: small elements at the edge overshoots a little (the same plate meshed at 0.3 mm instead: 3% lower at r = 6). A
#: factor under 1 or over 1.25 would be a wrong load, support or geometry, not the mesh.
BAND = (1.0, 1.25)
#: What a morphed variant's peak may differ from a fresh gmsh mesh of the same radius (measured: 3.5%).
REMESH_TOL = 0.06


def heywood(r: float) -> float:
    """Heywood's net-section stress-concentration factor of a central hole of radius ``r`` in width W."""
    return 2.0 + (1.0 - 2.0 * r / W) ** 3


def plate_with_hole(path: Path, radius: float = R0, order: int = 1) -> None:
    """The plate meshed by gmsh (OCC), refined toward the hole, written to ``path`` (.msh): physical
    surfaces FIXED (x = 0), LOAD (x = L), SIDES (y = 0 and y = W), HOLE, and the volume SOLID."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        box = occ.addBox(0, 0, 0, L, W, THICK)
        cyl = occ.addCylinder(CENTRE[0], CENTRE[1], -1, 0, 0, THICK + 2, radius)
        occ.cut([(3, box)], [(3, cyl)])
        occ.synchronize()
        groups: dict[str, list[int]] = {"FIXED": [], "LOAD": [], "SIDES": [], "HOLE": []}
        for dim, tag in gmsh.model.getEntities(2):
            x, y, z = occ.getCenterOfMass(dim, tag)
            if abs(x) < 1e-6:
                groups["FIXED"].append(tag)
            elif abs(x - L) < 1e-6:
                groups["LOAD"].append(tag)
            elif abs(y) < 1e-6 or abs(y - W) < 1e-6:
                groups["SIDES"].append(tag)
            elif math.hypot(x - CENTRE[0], y - CENTRE[1]) < 1.5 * radius and 0.1 < z < THICK - 0.1:
                groups["HOLE"].append(tag)
        for name, tags in groups.items():
            gmsh.model.addPhysicalGroup(2, tags, name=name)
        gmsh.model.addPhysicalGroup(3, [t for _, t in gmsh.model.getEntities(3)], name="SOLID")
        field = gmsh.model.mesh.field
        dist = field.add("Distance")
        field.setNumbers(dist, "SurfacesList", groups["HOLE"])
        size = field.add("Threshold")
        field.setNumber(size, "InField", dist)
        for key, value in (("SizeMin", FINE), ("SizeMax", COARSE), ("DistMin", 0.5), ("DistMax", 20.0)):
            field.setNumber(size, key, value)
        field.setAsBackgroundMesh(size)
        for option in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
            gmsh.option.setNumber(f"Mesh.{option}", 0)
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def rest_deck(folder: Path, radius: float = R0, order: int = 1) -> Path:
    """The gmsh plate converted to an Abaqus deck (node sets from the physical surfaces)."""
    plate_with_hole(folder / "plate.msh", radius, order)
    deck = folder / "plate.inp"
    mesh = read_mesh(folder / "plate.msh")
    write_mesh(mesh, mesh.V, deck)
    return deck


def spec() -> dict:
    """The hole's radius edit; the ends and the long sides held (see the module's docstring)."""
    return {"selections": {"fixed": {"set": "FIXED"}, "load": {"set": "LOAD"}, "sides": {"set": "SIDES"},
                           "hole": {"set": "HOLE"}},
            "fixed": ["fixed", "load", "sides"], "precision": "exact",
            "radius": [{"name": "hole", "selection": "hole",
                        "axis": {"point": CENTRE.tolist(), "direction": Z.tolist()}}]}


def deck_nodes(deck: Path) -> tuple[np.ndarray, np.ndarray]:
    """Labels and coordinates of the deck's ``*NODE`` lines, in file order, parsed here."""
    rows, inside = [], False
    for ln in deck.read_text().splitlines():
        if ln.startswith("*"):
            inside = ln.upper().startswith("*NODE") and not ln.upper().startswith(("*NODE PRINT", "*NODE FILE"))
            continue
        if inside and ln.strip():
            rows.append([float(v) for v in ln.split(",")])
    a = np.array(rows)
    return a[:, 0].astype(np.int64), a[:, 1:4]


def faces(T: np.ndarray) -> np.ndarray:
    """The boundary faces of tets ``T`` (corner triples that belong to one tet only); for tet10 rows, each face's
    three corners and then its three mid-side nodes (C3D10 order: edges 01, 12, 20, 03, 13, 23)."""
    local = [(0, 1, 2, 4, 5, 6), (0, 1, 3, 4, 8, 7), (1, 2, 3, 5, 9, 8), (0, 2, 3, 6, 9, 7)]
    k = 3 if T.shape[1] == 4 else 6
    F = np.vstack([T[:, f[:k]] for f in local])
    _, inv, count = np.unique(np.sort(F[:, :3], axis=1), axis=0, return_inverse=True, return_counts=True)
    return F[count[inv.ravel()] == 1]


def hole_faces(T: np.ndarray, V: np.ndarray, radius: float) -> np.ndarray:
    """Boundary faces whose corners all lie on the hole's cylinder (to 1e-9 mm)."""
    F = faces(T)
    _, rad, _ = about(V[F[:, :3].ravel()], CENTRE, Z)
    return F[(np.abs(rad - radius) < 1e-9).reshape(-1, 3).all(axis=1)]


def signed_volumes(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Six times each tet's signed volume (corners 0-3)."""
    a, b, c, d = (V[T[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)


def analysis(labels: np.ndarray, V: np.ndarray, T: np.ndarray) -> str:
    """Steel, the supports, the end traction as nodal forces, a static step printing element stresses.

    x = 0 held in x; the corner (0, 0, 0) held in y and z and the corner (0, W, 0) in z (no more than
    rigid motion: the plate contracts freely). The traction on x = L: each end triangle's share
    ``SIGMA * area / 3`` at each of its corners, the consistent load of a uniform traction on tet4 faces.
    """
    end = faces(T)
    end = end[(np.abs(V[end, 0] - L) < 1e-9).all(axis=1)]
    area = 0.5 * np.linalg.norm(np.cross(V[end[:, 1]] - V[end[:, 0]], V[end[:, 2]] - V[end[:, 0]]), axis=1)
    assert area.sum() == pytest.approx(W * THICK, rel=1e-12)
    force = np.zeros(len(V))
    for k in range(3):
        np.add.at(force, end[:, k], SIGMA * area / 3.0)
    a, b = (int(np.argmin(np.linalg.norm(V - p, axis=1))) for p in ([0, 0, 0], [0, W, 0]))
    assert np.abs(V[a]).max() == 0.0 and np.abs(V[b] - [0, W, 0]).max() == 0.0
    loads = "".join(f"{labels[i]}, 1, {float(force[i])!r}\n" for i in np.flatnonzero(force))
    return ("*MATERIAL, NAME=STEEL\n*ELASTIC\n210000, 0.3\n*SOLID SECTION, ELSET=SOLID, MATERIAL=STEEL\n"
            f"*STEP\n*STATIC\n*BOUNDARY\nFIXED, 1, 1\n{labels[a]}, 2, 3\n{labels[b]}, 3, 3\n*CLOAD\n{loads}"
            "*EL PRINT, ELSET=SOLID\nS\n*END STEP\n")


def element_labels(deck: Path) -> np.ndarray:
    """Labels of the deck's element lines, in file order."""
    text = deck.read_text()
    block = text[text.upper().index("*ELEMENT"):].split("\n*", 1)[0].splitlines()[1:]
    return np.array([int(ln.split(",")[0]) for ln in block if ln.strip()])


def solve(deck: Path, T: np.ndarray, radius: float) -> dict:
    """Run ccx on ``deck`` (with the analysis added) and read its peak hoop stress at the hole's edge."""
    labels, V = deck_nodes(deck)
    run = deck.with_name(deck.stem + "_run.inp")
    run.write_text(deck.read_text() + analysis(labels, V, T))
    text, dat = run_ccx(run)
    assert complaints(text) == [], complaints(text)[:5]
    S = dat_block(dat, "stresses")  # element, integration point, sxx, syy, szz, sxy, sxz, syz
    row = {int(e): k for k, e in enumerate(element_labels(deck))}
    el = np.array([row[int(e)] for e in S[:, 0]])
    # the elements with a face on the hole: their stress (one integration point) turned to hoop
    edge = np.zeros(len(V), bool)
    edge[np.unique(hole_faces(T, V, radius)[:, :3])] = True
    at_edge = edge[T[el]].sum(axis=1) >= 3
    centroid = V[T[el]].mean(axis=1)
    theta = np.arctan2(centroid[:, 1] - CENTRE[1], centroid[:, 0] - CENTRE[0])
    s, c = np.sin(theta), np.cos(theta)
    hoop = s * s * S[:, 2] + c * c * S[:, 3] - 2 * s * c * S[:, 5]
    k = int(np.argmax(np.where(at_edge, hoop, -np.inf)))
    net = FORCE / ((W - 2 * radius) * THICK)
    return {"r": radius, "peak": float(hoop[k]), "angle_deg": math.degrees(theta[k]), "net": net,
            "ratio": float(hoop[k]) / net, "edge_elements": int(at_edge.sum())}


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    """The rest deck, and for each radius: the morphed deck, its positions as written, and ccx's peak."""
    folder = tmp_path_factory.mktemp("hole")
    rest = rest_deck(folder)
    mesh = read_mesh(rest)
    _, V0 = deck_nodes(rest)
    np.testing.assert_array_equal(V0, mesh.V)  # the deck's node lines are the mesh's rows, in order
    d = precompute(mesh, spec())
    assert d.data.constraints.edits[0].nominal == pytest.approx(R0, rel=1e-12)
    out = []
    for r in RADII:
        deck = folder / f"hole_r{r:g}.inp"
        write_mesh(mesh, d.solve({"radius": {"hole": {"radius": r}}}).V, deck)
        out.append({"deck": deck, "V": deck_nodes(deck)[1], **solve(deck, mesh.T, r)})
    return {"rest": rest, "mesh": mesh, "V0": V0, "runs": out}


def test_every_hole_node_is_on_the_new_radius_with_its_height_and_angle_kept(variants):
    mesh, V0 = variants["mesh"], variants["V0"]
    hole = mesh.sets["HOLE"]
    assert hole.size > 400
    s0, r0, a0 = about(V0[hole], CENTRE, Z)
    assert np.abs(r0 - R0).max() <= 1e-9  # gmsh put them on the cylinder
    held = np.concatenate([mesh.sets[k] for k in ("FIXED", "LOAD", "SIDES")])
    for run in variants["runs"]:
        r, V = run["r"], run["V"]  # the positions in the deck ccx reads
        s, rad, ang = about(V[hole], CENTRE, Z)
        assert np.abs(rad - r).max() <= 1e-12 * r, (r, np.abs(rad - r).max())
        assert np.abs(s - s0).max() <= 1e-12 * THICK and np.abs(turn(a0, ang)).max() <= 1e-12
        np.testing.assert_array_equal(V[held], V0[held])
        for z in (0.0, THICK):  # the faces stay flat: the plate keeps its thickness
            on = np.abs(V0[:, 2] - z) < 1e-9
            assert np.abs(V[on, 2] - z).max() <= 1e-12 * THICK
        assert node_lines_differ(variants["rest"], run["deck"]) <= {"*NODE"}  # only coordinates change
        if r == R0:  # the rest radius: the rest shape, to the round-off of gmsh's nodes on the cylinder
            assert np.abs(V - V0).max() <= 1e-12 * L


def test_no_morphed_element_is_inverted(variants):
    tets = variants["mesh"].T
    rest = signed_volumes(variants["V0"], tets)
    assert (rest > 0).all()
    for run in variants["runs"]:
        vol = signed_volumes(run["V"], tets)
        assert (vol > 0).all(), (run["r"], int((vol <= 0).sum()))
        assert vol.sum() / 6 == pytest.approx(L * W * THICK - math.pi * run["r"] ** 2 * THICK, rel=2e-3)


def test_the_peak_rises_with_the_radius_and_the_net_section_factor_falls(variants):
    """Peterson/Howland: the peak at the hole's edge rises with d/W; the net-section factor falls."""
    runs = variants["runs"]
    peak = np.array([run["peak"] for run in runs])
    ratio = np.array([run["ratio"] for run in runs])
    table = [(run["r"], round(run["peak"], 1), round(run["net"], 1), round(run["ratio"], 3)) for run in runs]
    print("\nr mm | peak hoop MPa | net-section MPa | peak / net:", *table, sep="\n")  # pytest -s shows it
    assert (np.diff(peak) > 0).all(), table
    assert (np.diff(ratio) < 0).all(), table
    factor = ratio / np.array([heywood(r) for r in RADII])
    assert ((BAND[0] <= factor) & (factor <= BAND[1])).all(), (table, factor)
    for run in runs:  # the peak sits at the edge across the load (90 degrees), where theory puts it
        assert abs(abs(run["angle_deg"]) - 90.0) <= 10.0, run
        assert run["edge_elements"] > 300


def test_a_morphed_variant_has_the_peak_of_the_plate_meshed_afresh_at_its_radius(variants, tmp_path):
    """The edit gives the part of that radius: ccx's peak on a fresh gmsh mesh of it agrees."""
    for run in (variants["runs"][0], variants["runs"][-1]):
        folder = tmp_path / f"r{run['r']:g}"
        folder.mkdir()
        deck = rest_deck(folder, run["r"])
        fresh = solve(deck, read_mesh(deck).T, run["r"])
        assert fresh["peak"] == pytest.approx(run["peak"], rel=REMESH_TOL), (fresh, run)


def test_a_tet10_deck_keeps_its_mid_side_nodes_on_the_new_cylinder(tmp_path):
    deck = rest_deck(tmp_path, order=2)
    mesh = read_mesh(deck)
    assert mesh.T10 is not None and re.search(r"TYPE=C3D10", deck.read_text())
    _, V0 = deck_nodes(deck)
    np.testing.assert_array_equal(V0, mesh.V)
    F = hole_faces(mesh.T10, V0, R0)  # found here: the boundary faces on the hole, with their mid-side nodes
    corners, mids = np.unique(F[:, :3]), np.unique(F[:, 3:])
    assert F.shape[1] == 6 and mids.size > 400 and not np.isin(mids, corners).any()
    _, r_mid, _ = about(V0[mids], CENTRE, Z)
    assert np.abs(r_mid - R0).max() <= 1e-12 * R0  # gmsh placed them on the cylinder
    nodes = np.union1d(corners, mids)
    s0, _, a0 = about(V0[nodes], CENTRE, Z)
    d = precompute(mesh, spec())
    for r in RADII:
        out = tmp_path / f"hole_r{r:g}.inp"
        write_mesh(mesh, d.solve({"radius": {"hole": {"radius": r}}}).V, out)
        _, V = deck_nodes(out)
        s, rad, ang = about(V[nodes], CENTRE, Z)
        assert np.abs(rad - r).max() <= 1e-12 * r, (r, np.abs(rad - r).max())
        assert np.abs(s - s0).max() <= 1e-12 * THICK and np.abs(turn(a0, ang)).max() <= 1e-12
        assert (signed_volumes(V, mesh.T10) > 0).all()
