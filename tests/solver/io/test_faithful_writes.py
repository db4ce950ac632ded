"""Every format written back in place: a zero move gives the file's bytes, a move changes only point values.

Legacy VTK (ASCII and binary, 4.2 and 5.1, float and double, written by meshio and by VTK), Medit
(``.mesh`` text in its own number layout, ``.meshb`` binary), and every VTU layout VTK writes (ASCII,
binary, appended raw and base64; plain, zlib and LZMA) with the ``<InformationKey>`` VTK puts in the
points array. Files are read back with meshio and, for VTU, with VTK's own reader. Also: what is not read
is named (quadratic Medit elements; shells, beams and other elements in words, with their counts).
"""

from __future__ import annotations

import re
import struct

import meshio
import numpy as np
import pytest

from solver import read_mesh, write_mesh
from solver.errors import InvalidMeshError, LossyWriteError, UnreadableFileError, UnsupportedElementError
from solver.io.read import read_surface
from solver.testing import cube_mesh
from tests.conftest import SHARED

pv = pytest.importorskip("pyvista")
vtk_xml = pytest.importorskip("vtkmodules.vtkIOXML")
vtk_legacy = pytest.importorskip("vtkmodules.vtkIOLegacy")
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402


def _box() -> tuple[np.ndarray, np.ndarray]:
    V, T = cube_mesh(3, (10.0, 20.0, 30.0))  # thirds: coordinates with many digits
    return V, T


def _moved(V: np.ndarray) -> np.ndarray:
    """The far half bent: a smooth move of some nodes, values no short text holds."""
    P = V.copy()
    mid = (P[:, 0].min() + P[:, 0].max()) / 2
    far = P[:, 0] > mid
    P[far, 2] += 0.01 * (P[far, 0] - mid) ** 2 + 1 / 7
    P[far, 1] -= 0.125
    return P


def _grid(V: np.ndarray, T: np.ndarray, single: bool = False):
    g = pv.UnstructuredGrid(np.c_[np.full(len(T), 4), T].ravel(), np.full(len(T), 10, np.uint8),
                            V.astype(np.float32 if single else np.float64))
    g.point_data["temperature"] = np.arange(len(V), dtype=np.float64)
    g.cell_data["region"] = np.arange(len(T)) % 3.0  # float: meshio 5.3 reads no integer cell data of VTK's 5.1
    g.GetPoints().GetData().GetRange(-1)  # VTK writes the range it holds as an <InformationKey>
    return g


# ---------------------------------------------------------------- legacy VTK

def _vtk_by_vtk(path, version: int, binary: bool, single: bool) -> None:
    w = vtk_legacy.vtkUnstructuredGridWriter()
    w.SetInputData(_grid(*_box(), single))
    w.SetFileName(str(path))
    w.SetFileVersion(version)
    w.SetFileTypeToBinary() if binary else w.SetFileTypeToASCII()
    w.Write()


def _vtk_by_meshio(path, version: int, binary: bool, single: bool) -> None:
    V, T = _box()
    meshio.vtk.write(path, meshio.Mesh(V.astype(np.float32 if single else np.float64), [("tetra", T)],
                                       point_data={"temperature": np.arange(len(V), dtype=np.float64)}),
                     binary=binary, fmt_version=f"{version // 10}.{version % 10}")


LEGACY = [(w, v, b, s) for w in ("vtk", "meshio") for v in (42, 51) for b in (False, True) for s in (False, True)]


def _legacy(tmp_path, writer: str, version: int, binary: bool, single: bool):
    src = tmp_path / "part.vtk"
    (_vtk_by_vtk if writer == "vtk" else _vtk_by_meshio)(src, version, binary, single)
    head = src.read_bytes()[:120]
    assert head.startswith(f"# vtk DataFile Version {version // 10}.{version % 10}".encode())
    assert (b"BINARY" if binary else b"ASCII") in head and (b"float" if single else b"double") in head
    return src


@pytest.mark.parametrize(("writer", "version", "binary", "single"), LEGACY)
def test_legacy_vtk_zero_move_is_byte_identical(tmp_path, writer, version, binary, single):
    src = _legacy(tmp_path, writer, version, binary, single)
    mesh = read_mesh(src)
    out = tmp_path / "out.vtk"
    w = write_mesh(mesh, mesh.V, out)
    assert w.patched and w.dropped == []
    assert out.read_bytes() == src.read_bytes()


