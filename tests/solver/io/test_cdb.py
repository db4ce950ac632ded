"""Ansys MAPDL archives (.cdb): read as mapdl-archive reads them, written back in place.

The decks are mapdl-archive's own examples (written by MAPDL's CDWRITE) and small decks written
here; what the files hold is taken from mapdl-archive or from a few lines of parsing below,
never from tetmorph's reading of them.
"""

from __future__ import annotations

import pathlib

import mapdl_archive
import numpy as np
import pytest
from mapdl_archive import examples

from solver.errors import SolverError, UnreadableFileError, UnsupportedElementError
from solver.io import detect_format, format_of, read_mesh, write_mesh
from solver.io.read_bounds import ReadBounds

TETBEAM = pathlib.Path(examples.tetarchivefile)
HEXBEAM = pathlib.Path(examples.hexarchivefile)
SECTOR = pathlib.Path(examples.sector_archive_file)
ROTOR = TETBEAM.parent / "academic_rotor.cdb"


def _archive(path) -> mapdl_archive.Archive:
    return mapdl_archive.Archive(str(path), parse_vtk=False)


def _nblock_rows(lines: list[bytes]) -> range:
    """Indices of the node lines of the (single) NBLOCK of a deck's lines."""
    start = next(k for k, ln in enumerate(lines) if ln.startswith(b"NBLOCK")) + 2
    end = next(k for k in range(start, len(lines)) if lines[k].startswith((b"N,", b"-1")))
    return range(start, end)


# ------------------------------------------------------------------ small decks written here


def _nblock(nodes: dict[int, tuple[float, ...]]) -> str:
    """An NBLOCK as CDWRITE writes it, (3i8,6e20.13); a node may give fewer than three reals."""
    rows = [f"{i:8d}{0:8d}{0:8d}" + "".join(f"{v:20.13E}" for v in xyz) for i, xyz in nodes.items()]
    return (f"NBLOCK,6,SOLID,{max(nodes):10d},{len(nodes):10d}\n(3i8,6e20.13)\n" + "\n".join(rows)
            + "\nN,R5.3,LOC,       -1,\n")


def _eblock(elements: list[tuple[int, int, list[int]]]) -> str:
    """A SOLID EBLOCK, (19i8): (element number, type, nodes), nodes past the eighth on the next line."""
    rows = []
    for eid, itype, nodes in elements:
        rows.append("".join(f"{v:8d}" for v in [1, itype, 1, 1, 0, 0, 0, 0, len(nodes), 0, eid, *nodes[:8]]))
        if len(nodes) > 8:
            rows.append("".join(f"{v:8d}" for v in nodes[8:]))
    return (f"EBLOCK,19,SOLID,{max(e[0] for e in elements):10d},{len(elements):10d}\n(19i8)\n" + "\n".join(rows)
            + "\n      -1\n")


def _cube(base: int, x0: float) -> dict[int, tuple[float, float, float]]:
    """Nodes base+1 .. base+8 of a unit cube at x = x0, in MAPDL's brick order I J K L (z = 0), M N O P (z = 1)."""
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    return {base + k + 1: (x0 + c[0], float(c[1]), float(c[2])) for k, c in enumerate(corners)}


