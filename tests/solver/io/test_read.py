"""Unreadable input: every case says what is wrong, in the file's own terms (one test per case)."""

from __future__ import annotations

import re

import meshio
import numpy as np
import pytest

from solver import read_mesh
from solver.errors import InvalidMeshError, TopologyError, UnreadableFileError
from tests.conftest import DATA, shared_file

JUNK = re.compile(r"np\.int64|np\.float64|^\d+$|zero-size array|Traceback")


def _refused(path, code, *words, **kw):
    with pytest.raises(InvalidMeshError) as e:
        read_mesh(path, **kw)
    err = e.value
    assert err.code == code, (err.code, err.message)
    for w in words:
        assert w in err.message, (w, err.message)
    assert not JUNK.search(err.message), err.message
    return err


@pytest.mark.parametrize("name", ["x.vtu", "x.msh", "deck.inp", "m.mesh", "bulk.bdf"])
def test_empty_file(tmp_path, name):
    p = tmp_path / name
    p.write_bytes(b"")
    err = _refused(p, "empty_file", "is empty (0 bytes)")
    assert isinstance(err, UnreadableFileError)


def test_truncated_gmsh_vtu_and_tetgen(tmp_path):
    raw = (DATA / "screw.msh").read_bytes()
    cut = raw.rindex(b"\n", 0, raw.index(b"$EndElements") - 200) + 1  # after a whole element line
    p = tmp_path / "screw.msh"
    p.write_bytes(raw[:cut])
    _refused(p, "truncated_file", "ends inside its $Elements section", "truncated")
    p = tmp_path / "nodes.msh"
    p.write_bytes(raw[: raw.rindex(b"\n", 0, raw.index(b"$EndNodes") - 100) + 1])
    _refused(p, "truncated_file", "$Nodes")
    p = tmp_path / "midline.msh"
    p.write_bytes(raw[: raw.index(b"$EndElements") - 7])  # in the middle of the last element line
    _refused(p, "truncated_file", "ends in the middle of a line")
    vtu = tmp_path / "full.vtu"
    meshio.write(vtu, meshio.read(DATA / "bracket.inp"))
    data = vtu.read_bytes()
    p = tmp_path / "half.vtu"
    p.write_bytes(data[: len(data) // 2])
    _refused(p, "truncated_file", "</VTKFile>")
    node = (DATA / "beam.node").read_bytes().splitlines(keepends=True)
    (tmp_path / "beam.ele").write_bytes((DATA / "beam.ele").read_bytes())
    p = tmp_path / "beam.node"
    p.write_bytes(b"".join(node[:100]))
    head = int(next(ln for ln in node if ln.strip() and not ln.startswith(b"#")).split()[0])
    kept = sum(1 for ln in node[:100] if ln.strip() and not ln.startswith(b"#")) - 1
    _refused(p, "truncated_file", f"announces {head} nodes but holds {kept}")


def test_deck_cut_in_the_middle_of_a_line(tmp_path):
    raw = (DATA / "bracket.inp").read_bytes()
    start = raw.index(b"*ELEMENT, type=C3D4") if b"*ELEMENT, type=C3D4" in raw else raw.rindex(b"*ELEMENT")
    mid = raw.index(b"\n", start + 2000) + 6  # six characters into an element line
    p = tmp_path / "cut.inp"
    p.write_bytes(raw[:mid])
    _refused(p, "truncated_file", "ends in the middle of a line")


def test_wrong_format_names_what_the_file_is(tmp_path):
    p = tmp_path / "part.vtu"
    p.write_bytes((DATA / "screw.msh").read_bytes())
    err = _refused(p, "wrong_format", "named as a VTK XML", "Gmsh mesh", "rename it to .msh")
    assert err.details["detected"] == "gmsh" and err.details["expected"] == "vtu"
    p = tmp_path / "deck.inp"
    p.write_bytes((DATA / "screw.msh").read_bytes())
    assert _refused(p, "wrong_format").details["detected"] == "gmsh"
    p = tmp_path / "deck.msh"
    p.write_bytes((DATA / "bracket.inp").read_bytes())
    assert _refused(p, "wrong_format", "Abaqus").details["detected"] == "abaqus"
    p = tmp_path / "noise.msh"
    p.write_bytes(b"\x00\x01 this is not a mesh \xff" * 20)
    err = _refused(p, "wrong_format", "does not start like one")
    assert err.details["detected"] is None


def test_surface_where_a_volume_is_expected_points_to_tetrahedralize(tmp_path):
    for path in (DATA / "42400-IDGH.stl", shared_file("surface/bunny.off")):
        err = _refused(path, "surface_not_volume", "triangle surface", "tetmorph tetrahedralize", volume=True)
        assert err.details["cells"]["triangle"] > 0
    assert read_mesh(shared_file("surface/bunny.off")).is_surface  # without volume=True: a surface to morph


def test_index_out_of_range_in_a_deck_names_element_and_node(tmp_path):
    lines = (DATA / "bracket.inp").read_text().splitlines(keepends=True)
    k = next(i for i, ln in enumerate(lines) if ln.upper().startswith("*ELEMENT") and "C3D4" in ln.upper()) + 5
    fields = lines[k].split(",")
    eid = int(fields[0])
    fields[2] = " 99999"
    lines[k] = ",".join(fields)
    p = tmp_path / "bad.inp"
    p.write_text("".join(lines))
    err = _refused(p, "undefined_node", f"line {k + 1}", f"element {eid}", "node 99999")
    assert (err.details["element"], err.details["node"], err.details["line"]) == (eid, 99999, k + 1)
    bdf = (DATA / "bar_small.bdf").read_text().splitlines(keepends=True)
    k = next(i for i, ln in enumerate(bdf) if ln.startswith("CTETRA"))
    line = bdf[k]
    bdf[k] = line[:24] + f"{77777:<8d}" + line[32:]
    p = tmp_path / "bad.bdf"
    p.write_text("".join(bdf))
    _refused(p, "undefined_node", "element 1", "node 77777", f"line {k + 1}")


def test_index_out_of_range_in_tetgen(tmp_path):
    (tmp_path / "beam.node").write_bytes((DATA / "beam.node").read_bytes())
    ele = (DATA / "beam.ele").read_text().splitlines(keepends=True)
    k = next(i for i, ln in enumerate(ele) if ln.strip() and not ln.startswith("#")) + 3
    parts = ele[k].split()
    ele[k] = " ".join([parts[0], "5000", *parts[2:]]) + "\n"
    (tmp_path / "beam.ele").write_text("".join(ele))
    _refused(tmp_path / "beam.node", "undefined_node", f"element {parts[0]}", "node 5000", f"line {k + 1}")


def test_empty_deck_and_empty_gmsh_file(tmp_path):
    p = tmp_path / "empty.inp"
    p.write_text("*HEADING\nan empty deck\n*STEP\n*STATIC\n*END STEP\n")
    _refused(p, "no_nodes", "defines no nodes", "*NODE")
    p = tmp_path / "empty.msh"
    p.write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n")
    _refused(p, "no_nodes", "without a $Nodes section")
    p = tmp_path / "nobulk.bdf"
    p.write_text("SOL 101\nCEND\n")
    _refused(p, "no_nodes", "BEGIN BULK")


def test_duplicate_nodes_are_named_with_a_hint_about_ties():
    """A cube in two halves whose interface nodes were merged only along one edge: the halves
    touch along that edge (edges in four boundary faces), and the other interface nodes are pairs."""
    from solver import mesh_from_arrays
    from solver.testing import cube_mesh

    V, T = cube_mesh(4)
    top = V[T].mean(1)[:, 2] > 0.5
    iface = np.flatnonzero(np.abs(V[:, 2] - 0.5) < 1e-12)
    split = iface[np.abs(V[iface, 1]) > 1e-12]  # the y = 0 edge of the interface stays shared
    copy = np.arange(len(V))
    copy[split] = len(V) + np.arange(split.size)
    T2 = T.copy()
    T2[top] = copy[T[top]]
    V2 = np.vstack([V, V[split]])
    with pytest.raises(TopologyError) as e:
        mesh_from_arrays(V2, T2)
    err = e.value
    assert err.code == "duplicate_nodes" and err.details["cause"] == "non_manifold_boundary"
    expected = sorted([int(a), len(V) + k] for k, a in enumerate(split))
    assert err.details["pairs"] == expected and err.details["count"] == split.size
    assert f"{expected[0][0]}-{expected[0][1]}" in err.message and "ties" in err.message
    # all interface nodes split: two bodies that touch, the parts of an assembly, accepted
    copy[iface] = len(V) + np.arange(iface.size)
    T3 = T.copy()
    T3[top] = copy[T[top]]
    m = mesh_from_arrays(np.vstack([V, V[iface]]), T3)
    assert m.info()["bodies"] == 2 and m.info()["coincident_nodes"] == iface.size


def test_unmerged_surface_seam_is_duplicate_nodes(tmp_path):
    """bunny.off with the faces on one side of x = 0 on copies of their nodes: open rims that meet."""
    m = meshio.read(shared_file("surface/bunny.off"))
    P, F = m.points, m.cells_dict["triangle"]
    right = P[F].mean(1)[:, 0] > np.median(P[:, 0])
    copy = np.arange(len(P)) + len(P)
    F2 = F.copy()
    F2[right] = copy[F[right]]
    p = tmp_path / "seam.off"
    meshio.write(p, meshio.Mesh(np.vstack([P, P]), [("triangle", F2)]))
    err = _refused(p, "duplicate_nodes", "coincident")
    pairs = np.array(err.details["pairs"])
    assert (pairs[:, 1] - pairs[:, 0] == len(P)).all()  # each pair is a node and its copy


def test_nastran_grids_in_a_local_system_are_read_in_basic_and_an_undefined_one_is_refused(tmp_path):
    """GRID 1 at (0, 0, 10) given in system 3, a CORD2R system moved by (1, 2, 3): read at (0, 0, 10)."""
    bdf = (DATA / "bar_small.bdf").read_text().splitlines(keepends=True)
    k = next(i for i, ln in enumerate(bdf) if ln.startswith("GRID"))
    assert bdf[k] == "GRID    1                     0.      0.     10.\n"
    bdf[k] = "GRID    1       3       -1.     -2.     7.\n"
    p = tmp_path / "local.bdf"
    p.write_text("".join(bdf))
    _refused(p, "undefined_coordinate_system", "GRID 1 is given in coordinate system 3", "CORD2R")
    bdf.insert(k, "CORD2R  3               1.      2.      3.      1.      2.      4.\n+       2.      2.      3.\n")
    p.write_text("".join(bdf))
    mesh = read_mesh(p)
    np.testing.assert_array_equal(mesh.V[0], [0.0, 0.0, 10.0])
    np.testing.assert_array_equal(mesh.V, read_mesh(DATA / "bar_small.bdf").V)


def test_unknown_extension_names_the_detected_format(tmp_path):
    p = tmp_path / "part.bin"
    p.write_bytes((DATA / "screw.msh").read_bytes())
    err = _refused(p, "unknown_format", "Gmsh")
    assert err.details["detected"] == "gmsh"
    assert read_mesh(p, "gmsh").n == read_mesh(DATA / "screw.msh").n


def test_tetgen_numbering_and_comments(tmp_path):
    """TetGen files number from 0 or 1; comments may follow data on a line."""
    b = read_mesh(DATA / "beam.node")
    assert b.source.info["tetgen:base"] == 1 and (b.n, len(b.T)) == (208, 450)
    node = ["# zero-based copy", "208 3 0 0"]
    rows = [ln.split() for ln in (DATA / "beam.node").read_text().splitlines() if ln.strip()
            and not ln.startswith("#")][1:]
    node += [f"{int(r[0]) - 1} {r[1]} {r[2]} {r[3]}  # node" for r in rows]
    ele = [ln.split() for ln in (DATA / "beam.ele").read_text().splitlines() if ln.strip()
           and not ln.startswith("#")]
    (tmp_path / "z.node").write_text("\n".join(node) + "\n")
    (tmp_path / "z.ele").write_text("\n".join([" ".join(ele[0])] + [" ".join(str(int(x) - 1) for x in r)
                                                                     for r in ele[1:]]) + "\n")
    z = read_mesh(tmp_path / "z.ele")
    assert z.source.info["tetgen:base"] == 0
    np.testing.assert_array_equal(z.T, b.T)
    np.testing.assert_array_equal(z.V, b.V)


def test_a_file_read_with_an_explicit_format_is_written_back_in_place(tmp_path):
    p = tmp_path / "part.bin"
    p.write_bytes((DATA / "screw.msh").read_bytes())
    mesh = read_mesh(p, "gmsh")
    assert mesh.file_format == "gmsh"
    from solver import write_mesh

    out = tmp_path / "out.msh"
    assert write_mesh(mesh, mesh.V, out).patched and out.read_bytes() == p.read_bytes()


def _vtu_bomb(path, points: int) -> None:
    """A VTU whose compressed points (a few hundred bytes of zlib) declare ``points`` nodes."""
    import zlib

    from .test_bounds import vtu_blocks

    raw = bytes(1 << 20)  # 1 MB of zeros stands for the rest: the header is what declares the size
    block = zlib.compress(raw, 9)
    path.write_bytes(vtu_blocks(points, [1, len(raw), len(raw), len(block)], [block]))


def test_files_declaring_more_than_the_bounds_are_refused_before_they_are_read(tmp_path):
    import resource

    from solver.limits import MAX_POINTS

    bomb = tmp_path / "bomb.vtu"
    _vtu_bomb(bomb, 300_000_000)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(bomb)
    assert e.value.code == "too_many_points" and e.value.details["declared"] == 300_000_000
    assert e.value.details["bound"] == MAX_POINTS and "300,000,000 nodes" in e.value.message
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000  # KiB: nothing expanded
    msh = tmp_path / "huge.msh"
    msh.write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 400000000 1 400000000\n$EndNodes\n")
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(msh)
    assert e.value.code == "too_many_points"
    vtk = tmp_path / "huge.vtk"
    vtk.write_text("# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 90000000000 double\n")
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(vtk)
    assert e.value.code == "too_many_points"


def test_a_gmsh_block_declaring_more_than_its_section_is_refused_before_it_is_read(tmp_path):
    """Gmsh 4.1: the section's totals are small and pass the bounds, but one block declares a count a reader
    would allocate (once a raw MemoryError of petabytes): refused with the block's count, nothing read."""
    import resource

    head = ("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 0 1\n1 0 0 0 1 1 1 0 0\n$EndEntities\n"
            "$Nodes\n1 4 1 4\n3 1 0 {nodes}\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n"
            "$Elements\n1 1 1 1\n3 1 4 {elems}\n1 1 2 3 4\n$EndElements\n")
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for nodes, elems, code, declared in ((4, 99_999_999_999_999, "too_many_cells", 99_999_999_999_999),
                                         (88_888_888_888, 1, "too_many_points", 88_888_888_888)):
        path = tmp_path / f"{code}.msh"
        path.write_text(head.format(nodes=nodes, elems=elems))
        with pytest.raises(UnreadableFileError) as e:
            read_mesh(path)
        assert e.value.code == code and e.value.details["declared"] == declared
        assert "MemoryError" not in e.value.message and "block" in e.value.message
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000  # KiB
    path = tmp_path / "ok.msh"
    path.write_text(head.format(nodes=4, elems=1))
    assert read_mesh(path).n == 4  # the same file, consistent, reads


def test_the_gmsh22_name_reads_a_gmsh_file_and_keeps_its_size_bounds(tmp_path):
    """meshio names its Gmsh 2.2 writer ``gmsh22``; a file given that name reads as Gmsh, bounds included."""
    src = read_mesh(DATA / "mixed.msh")
    path = tmp_path / "v22.msh"
    meshio.write(path, meshio.read(DATA / "mixed.msh"), file_format="gmsh22", binary=False)
    assert open(path).read().startswith("$MeshFormat\n2.2")
    m = read_mesh(path, "gmsh22")
    assert m.file_format == "gmsh" and np.array_equal(m.V, src.V) and np.array_equal(m.T, src.T)
    msh = tmp_path / "huge.msh"
    msh.write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 400000000 1 400000000\n$EndNodes\n")
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(msh, "gmsh22")
    assert e.value.code == "too_many_points"