def _points_block(data: bytes, n: int, binary: bool, single: bool) -> tuple[int, int]:
    m = re.search(rb"(?m)^POINTS \d+ \w+\r?\n", data)
    assert m is not None
    if binary:
        return m.end(), m.end() + 3 * n * (4 if single else 8)
    words = list(re.finditer(rb"\S+", data[m.end():]))
    return m.end(), m.end() + words[3 * n - 1].end()


@pytest.mark.parametrize(("writer", "version", "binary", "single"), LEGACY)
def test_legacy_vtk_move_changes_only_point_values(tmp_path, writer, version, binary, single):
    src = _legacy(tmp_path, writer, version, binary, single)
    mesh = read_mesh(src)
    P = _moved(mesh.V)
    out = tmp_path / "out.vtk"
    assert write_mesh(mesh, P, out).patched
    a, b = src.read_bytes(), out.read_bytes()
    lo, hi = _points_block(a, mesh.n, binary, single)
    lo2, hi2 = _points_block(b, mesh.n, binary, single)
    assert a[:lo] == b[:lo2] and a[hi:] == b[hi2:]  # header, cells, data, METADATA: the same bytes
    precision = np.float32 if single else np.float64
    np.testing.assert_array_equal(meshio.read(out).points, P.astype(precision))
    unmoved = ~(P != mesh.V).any(1)
    if binary:
        assert len(a) == len(b)
        old = np.frombuffer(a[lo:hi], ">f4" if single else ">f8").reshape(-1, 3)
        new = np.frombuffer(b[lo2:hi2], ">f4" if single else ">f8").reshape(-1, 3)
        assert old[unmoved].tobytes() == new[unmoved].tobytes()
    else:  # the same separators, the same text for every unmoved number
        assert re.findall(rb"\s+", a[lo:hi]) == re.findall(rb"\s+", b[lo2:hi2])
        old, new = a[lo:hi].split(), b[lo2:hi2].split()
        same = np.array([x == y for x, y in zip(old, new, strict=True)]).reshape(-1, 3)
        assert same[unmoved].all() and not same[~unmoved][:, 1].any()  # moved y values rewritten


def test_sfepy_vtk_keeps_its_one_line_of_points(tmp_path):
    from tests.conftest import DATA

    mesh = read_mesh(DATA / "wheelset.vtk")
    P = mesh.V.copy()
    P[7] += [0.5, 0.25, -0.125]
    w = write_mesh(mesh, P, tmp_path / "out.vtk")
    a, b = (DATA / "wheelset.vtk").read_bytes(), (tmp_path / "out.vtk").read_bytes()
    assert w.patched and len(a.splitlines()) == len(b.splitlines())
    diff = [(x, y) for x, y in zip(a.split(), b.split(), strict=True) if x != y]
    assert len(diff) == 3 and [float(y) for _, y in diff] == P[7].tolist()


# ---------------------------------------------------------------- Medit

def _medit_by_hand(V: np.ndarray, T: np.ndarray) -> bytes:
    """Version 1 (single precision) in a layout of its own: comments, fixed columns, extra keywords."""
    rows = "".join(f"  {x:10.4f} {y:10.4f}\t{z:10.4f}   {k % 3 + 1}\n" for k, (x, y, z) in enumerate(V))
    tets = "".join(" ".join(str(i + 1) for i in t) + " 7\n" for t in T)
    return (f"# a Medit mesh laid out by hand\nMeshVersionFormatted 1\n\nDimension\n3\n\nVertices\n{len(V)}\n"
            f"{rows}\n# the elements\nTetrahedra\n{len(T)}\n{tets}\nCorners\n2\n1\n2\n\nEnd\n").encode()


def _meshb(V: np.ndarray, blocks: list[tuple[int, np.ndarray]], version: int = 1, end: str = ">") -> bytes:
    """A binary Medit file written here, keyword by keyword (big-endian version 1 unless told)."""
    itype, ftype, ptype = {1: ("i4", "f4", "i4"), 2: ("i4", "f8", "i4"), 3: ("i4", "f8", "i8")}[version]
    pw = np.dtype(ptype).itemsize
    out = bytearray(struct.pack(end + "ii", 1, version))

    def keyword(code: int, body: bytes, count: int | None) -> None:
        head = struct.pack(end + "i", code)
        size = len(head) + pw + (4 if count is not None else 0) + len(body)
        out.extend(head + np.array([len(out) + size], end + ptype).tobytes()
                   + (struct.pack(end + "i", count) if count is not None else b"") + body)

    keyword(3, struct.pack(end + "i", 3), None)
    rec = np.zeros(len(V), [("x", end + ftype, (3,)), ("ref", end + itype)])
    rec["x"], rec["ref"] = V, 1
    keyword(4, rec.tobytes(), len(V))
    for code, E in blocks:
        keyword(code, np.c_[E + 1, np.ones(len(E), int)].astype(end + itype).tobytes(), len(E))
    out.extend(struct.pack(end + "i", 54))
    return bytes(out)