def _write(tmp_path, name: str, text: str) -> pathlib.Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _linear_deck(tmp_path) -> tuple[pathlib.Path, dict[int, tuple[str, list[int]]]]:
    """Tets as degenerate 8- and 20-node bricks, a wedge, a pyramid, a brick, 4-node SOLID187 and SOLID285.

    Returns the deck and, per element number, the cell type and node numbers expected (meshio order).
    """
    nodes: dict[int, tuple[float, ...]] = {}
    for k in range(7):
        nodes.update(_cube(10 * k, 2.0 * k))
    n = [[10 * k + j for j in range(9)] for k in range(7)]  # n[k][1..8]: cube k's I..P
    elements = [
        (1, 1, [n[0][1], n[0][2], n[0][3], n[0][3], n[0][5], n[0][5], n[0][5], n[0][5]]),  # SOLID185 tet
        (2, 1, [n[1][1], n[1][2], n[1][3], n[1][3], n[1][5], n[1][6], n[1][7], n[1][7]]),  # SOLID185 wedge
        (3, 1, [n[2][1], n[2][2], n[2][3], n[2][4], n[2][5], n[2][5], n[2][5], n[2][5]]),  # SOLID185 pyramid
        (4, 1, n[3][1:9]),  # SOLID185 brick
        (5, 2, [n[4][1], n[4][2], n[4][3], n[4][3], n[4][5], n[4][5], n[4][5], n[4][5],  # SOLID186 tet, no mids
                0, 0, n[4][3], 0, n[4][5], n[4][5], n[4][5], n[4][5], 0, 0, 0, 0]),
        (6, 3, [n[5][1], n[5][2], n[5][3], n[5][5]]),  # SOLID187 without its mid-side nodes
        (7, 4, [n[6][1], n[6][2], n[6][3], n[6][5]]),  # SOLID285
    ]
    expected = {
        1: ("tetra", [n[0][1], n[0][2], n[0][3], n[0][5]]),
        2: ("wedge", [n[1][3], n[1][2], n[1][1], n[1][7], n[1][6], n[1][5]]),
        3: ("pyramid", [n[2][1], n[2][2], n[2][3], n[2][4], n[2][5]]),
        4: ("hexahedron", n[3][1:9]),
        5: ("tetra", [n[4][1], n[4][2], n[4][3], n[4][5]]),
        6: ("tetra", [n[5][1], n[5][2], n[5][3], n[5][5]]),
        7: ("tetra", [n[6][1], n[6][2], n[6][3], n[6][5]]),
    }
    components = ("CMBLOCK,TETS    ,ELEM,       3  ! users element component definition\n(8i10)\n"
                  "         1         5        -7\n"
                  "CMBLOCK,BASE    ,NODE,       4  ! users node component definition\n(8i10)\n"
                  "         1        -4        11       -12\n")
    text = ("/PREP7\nET,       1,185\nET,       2,186\nET,       3,187\nET, 4,SOLID285\n" + _nblock(nodes)
            + _eblock(elements) + components + "FINISH\n")
    return _write(tmp_path, "bricks.cdb", text), expected


def _quadratic_deck(tmp_path) -> pathlib.Path:
    """A ten-node tet as a degenerate SOLID186 (corners I J K M, mid-sides Q R T Y Z A) and a SOLID187."""
    corners = {1: (0.0, 0.0, 0.0), 2: (1.0, 0.0, 0.0), 3: (0.0, 1.0, 0.0), 4: (0.0, 0.0, 1.0),
               11: (2.0, 0.0, 0.0), 12: (3.0, 0.0, 0.0), 13: (2.0, 1.0, 0.0), 14: (2.0, 0.0, 1.0)}
    edges = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]  # meshio's (and SOLID187's) mid-side order
    nodes: dict[int, tuple[float, ...]] = dict(corners)
    for base in (0, 10):
        c = [base + 1, base + 2, base + 3, base + 4]
        for k, (a, b) in enumerate(edges):
            nodes[base + 101 + k] = tuple((np.array(corners[c[a]]) + corners[c[b]]) / 2)
    i, j, k_, m = 1, 2, 3, 4
    q, r, t, y, z, a = 101, 102, 103, 104, 105, 106
    solid186 = [i, j, k_, k_, m, m, m, m, q, r, k_, t, m, m, m, m, y, z, a, a]
    solid187 = [11, 12, 13, 14, 111, 112, 113, 114, 115, 116]
    text = ("/PREP7\nET,1,186\nET,2,187\n" + _nblock(nodes) + _eblock([(1, 1, solid186), (2, 2, solid187)])
            + "FINISH\n")
    return _write(tmp_path, "tet10.cdb", text)


def _cells_by_id(mesh) -> dict[int, tuple[str, list[int]]]:
    """Element number -> (cell type, node numbers) of a mesh as read (the meshio mesh it keeps)."""
    src = mesh.source
    out = {}
    for block, ids in zip(src.cells, src.cells_id, strict=True):
        for row, eid in zip(block.data, ids, strict=True):
            out[int(eid)] = (block.type, [int(x) for x in src.points_id[row]])
    return out


