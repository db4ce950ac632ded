"""Round trips across formats: read A, write B, read back (with meshio, and Gmsh for .msh).

For every pair the written file is checked on its own terms: point count and
coordinates, cell types and counts, and the named sets and regions. A pair
whose target cannot hold something is refused with a typed error naming it;
``lossy=True`` writes the rest and lists what was dropped.
"""

from __future__ import annotations

import re

import meshio
import numpy as np
import pytest

from solver import read_mesh, write_mesh
from solver.errors import LossyWriteError
from solver.io.content import VOLUME
from tests.conftest import DATA, shared_file

SOURCES = {
    "bracket.inp": lambda: DATA / "bracket.inp",  # C3D4 + CPS3, NSET and ELSET
    "segmenttet.inp": lambda: shared_file("tet/segmenttet.inp"),  # C3D10, NSETs Nleft/Nright, ELSET Eall
    "mixed.msh": lambda: DATA / "mixed.msh",  # hex, tet, pyramid, wedge; physical groups
    "cube_cylinder.mesh": lambda: shared_file("tet/cube_cylinder.mesh"),  # two medit:ref regions
    "beam.node": lambda: DATA / "beam.node",  # TetGen
    "bar_small.bdf": lambda: DATA / "bar_small.bdf",  # Nastran: CTETRA PID 1, CTRIA3 PID 2
    "wheelset.vtk": lambda: DATA / "wheelset.vtk",  # cell data mat_id, point data node_groups
}
TARGETS = ["inp", "msh", "vtu", "vtk", "mesh", "node", "bdf"]
#: Cell types each target holds (what the test expects, from the formats' specifications).
HOLDS = {
    "inp": {"tetra", "tetra10", "hexahedron", "wedge", "triangle", "quad", "line"},
    "msh": {"tetra", "tetra10", "hexahedron", "wedge", "pyramid", "triangle", "quad", "line", "vertex"},
    "vtu": {"tetra", "tetra10", "hexahedron", "wedge", "pyramid", "triangle", "quad", "line"},
    "vtk": {"tetra", "tetra10", "hexahedron", "wedge", "pyramid", "triangle", "quad", "line"},
    "mesh": {"tetra", "hexahedron", "wedge", "pyramid", "triangle", "quad", "line"},
    "node": {"tetra"},
    "bdf": {"tetra", "tetra10", "hexahedron", "wedge", "pyramid", "triangle", "quad"},
}
#: Targets that keep set names.
NAMED = {"inp", "msh", "vtu", "vtk"}
#: Region labels each target keeps values of (without names).
LABEL_KEY = {"mesh": "medit:ref", "node": "tetgen:ref", "bdf": "nastran:ref"}


def _geometry(src: meshio.Mesh) -> np.ndarray:
    """New positions: a smooth shear of the file's points (independent of the solver)."""
    P = np.asarray(src.points, dtype=np.float64)
    lo, hi = P.min(0), P.max(0)
    s = (P[:, 0] - lo[0]) / max(hi[0] - lo[0], 1e-300)
    out = P.copy()
    out[:, 2] += 0.05 * (hi[2] - lo[2]) * s**2
    return out


def _read(path) -> meshio.Mesh:
    """The written file read by another program: Gmsh for .msh (meshio 5.3 cannot read Gmsh 2.2
    element data next to several cell types), meshio for the rest."""
    if str(path).endswith(".msh"):
        import gmsh
        from meshio.gmsh.common import _gmsh_to_meshio_type

        gmsh.initialize()
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.open(str(path))
            tags, xyz, _ = gmsh.model.mesh.getNodes()
            P = np.empty((len(tags), 3))
            P[tags.astype(int) - 1] = xyz.reshape(-1, 3)
            types, _, nodes = gmsh.model.mesh.getElements()
            cells = [(_gmsh_to_meshio_type[int(t)], np.asarray(n, int).reshape(-1, gmsh.model.mesh.getElementProperties(
                int(t))[3]) - 1) for t, n in zip(types, nodes, strict=True)]
        finally:
            gmsh.finalize()
        return meshio.Mesh(P, cells)
    return meshio.read(path)


def _counts(m: meshio.Mesh) -> dict[str, int]:
    out: dict[str, int] = {}
    for c in m.cells:
        out[c.type] = out.get(c.type, 0) + len(c.data)
    return out


def _named(src_path) -> set[str]:
    """The names a file gives its sets, read with meshio (node sets, element sets, physical names)."""
    m = meshio.read(src_path)
    names = set(m.point_sets) | {k for k in m.cell_sets if not k.startswith("gmsh:")}
    names |= set(m.field_data) if "gmsh:physical" in m.cell_data else set()
    return names