def _medit_source(tmp_path, name: str):
    """A Medit file: meshio's text (version 2, %.16e) or binary (version 3), one laid out by hand, one written
    here big-endian, or the shared cube_cylinder.mesh (numbers as 1.00000000000e+000)."""
    if name == "cube_cylinder.mesh":
        shared = SHARED / "tet" / name
        if not shared.exists():
            pytest.skip(f"{shared} is not there")
        return shared
    V, T = _box()
    p = tmp_path / name
    if name.startswith("meshio"):
        meshio.write(p, meshio.Mesh(V, [("tetra", T.astype(np.int32))]))
    else:
        p.write_bytes(_medit_by_hand(V, T) if name.endswith(".mesh") else _meshb(V, [(8, T)]))
    return p


@pytest.mark.parametrize("name", ["meshio.mesh", "by_hand.mesh", "meshio.meshb", "big_endian.meshb",
                                  "cube_cylinder.mesh"])
def test_medit_zero_move_is_byte_identical_and_a_move_keeps_the_layout(tmp_path, name):
    src = _medit_source(tmp_path, name)
    mesh = read_mesh(src)
    ext = src.suffix
    assert write_mesh(mesh, mesh.V, tmp_path / f"same{ext}").patched
    assert (tmp_path / f"same{ext}").read_bytes() == src.read_bytes()
    P = _moved(mesh.V)
    out = tmp_path / f"out{ext}"
    assert write_mesh(mesh, P, out).patched
    a, b = src.read_bytes(), out.read_bytes()
    back = meshio.read(out)
    single = b"MeshVersionFormatted 1" in a or name == "big_endian.meshb"
    np.testing.assert_array_equal(back.points, P.astype(np.float32 if single else np.float64))
    orig = meshio.read(src)
    np.testing.assert_array_equal(back.point_data["medit:ref"], orig.point_data["medit:ref"])
    np.testing.assert_array_equal(back.cells_dict["tetra"], orig.cells_dict["tetra"])
    if ext == ".meshb":
        assert len(a) == len(b)
        w = write_mesh(mesh, P, tmp_path / "as_text.mesh")  # the other kind of Medit file: written, not patched
        assert not w.patched and (tmp_path / "as_text.mesh").read_bytes().startswith(b"MeshVersionFormatted")
        np.testing.assert_array_equal(meshio.read(tmp_path / "as_text.mesh").points, P)
        return
    lines_a, lines_b = a.splitlines(), b.splitlines()
    assert len(lines_a) == len(lines_b)
    moved = (P != mesh.V).any(1)
    start = lines_a.index(b"Vertices") + 2
    for k, (x, y) in enumerate(zip(lines_a, lines_b, strict=True)):
        vertex = start <= k < start + mesh.n
        if not vertex or not moved[k - start]:
            assert x == y  # header, comments, elements, unmoved vertices: the same text
        else:  # the same separators and reference; numbers in the notation of the line they replace
            assert re.findall(rb"\s+", x) == re.findall(rb"\s+", y) and x.split()[-1] == y.split()[-1]
            assert (b"e" in x.split()[0]) == (b"e" in y.split()[0])
            if b"e+000" in x or b"e-000" in x:
                assert all(len(t.split(b"e")[1]) == 4 for t in y.split()[:3])


# ---------------------------------------------------------------- VTU written by VTK

VTU = [("ascii", None, False)] + [(mode, comp, wide) for mode in ("binary", "raw", "base64")
                                   for comp in (None, "zlib", "lzma") for wide in (False, True)]


def _vtu_by_vtk(path, mode: str, compressor: str | None, wide: bool, single: bool) -> None:
    w = vtk_xml.vtkXMLUnstructuredGridWriter()
    w.SetInputData(_grid(*_box(), single))
    w.SetFileName(str(path))
    w.SetDataMode({"ascii": 0, "binary": 1}.get(mode, 2))
    w.SetEncodeAppendedData(mode == "base64")
    {None: w.SetCompressorTypeToNone, "zlib": w.SetCompressorTypeToZLib,
     "lzma": w.SetCompressorTypeToLZMA}[compressor]()
    if wide:
        w.SetHeaderTypeToUInt64()
    w.Write()


