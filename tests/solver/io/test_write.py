"""Same-format writes keep every byte but the coordinates of moved nodes (Nastran, TetGen, and
the Abaqus, Gmsh and VTU patchers), checked against the files with meshio."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from solver import read_mesh, write_mesh
from solver.errors import LossyWriteError
from tests.conftest import DATA, shared_file

DECKS = ["bar_small.bdf", "bar_large.bdf", "bar_free.bdf", "bar10_small.bdf"]


def _moved(V: np.ndarray) -> np.ndarray:
    """Nodes past mid-length bent down; some coordinates a tiny negative (meshio's writer fails on them)."""
    P = V.copy()
    far = P[:, 0] > 50
    P[far, 2] -= 0.01 * (P[far, 0] - 50) ** 1.5
    P[far & (np.abs(P[:, 1]) < 1e-9), 1] = -3.55e-15
    return P


def _cards(lines: list[bytes]) -> list[int]:
    """Indices of GRID card lines and their large-field continuations."""
    out = []
    for k, ln in enumerate(lines):
        if ln.startswith(b"GRID"):
            out.append(k)
            if ln.startswith(b"GRID*"):
                out.append(k + 1)
    return out


@pytest.mark.parametrize("name", DECKS)
def test_nastran_deck_keeps_everything_but_moved_grids(name, tmp_path):
    src = DATA / name
    mesh = read_mesh(src)
    P = _moved(mesh.V)
    out = tmp_path / "out.bdf"
    w = write_mesh(mesh, P, out)
    assert w.patched and w.dropped == []
    a, b = src.read_bytes().splitlines(), out.read_bytes().splitlines()
    assert len(a) == len(b)
    changed = {k for k, (x, y) in enumerate(zip(a, b, strict=True)) if x != y}
    grid_lines = set(_cards(a))
    assert changed and changed <= grid_lines  # SOL, CEND, MAT1, PSOLID, PSHELL, SPC1, FORCE, PARAM untouched
    for card in (b"SOL 101", b"CEND", b"MAT1", b"PSOLID", b"PSHELL", b"SPC1", b"FORCE", b"PARAM"):
        assert any(ln.startswith(card) for ln in b), card
    moved = np.flatnonzero((P != mesh.V).any(1))
    grids = [k for k in _cards(a) if a[k].startswith(b"GRID")]
    unmoved = np.setdiff1d(np.arange(mesh.n), moved)
    assert all(a[grids[i]] == b[grids[i]] for i in unmoved)  # unmoved nodes keep their text
    back = meshio.read(out)
    width = {"bar_large.bdf": 16, "bar_free.bdf": None}.get(name, 8)
    tol = 1e-12 if width is None else (1e-10 if width == 16 else 1e-4)
    np.testing.assert_allclose(back.points, P, rtol=0, atol=tol * 100)
    assert (back.points[P[:, 1] == -3.55e-15, 1] == -3.55e-15).all()
    if width == 8:  # small field: every field of a rewritten card sits in its 8 columns
        for k in changed:
            line = b[k].decode()
            assert len(line.rstrip()) <= 72 and line[:8] == a[k].decode()[:8] and line[8:24] == a[k].decode()[8:24]
    assert [c.type for c in back.cells] == [c.type for c in meshio.read(src).cells]


@pytest.mark.parametrize("name", ["bar_small.bdf", "bracket.inp", "mixed.msh", "beam.node"])
def test_unmoved_write_is_byte_identical(name, tmp_path):
    mesh = read_mesh(DATA / name)
    out = tmp_path / f"out.{name.rsplit('.', 1)[1]}"
    assert write_mesh(mesh, mesh.V, out).patched
    assert out.read_bytes() == (DATA / name).read_bytes()


def test_ascii_vtu_keeps_the_text_of_unmoved_points(tmp_path):
    src = tmp_path / "bracket.vtu"
    meshio.write(src, meshio.read(DATA / "bracket.inp"), binary=False)
    mesh = read_mesh(src)
    P = mesh.V.copy()
    P[0] += 1.0
    out = tmp_path / "out.vtu"
    write_mesh(mesh, P, out)
    a, b = src.read_bytes(), out.read_bytes()
    assert len(set(a.split()) ^ set(b.split())) <= 6  # only node 0's three values differ
    np.testing.assert_array_equal(meshio.read(out).points, P)


def test_tetgen_keeps_its_numbering_comments_and_ele(tmp_path):
    mesh = read_mesh(DATA / "beam.node")
    P = mesh.V.copy()
    P[P[:, 1] > 0.5, 0] += 0.125
    out = tmp_path / "bent.node"
    w = write_mesh(mesh, P, out)
    assert w.patched and sorted(w.files) == sorted([str(out), str(tmp_path / "bent.ele")])
    assert (tmp_path / "bent.ele").read_bytes() == (DATA / "beam.ele").read_bytes()
    a, b = (DATA / "beam.node").read_text().splitlines(), out.read_text().splitlines()
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        if x.startswith("#") or not x.strip():
            assert x == y  # comments and blank lines untouched
        else:
            assert x.split()[0] == y.split()[0]  # the file's own (1-based) node numbers
    assert a[4] == b[4]  # the header
    back = meshio.read(out)  # meshio reads the .node next to its .ele
    np.testing.assert_array_equal(back.points, P)
    np.testing.assert_array_equal(back.cells_dict["tetra"], mesh.T)
    # written to .ele, the same pair is written
    w2 = write_mesh(mesh, P, tmp_path / "other.ele")
    assert (tmp_path / "other.node").read_bytes() == out.read_bytes()
    assert w2.patched


def test_nastran_from_another_format_writes_tiny_values(tmp_path):
    """meshio's writer fails on values like -3.55e-15; tetmorph writes them, and the deck reads back."""
    mesh = read_mesh(DATA / "bracket.inp")
    P = mesh.V.copy()
    P[P[:, 1] == 0, 1] = -3.55e-15
    out = tmp_path / "bracket.bdf"
    with pytest.raises(LossyWriteError):  # the deck's named sets have no place in bulk data
        write_mesh(mesh, P, out)
    assert not out.exists()
    w = write_mesh(mesh, P, out, lossy=True)
    assert {d["name"] for d in w.dropped} >= {"FIXED", "LOAD", "SOLID"}
    back = meshio.read(out)
    np.testing.assert_allclose(back.points, P, rtol=1e-14, atol=1e-13)
    assert (back.points[P[:, 1] == -3.55e-15, 1] == -3.55e-15).all()
    src = meshio.read(DATA / "bracket.inp")
    assert sorted((c.type, len(c.data)) for c in back.cells) == sorted(
        [("tetra", sum(len(c.data) for c in src.cells if c.type == "tetra")),
         ("triangle", sum(len(c.data) for c in src.cells if c.type == "triangle"))])


def test_features_written_into_a_deck_keep_the_deck(tmp_path):
    """Extra node sets go into a patched Abaqus deck before its first *STEP; the rest is kept."""
    deck = tmp_path / "deck.inp"
    deck.write_bytes((DATA / "bracket.inp").read_bytes() + b"*STEP\n*STATIC\n*END STEP\n")
    mesh = read_mesh(deck)
    out = tmp_path / "out.inp"
    w = write_mesh(mesh, mesh.V, out, point_sets={"HOLE rim": np.array([0, 1, 2])})
    assert w.patched
    text = out.read_text()
    assert text.replace("*NSET, NSET=HOLE_rim\n1, 2, 3\n", "") == deck.read_text()
    assert text.index("NSET=HOLE_rim") < text.index("*STEP")
    assert meshio.read(out).point_sets["HOLE_rim"].tolist() == [0, 1, 2]


GROUPED_OBJ = """# two groups of a tetrahedron's faces
v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
g bottom
f 1 3 2
f 1 2 4
g top
f 1 4 3
f 2 3 4
"""


def test_an_obj_keeps_its_face_groups_and_a_single_group_is_no_loss(tmp_path):
    src = tmp_path / "t.obj"
    src.write_text(GROUPED_OBJ)
    mesh = read_mesh(src)
    P = mesh.V + [0.5, 0.0, 0.25]
    w = write_mesh(mesh, P, tmp_path / "out.obj")
    assert w.dropped == []
    back, orig = meshio.read(tmp_path / "out.obj"), meshio.read(src)  # meshio numbers the groups by g line
    np.testing.assert_array_equal(back.points, P)
    np.testing.assert_array_equal(np.concatenate(back.cell_data["obj:group_ids"]),
                                  np.concatenate(orig.cell_data["obj:group_ids"]))
    np.testing.assert_array_equal(back.cells_dict["triangle"], orig.cells_dict["triangle"])
    plain = read_mesh(shared_file("surface/fandisk.obj"))  # no g line: one group, nothing to keep
    assert write_mesh(plain, plain.V, tmp_path / "fandisk.obj").dropped == []


def test_an_obj_with_texture_coordinates_per_corner_reads_and_says_what_it_left_out(tmp_path):
    spot = read_mesh(shared_file("surface/spot.obj"))
    info = spot.info()
    assert info["vertices"] == 2930 and info["dropped_on_read"] == ["3225 texture coordinates (vt)"]
    faces = [ln.split()[1:] for ln in shared_file("surface/spot.obj").read_text().splitlines() if ln.startswith("f ")]
    want = np.array([[int(c.split("/")[0]) - 1 for c in f] for f in faces])  # the file's faces, read here
    np.testing.assert_array_equal(spot.surface, want)
    write_mesh(spot, spot.V, tmp_path / "spot.obj")
    np.testing.assert_array_equal(meshio.read(tmp_path / "spot.obj").cells_dict["triangle"], want)


def test_an_stl_round_trip_writes_the_normals_of_the_new_positions(tmp_path):
    from solver.testing import sphere_surface

    V, F = sphere_surface(1)
    src = tmp_path / "s.stl"
    meshio.write(src, meshio.Mesh(V, [("triangle", F)]), binary=True)
    mesh = read_mesh(src)
    P = mesh.V * [2.0, 1.0, 0.5]
    assert write_mesh(mesh, P, tmp_path / "out.stl").dropped == []
    lines = (tmp_path / "out.stl").read_text().split("\n")  # the ASCII facets, read here
    normals = np.array([[float(x) for x in ln.split()[2:5]] for ln in lines if ln.strip().startswith("facet")])
    verts = np.array([[float(x) for x in ln.split()[1:4]] for ln in lines if ln.strip().startswith("vertex")])
    tri = verts.reshape(-1, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    assert len(normals) == len(F) and np.abs(normals / np.linalg.norm(normals, axis=1)[:, None] - n).max() < 1e-9


def test_a_missing_output_folder_is_created_and_one_that_cannot_be_is_named(tmp_path):
    from solver.errors import InvalidMeshError

    mesh = read_mesh(DATA / "bar_small.bdf")
    w = write_mesh(mesh, mesh.V, tmp_path / "out" / "deep" / "bar.bdf")  # as the README's snippet writes out/
    assert (tmp_path / "out" / "deep" / "bar.bdf").read_bytes() == (DATA / "bar_small.bdf").read_bytes()
    assert w.patched
    (tmp_path / "afile").write_text("x")
    with pytest.raises(InvalidMeshError) as e:
        write_mesh(mesh, mesh.V, tmp_path / "afile" / "bar.bdf")
    assert e.value.code == "unwritable_folder" and e.value.details["folder"].endswith("afile")