def _tet_volumes(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    a, b, c, d = (P[T[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6


# ------------------------------------------------------------------ 1. the same mesh as mapdl-archive's


def test_tetbeam_reads_as_mapdl_archive_reads_it():
    mesh = read_mesh(TETBEAM)
    arc = _archive(TETBEAM)
    src = mesh.source
    assert mesh.file_format == "ansys-cdb"
    assert np.array_equal(src.points_id, arc.nnum)  # points in the order of the node lines
    assert np.allclose(mesh.V, arc.nodes, rtol=1e-14, atol=0)  # mapdl-archive's parser is off by an ulp or so
    assert [c.type for c in src.cells] == ["tetra"]
    assert np.array_equal(src.cells_id[0], arc.enum)
    # mapdl-archive's raw element records: 10 attribute fields, then the node numbers (SOLID187, 4 given)
    theirs = np.array([e[10:] for e in arc.elem])
    assert theirs.shape == (len(arc.enum), 4)
    assert np.array_equal(src.points_id[src.cells[0].data], theirs)
    assert np.array_equal(mesh.T, src.cells[0].data)
    assert (_tet_volumes(mesh.V, mesh.T) > 0).all()


@pytest.mark.parametrize("path", [SECTOR, ROTOR], ids=["sector", "academic_rotor"])
def test_brick_decks_read_as_mapdl_archive_reads_them(path):
    """SOLID185 bricks, four of them wedges (K=L, O=P): meshio's node order, as mapdl-archive's VTK grid."""
    mesh = read_mesh(path)
    arc = _archive(path)
    assert np.array_equal(mesh.source.points_id, arc.nnum)
    assert np.allclose(mesh.V, arc.nodes, rtol=1e-14, atol=0)
    ours = _cells_by_id(mesh)
    assert sorted(ours) == sorted(arc.enum.tolist())
    for eid, rec in zip(arc.enum.tolist(), arc.elem, strict=True):
        I, J, K, L, M, N, O, P = (int(x) for x in rec[10:18])
        if K == L and O == P:
            assert ours[eid] == ("wedge", [K, J, I, O, N, M])
        else:
            assert ours[eid] == ("hexahedron", [I, J, K, L, M, N, O, P])


# ------------------------------------------------------------------ 2, 3. written back in place


@pytest.mark.parametrize("path", [TETBEAM, SECTOR, ROTOR], ids=["TetBeam", "sector", "academic_rotor"])
def test_zero_move_writes_the_same_bytes(tmp_path, path):
    mesh = read_mesh(path)
    out = tmp_path / path.name
    written = write_mesh(mesh, mesh.V, out)
    assert written.patched
    assert out.read_bytes() == path.read_bytes()


@pytest.mark.parametrize("newline", [b"\n", b"\r\n"], ids=["lf", "crlf"])
def test_bent_beam_changes_only_the_moved_nodes_coordinates(tmp_path, newline):
    raw = TETBEAM.read_bytes().replace(b"\n", newline)
    src = tmp_path / "TetBeam.cdb"
    src.write_bytes(raw)
    mesh = read_mesh(src)
    V = mesh.V.copy()
    x = _archive(TETBEAM).nodes[:, 0]
    bend = x > 5.0  # the beam runs along x from 0 to 10: its right half bends
    V[bend, 1] += 0.02 * (x[bend] - 5.0) ** 2
    V[bend, 2] -= 0.01 * (x[bend] - 5.0)
    out = tmp_path / "bent.cdb"
    assert write_mesh(mesh, V, out).patched

    arc = _archive(out)
    assert np.array_equal(arc.nnum, _archive(TETBEAM).nnum)
    assert np.allclose(arc.nodes, V, rtol=1e-13, atol=1e-13)  # e20.13: 14 significant digits

    before, after = raw.split(newline), out.read_bytes().split(newline)
    assert len(before) == len(after)
    rows = _nblock_rows(before)
    changed = {k for k, (a, b) in enumerate(zip(before, after, strict=True)) if a != b}
    assert changed == {rows.start + r for r in np.flatnonzero(bend).tolist()}
    for k in changed:  # node number and the two other integer fields kept; three reals of 20 columns
        assert after[k][:24] == before[k][:24] and len(after[k]) == 24 + 60
        assert b"E" in after[k][24:44] and after[k][24:].count(b"E") == 3


def test_coordinates_a_line_left_out_are_written_when_they_change(tmp_path):
    """MAPDL leaves out trailing zero reals: a node at z = 0 that moves up gets its y and z fields."""
    nodes = {1: (0.0,), 2: (1.0,), 3: (0.0, 1.0), 4: (0.0, 0.0, 1.0)}
    text = "/PREP7\nET,1,285\n" + _nblock(nodes) + _eblock([(1, 1, [1, 2, 3, 4])]) + "FINISH\n"
    deck = _write(tmp_path, "short.cdb", text)
    mesh = read_mesh(deck)
    assert np.array_equal(mesh.V, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    V = mesh.V.copy()
    V[0] = [0.0, 0.0, -0.25]  # the first node gets all three fields
    V[1] = [1.5, 0.0, 0.0]  # the second keeps its single field
    out = tmp_path / "moved.cdb"
    write_mesh(mesh, V, out)
    lines = out.read_text().splitlines()
    rows = _nblock_rows([ln.encode() for ln in lines])
    assert lines[rows.start] == f"{1:8d}{0:8d}{0:8d}{0.0:20.13E}{0.0:20.13E}{-0.25:20.13E}"
    assert lines[rows.start + 1] == f"{2:8d}{0:8d}{0:8d}{1.5:20.13E}"
    assert lines[rows.start + 2:] == text.splitlines()[rows.start + 2:]
    assert np.allclose(_archive(out).nodes, V, rtol=0, atol=0)


# ------------------------------------------------------------------ 4. components


def test_node_component_of_sector_is_a_set():
    text = SECTOR.read_text().splitlines()
    at = next(k for k, ln in enumerate(text) if ln.startswith("CMBLOCK,REFINE"))
    values = [int(v) for v in text[at + 2].split()]  # 384 395 -396 438 -446 503 -515
    ids: list[int] = []
    for v in values:
        ids += list(range(ids[-1] + 1, -v + 1)) if v < 0 else [v]
    arc = _archive(SECTOR)
    assert sorted(ids) == sorted(arc.node_components["REFINE"].tolist())
    mesh = read_mesh(SECTOR)
    expected = np.flatnonzero(np.isin(arc.nnum, ids))
    assert np.array_equal(np.sort(mesh.sets["REFINE"]), expected)
    assert np.array_equal(mesh.source.point_sets["REFINE"], expected)


def test_element_and_node_components_with_ranges(tmp_path):
    deck, expected = _linear_deck(tmp_path)
    mesh = read_mesh(deck)
    src = mesh.source
    members = {int(src.cells_id[b][i]) for b, idx in enumerate(src.cell_sets["TETS"]) for i in idx}
    assert members == {1, 5, 6, 7}
    nodes_of_tets = {n for e in (1, 5, 6, 7) for n in expected[e][1]}
    assert set(src.points_id[mesh.sets["TETS"]].tolist()) == nodes_of_tets
    assert set(src.points_id[mesh.sets["BASE"]].tolist()) == {1, 2, 3, 4, 11, 12}


# ------------------------------------------------------------------ 5. degenerate bricks


def test_degenerate_bricks_read_as_tets_wedges_and_pyramids(tmp_path):
    deck, expected = _linear_deck(tmp_path)
    mesh = read_mesh(deck)
    assert _cells_by_id(mesh) == expected
    tets = mesh.source.cells[[c.type for c in mesh.source.cells].index("tetra")].data
    assert len(tets) == 4 and (_tet_volumes(mesh.V, tets) > 0).all()
    assert (_tet_volumes(mesh.V, mesh.T) > 0).all()
    assert {k: len(v) for k, v in mesh.cells.items()} == {"hexahedron": 1, "wedge": 1, "pyramid": 1}


def test_degenerate_solid186_and_solid187_read_as_ten_node_tets(tmp_path):
    mesh = read_mesh(_quadratic_deck(tmp_path))
    src = mesh.source
    assert [c.type for c in src.cells] == ["tetra10"]
    assert _cells_by_id(mesh) == {1: ("tetra10", [1, 2, 3, 4, 101, 102, 103, 104, 105, 106]),
                                  2: ("tetra10", [11, 12, 13, 14, 111, 112, 113, 114, 115, 116])}
    T10 = mesh.T10
    P = mesh.V
    for k, (a, b) in enumerate([(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]):  # mid-sides on their edges
        assert np.allclose(P[T10[:, 4 + k]], (P[T10[:, a]] + P[T10[:, b]]) / 2)
    assert (_tet_volumes(P, T10[:, :4]) > 0).all()


def test_hexbeam_twenty_node_bricks_are_refused_by_count_and_type():
    arc = _archive(HEXBEAM)
    n = len(arc.enum)
    assert all(len(e) - 10 == 20 and len(set(e[10:].tolist())) == 20 for e in arc.elem)  # full 20-node bricks
    with pytest.raises(UnsupportedElementError) as e:
        read_mesh(HEXBEAM)
    assert f"{n} quadratic (20-node) hexahedra (SOLID186, type 1)" in e.value.message
    assert e.value.details["types"] == {"hexahedron20": n}


# ------------------------------------------------------------------ 6. damaged files


@pytest.mark.parametrize("fraction", [0.3, 0.6, 0.9])
def test_truncated_tetbeam_is_refused(tmp_path, fraction):
    raw = TETBEAM.read_bytes()
    assert raw.index(b"N,R5.3,LOC") < 0.3 * len(raw) < 0.9 * len(raw) < raw.index(b"EN,R5.5")  # cut in the EBLOCK
    p = tmp_path / "cut.cdb"
    p.write_bytes(raw[: int(fraction * len(raw))])
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(p)
    assert e.value.code == "truncated_file", e.value.message
    assert "EBLOCK" in e.value.message


def test_declared_counts_over_the_bounds_are_refused():
    arc = _archive(TETBEAM)
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(TETBEAM, bounds=ReadBounds(points=len(arc.nnum) - 1))
    assert e.value.code == "too_many_points" and e.value.details["declared"] == len(arc.nnum)
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(TETBEAM, bounds=ReadBounds(cells=len(arc.enum) - 1))
    assert e.value.code == "too_many_cells" and e.value.details["declared"] == len(arc.enum)


def test_byte_flips_end_in_a_mesh_or_a_typed_error(tmp_path):
    raw = TETBEAM.read_bytes()
    rng = np.random.default_rng(20240517)
    outcomes = []
    for k in range(20):
        data = bytearray(raw)
        at = int(rng.integers(len(data)))
        data[at] ^= 1 << int(rng.integers(8))
        p = tmp_path / f"flip{k}.cdb"
        p.write_bytes(bytes(data))
        try:
            read_mesh(p)
            outcomes.append("read")
        except SolverError as e:  # the archive's reader answered, naming the defect
            assert e.code not in ("unknown_format", "wrong_format"), e.message
            assert e.message and "Traceback" not in e.message
            outcomes.append(e.code)
    assert len(outcomes) == 20


# ------------------------------------------------------------------ 7. names, sniffing, refusals


def test_format_names_and_sniffing():
    assert format_of("model.cdb") == "ansys-cdb"
    assert format_of("MODEL.CDB") == "ansys-cdb"
    assert format_of("model.txt", "mapdl") == "ansys-cdb"
    assert detect_format(TETBEAM.read_bytes()[:8192]) == "ansys-cdb"


def test_shells_and_beams_are_refused_in_words(tmp_path):
    nodes = {1: (0.0, 0.0, 0.0), 2: (1.0, 0.0, 0.0), 3: (1.0, 1.0, 0.0), 4: (0.0, 1.0, 0.0), 5: (0.5, 0.5, 0.0)}
    shells = [(1, 3, [1, 2, 5, 5]), (2, 3, [2, 3, 5, 5]), (3, 3, [3, 4, 5, 5])]
    deck = _write(tmp_path, "shells.cdb", "/PREP7\nET,3,181\n" + _nblock(nodes) + _eblock(shells) + "FINISH\n")
    with pytest.raises(UnsupportedElementError) as e:
        read_mesh(deck)
    assert "3 shell elements (SHELL181, type 3)" in e.value.message
    mixed = shells + [(4, 5, [1, 3]), (5, 5, [2, 4])]
    deck = _write(tmp_path, "mixed.cdb", "/PREP7\nET,3,181\nET,5,BEAM188\n" + _nblock(nodes) + _eblock(mixed)
                  + "FINISH\n")
    with pytest.raises(UnsupportedElementError) as e:
        read_mesh(deck)
    assert "3 shell elements (SHELL181, type 3) and 2 beam elements (BEAM188, type 5)" in e.value.message
    assert e.value.details["types"] == {"SHELL181": 3, "BEAM188": 2}