def _read_vtk(path) -> dict[str, np.ndarray]:
    r = vtk_xml.vtkXMLUnstructuredGridReader()
    r.SetFileName(str(path))
    r.Update()
    g = r.GetOutput()
    return {"points": vtk_to_numpy(g.GetPoints().GetData()),
            "temperature": vtk_to_numpy(g.GetPointData().GetArray("temperature")),
            "region": vtk_to_numpy(g.GetCellData().GetArray("region")),
            "connectivity": vtk_to_numpy(g.GetCells().GetConnectivityArray()),
            "types": vtk_to_numpy(g.GetCellTypes())}


def _skeleton(data: bytes) -> bytes:
    """The XML outside the points' values and the appended data, appended offsets left out."""
    head = data.split(b"<AppendedData")[0]
    head = re.sub(rb"(<Points>\s*<DataArray[^>]*>)[^<]*", rb"\1", head)
    return re.sub(rb'offset="\d+" *', b"offset", head)


@pytest.mark.parametrize(("mode", "compressor", "wide"), VTU)
@pytest.mark.parametrize("single", [False, True])
def test_vtu_written_by_vtk_round_trips_with_its_information_key(tmp_path, mode, compressor, wide, single):
    src = tmp_path / "part.vtu"
    _vtu_by_vtk(src, mode, compressor, wide, single)
    a = src.read_bytes()
    assert re.search(rb"<Points>\s*<DataArray[^>]*>[^<]*<InformationKey", a)  # VTK's L2_NORM_RANGE
    mesh = read_mesh(src)
    assert write_mesh(mesh, mesh.V, tmp_path / "same.vtu").patched
    assert (tmp_path / "same.vtu").read_bytes() == a
    P = _moved(mesh.V)
    out = tmp_path / "out.vtu"
    w = write_mesh(mesh, P, out)
    assert w.patched and w.dropped == []
    b = out.read_bytes()
    assert _skeleton(b) == _skeleton(a)  # InformationKey, ranges, other arrays' XML: the same
    before, after = _read_vtk(src), _read_vtk(out)
    np.testing.assert_array_equal(after["points"], P.astype(np.float32 if single else np.float64))
    for key in ("temperature", "region", "connectivity", "types"):
        np.testing.assert_array_equal(after[key], before[key])
    np.testing.assert_array_equal(meshio.read(out).points, P.astype(np.float32 if single else np.float64))
    if compressor is None and mode != "ascii":  # plain binary: the same length, only point bytes differ
        assert len(a) == len(b)


def test_a_compressed_vtu_recompresses_only_the_blocks_that_changed(tmp_path):
    src = tmp_path / "big.vtu"
    V, T = cube_mesh(16)  # 4913 points: four 32 KiB blocks of coordinates
    w = vtk_xml.vtkXMLUnstructuredGridWriter()
    w.SetInputData(_grid(V, T))
    w.SetFileName(str(src))
    w.SetCompressorTypeToZLib()
    w.SetEncodeAppendedData(False)  # appended raw bytes, compressed
    w.Write()
    mesh = read_mesh(src)
    P = mesh.V.copy()
    P[4500:] += [0.0, 0.0, 1 / 3]  # only the last block changes
    out = tmp_path / "out.vtu"
    assert write_mesh(mesh, P, out).patched
    a, b = src.read_bytes(), out.read_bytes()

    def blocks(data: bytes) -> list[bytes]:
        at = int(re.search(rb'Name="Points"[^>]*offset="(\d+)"', data)[1])
        app = data[data.index(b"_", data.index(b"<AppendedData")) + 1:]
        head = np.frombuffer(app, "<u4", 3 + int(np.frombuffer(app, "<u4", 1, at)[0]), at)
        cuts = at + 4 * len(head) + np.r_[0, np.cumsum(head[3:])]
        return [app[i:j] for i, j in zip(cuts[:-1], cuts[1:], strict=True)]

    old, new = blocks(a), blocks(b)
    assert len(old) == len(new) == 4 and old[:3] == new[:3] and old[3] != new[3]
    after, before = _read_vtk(out), _read_vtk(src)
    np.testing.assert_array_equal(after["points"], P)
    for key in ("temperature", "region", "connectivity"):  # arrays after the points moved with their offsets
        np.testing.assert_array_equal(after[key], before[key])