@pytest.mark.slow
@pytest.mark.parametrize("target", TARGETS)
@pytest.mark.parametrize("source", list(SOURCES))
def test_round_trip(source, target, tmp_path):
    path = SOURCES[source]()
    src = meshio.read(path)
    mesh = read_mesh(path)
    P = _geometry(src)
    out = tmp_path / f"out.{target}"
    src_types = _counts(src)
    lost_types = {t for t in src_types if t not in HOLDS[target] and not (t == "tetra10" and "tetra" in HOLDS[target])}
    quadratic_lost = "tetra10" in src_types and "tetra10" not in HOLDS[target]
    names = _named(path)
    data_arrays = {k for k in src.point_data if not k.startswith(("gmsh:", "medit:", "tetgen:", "nastran:"))}
    data_arrays |= {k for k in src.cell_data if not k.startswith(("gmsh:", "medit:", "tetgen:", "nastran:"))
                    and k not in ("mat_id",)}
    same_format = path.suffix.lower().lstrip(".") == target
    # a deck of volume elements holds named faces as node sets, never as CPS3/T3D2 elements of the model
    faces_as_sets = target == "inp" and not same_format and any(t in VOLUME for t in src_types)
    expect_loss = not same_format and bool(
        lost_types or quadratic_lost or (names and target not in NAMED)
        or (data_arrays and target not in ("vtu", "vtk", "msh")))
    if expect_loss:
        with pytest.raises(LossyWriteError) as e:
            write_mesh(mesh, P, out)
        assert not out.exists()
        lost = {d["name"] for d in e.value.details["losses"]}
        assert lost_types <= lost and (not quadratic_lost or "tetra10" in lost)
        if target not in NAMED:
            assert names <= lost, names - lost
        assert "Nothing was written" in e.value.message and "lossy=True" in e.value.message
        w = write_mesh(mesh, P, out, lossy=True)
        assert {d["name"] for d in w.dropped} == lost
    else:
        w = write_mesh(mesh, P, out)
        assert w.dropped == []
    back = _read(out)
    # coordinates: every point written, at its new position
    assert len(back.points) == len(P)
    tol = (1e-6 if same_format else 1e-9) if target == "bdf" else 1e-12  # bar_small: 8-column fields
    scale = np.abs(P).max()
    np.testing.assert_allclose(np.asarray(back.points, float)[:, : P.shape[1]], P, rtol=0, atol=tol * scale)
    # cells: every element of a type the target holds, corners of quadratic tets where it holds only linear
    expected = {("tetra" if t == "tetra10" and quadratic_lost else t): n for t, n in src_types.items()
                if t not in lost_types and t != "vertex" and n and not (faces_as_sets and t not in VOLUME)}
    got = {t: n for t, n in _counts(back).items() if t != "vertex" and n}
    assert got == expected
    if lost_types or quadratic_lost and target != "node":
        return  # the mesh without those elements may not be a valid body to read back
    again = read_mesh(out)
    if target in NAMED:  # every named set, and every region, by name and by content
        for k, ids in mesh.sets.items():
            name = w.renamed.get(k, k)
            if target == "inp":
                assert re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name), name
            assert name in again.sets, (k, name, sorted(again.sets))
            np.testing.assert_array_equal(again.sets[name], ids, err_msg=k)
    else:  # regions keep their values under the target's label
        regions = {k for k in mesh.sets if "=" in k and k.split("=")[0] in (
            "medit:ref", "CellEntityIds", "MaterialIds", "mat_id", "nastran:ref", "tetgen:ref")}
        for k in regions:
            name = f"{LABEL_KEY[target]}={k.split('=')[1]}"
            assert w.renamed.get(k, k) == name or k == name
            np.testing.assert_array_equal(again.sets[name], mesh.sets[k], err_msg=k)


def test_gmsh_reads_the_physical_groups_written_from_a_deck(tmp_path):
    """Gmsh itself sees the deck's node and element sets as physical groups of the right size."""
    import gmsh

    src = shared_file("tet/segmenttet.inp")
    mesh = read_mesh(src)
    out = tmp_path / "segment.msh"
    write_mesh(mesh, mesh.V, out)
    deck = meshio.read(src)
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(out))
        groups = {gmsh.model.getPhysicalName(d, t): (d, len(gmsh.model.mesh.getNodesForPhysicalGroup(d, t)[0]))
                  for d, t in gmsh.model.getPhysicalGroups()}
    finally:
        gmsh.finalize()
    assert groups == {"Nleft": (0, len(deck.point_sets["Nleft"])), "Nright": (0, len(deck.point_sets["Nright"])),
                      "Eall": (3, len(deck.points)), "Nall": (0, len(deck.points))}  # *Node,NSET=Nall