def test_vtu_points_it_cannot_write_back_are_a_named_loss(tmp_path):
    src = tmp_path / "ints.vtu"
    V, T = cube_mesh(2, (2.0, 2.0, 2.0))
    meshio.write(src, meshio.Mesh(V, [("tetra", T)]), binary=False)
    text = src.read_text()
    ints = re.sub(r'(<Points>\s*<DataArray type=")Float64', r"\1Int64", text)
    src.write_text(re.sub(r"(\d)\.\d+e\+00", r"\1", ints))  # whole coordinates as integers
    mesh = read_mesh(src)
    P = mesh.V + 0.5
    with pytest.raises(LossyWriteError) as e:
        write_mesh(mesh, P, tmp_path / "out.vtu")
    assert "file_content" in str(e.value.details["losses"]) and "Int64" in str(e.value)
    w = write_mesh(mesh, P, tmp_path / "out.vtu", lossy=True)
    assert not w.patched and w.dropped[0]["kind"] == "file_content"
    np.testing.assert_array_equal(meshio.read(tmp_path / "out.vtu").points, P)


# ---------------------------------------------------------------- what is not read, named

P2_MESH = """MeshVersionFormatted 2
Dimension 3
Vertices
10
0 0 0 1
1 0 0 1
0 1 0 1
0 0 1 1
0.5 0 0 1
0.5 0.5 0 1
0 0.5 0 1
0 0 0.5 1
0.5 0 0.5 1
0 0.5 0.5 1
TetrahedraP2
1
1 2 3 4 5 6 7 8 9 10 1
TrianglesP2
1
1 2 3 5 6 7 2
End
"""


def test_quadratic_medit_elements_are_named(tmp_path):
    src = tmp_path / "p2.mesh"
    src.write_text(P2_MESH)
    with pytest.raises(UnsupportedElementError) as e:
        read_mesh(src)
    msg = str(e.value)
    assert "1 10-node tetrahedron (TetrahedraP2)" in msg and "TrianglesP2" in msg and "truncated" not in msg
    assert e.value.details["keywords"] == {"TetrahedraP2": 1, "TrianglesP2": 1}
    # binary: meshio skips the keyword's elements; they are named before it reads
    V = np.array([[float(x) for x in ln.split()[:3]] for ln in P2_MESH.splitlines()[4:14]])
    binary = tmp_path / "p2.meshb"
    binary.write_bytes(_meshb(V, [(30, np.arange(10)[None]), (24, np.array([[0, 1, 2, 4, 5, 6]] * 3))]))
    with pytest.raises(UnsupportedElementError) as e:
        read_mesh(binary)
    assert "1 10-node tetrahedron (TetrahedraP2) and 3 6-node triangular shell/face elements (TrianglesP2)" \
        in str(e.value)


def test_shells_and_beams_are_named_in_words(tmp_path):
    V, T = cube_mesh(2)
    quad, lines = np.array([[0, 1, 4, 3]]), np.c_[np.arange(12), np.arange(1, 13)]
    src = tmp_path / "shells.vtu"
    meshio.write(src, meshio.Mesh(V, [("quad", quad), ("line", lines)]))
    with pytest.raises(InvalidMeshError) as e:
        read_mesh(src)
    assert e.value.code == "no_elements"
    assert "has no volume elements, only 1 quadrilateral shell element (quad) and 12 beam/truss elements (line)" \
        in str(e.value)
    beams = tmp_path / "beams.vtu"
    meshio.write(beams, meshio.Mesh(V, [("line", lines[:2])]))
    with pytest.raises(UnreadableFileError) as e:
        read_surface(beams)
    assert "has no triangles or quadrilaterals to read as a surface, only 2 beam/truss elements (line)" in str(e.value)
    solid = tmp_path / "solid.vtu"
    meshio.write(solid, meshio.Mesh(V, [("tetra", T), ("quad", quad)]))
    with pytest.raises(UnreadableFileError) as e:
        read_surface(solid)
    assert "is a volume mesh already (48 tetrahedra (tetra) and 1 quadrilateral shell element (quad))" in str(e.value)
    hex20 = tmp_path / "hex20.vtu"  # a solid tetmorph does not deform, next to tets, shells and beams
    meshio.write(hex20, meshio.Mesh(V, [("tetra", T), ("hexahedron20", np.arange(20)[None]), ("quad", quad),
                                        ("line", lines)]))
    with pytest.raises(UnsupportedElementError) as e:
        read_mesh(hex20)
    assert "1 20-node hexahedron (hexahedron20) is not supported" in str(e.value)
    assert "{" not in str(e.value) and e.value.details["types"] == {"hexahedron20": 1}
    mixed = tmp_path / "mixed.vtu"
    meshio.write(mixed, meshio.Mesh(V, [("tetra10", np.arange(10)[None]),
                                        ("hexahedron", np.tile(np.arange(8), (1_200, 1)))]))
    with pytest.raises(UnsupportedElementError) as e:
        read_mesh(mixed)
    assert "1,200 hexahedra (hexahedron) next to quadratic tetrahedra are not supported yet" in str(e.value)