def test_msh_to_vtu_keeps_group_names_not_physical_numbers(tmp_path):
    mesh = read_mesh(DATA / "mixed.msh")
    out = tmp_path / "mixed.vtu"
    write_mesh(mesh, mesh.V, out)
    back = meshio.read(out)
    assert {k for k in back.cell_data if k.startswith("set:")} == {f"set:{k}" for k in
                                                                     ("FIXED", "LOAD", "HEX", "TET", "WEDGE")}
    assert not any(k.startswith("physical:") for k in read_mesh(out).sets)


def test_quadratic_deck_to_msh_is_gmsh_not_ansys(tmp_path):
    mesh = read_mesh(shared_file("tet/tractor_wheel_coarse.INP"))
    out = tmp_path / "o.msh"
    write_mesh(mesh, mesh.V, out)
    assert out.read_bytes().startswith(b"$MeshFormat")
    assert _counts(meshio.read(out))["tetra10"] == 11171


def test_medit_to_abaqus_keeps_material_refs_as_element_sets(tmp_path):
    mesh = read_mesh(shared_file("tet/cube_cylinder.mesh"))
    out = tmp_path / "cc.inp"
    w = write_mesh(mesh, mesh.V, out)
    deck = meshio.read(out)
    refs = np.asarray(meshio.read(shared_file("tet/cube_cylinder.mesh")).cell_data["medit:ref"][0])
    for v in (1, 2):
        name = w.renamed[f"medit:ref={v}"]
        assert sorted(deck.cell_sets[name][0].tolist()) == np.flatnonzero(refs == v).tolist()


def test_lossy_write_lists_what_was_dropped(tmp_path):
    mesh = read_mesh(shared_file("tet/segmenttet.inp"))
    with pytest.raises(LossyWriteError) as e:
        write_mesh(mesh, mesh.V, tmp_path / "s.mesh")
    msg = e.value.message
    for words in ("tetra10", "Nleft", "Nright", "Eall", "no set names", "linear tetrahedra"):
        assert words in msg, words
    w = write_mesh(mesh, mesh.V, tmp_path / "s.mesh", lossy=True)
    assert {(d["kind"], d["name"]) for d in w.dropped} == {
        ("quadratic_nodes", "tetra10"), ("set_names", "Eall"),  # overlapping node sets (Nall holds every node
        ("node_set", "Nleft"), ("node_set", "Nright"), ("node_set", "Nall")}  # since *Node,NSET= is read): no refs
    back = meshio.read(tmp_path / "s.mesh")
    assert _counts(back) == {"tetra": 1489}  # the corners of every element, not an empty file


def _deck_blocks(text: str) -> tuple[list[str], dict[str, set[int]]]:
    """Element types and node sets of an Abaqus deck, read here line by line (1-based node numbers)."""
    types, nsets, current = [], {}, None
    for line in text.splitlines():
        head = line.strip().upper()
        if head.startswith("*"):
            current = None
            if head.startswith("*ELEMENT"):
                types.append(re.search(r"TYPE\s*=\s*(\w+)", head).group(1))
            elif head.startswith("*NSET"):
                current = re.search(r"NSET\s*=\s*([\w=-]+)", line, re.I).group(1)
                nsets[current] = set()
        elif current is not None and head:
            nsets[current] |= {int(v) for v in head.replace(",", " ").split()}
    return types, nsets


@pytest.mark.parametrize("order", [1, 2])
def test_gmsh_surface_groups_become_node_sets_of_a_deck_not_elements(tmp_path, order):
    from tests.gmsh_parts import block_with_faces

    src = tmp_path / "block.msh"
    block_with_faces(src, 5.0, order)
    m = meshio.read(src)
    face_type = "triangle" if order == 1 else "triangle6"
    w = write_mesh(read_mesh(src), np.asarray(m.points, float), tmp_path / "block.inp")
    assert w.dropped == []
    types, nsets = _deck_blocks((tmp_path / "block.inp").read_text())
    assert set(types) == {"C3D4" if order == 1 else "C3D10"}, types  # no CPS3 / CPE6 / T3D2 in the model
    for name in ("FIXED", "LOAD"):
        faces = np.asarray(m.cell_sets_dict[name][face_type], np.int64)  # meshio's own reading of the .msh
        want = set((np.unique(m.cells_dict[face_type][faces]) + 1).tolist())
        assert nsets[name] == want
    assert abs(np.asarray(m.points)[np.array(sorted(nsets["FIXED"])) - 1, 0]).max() < 1e-9
