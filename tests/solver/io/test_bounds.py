"""Files that declare more than they may expand to are refused before anything is allocated.

Each crafted file is a few hundred bytes declaring a size its reader would
allocate (terabytes), loop over, or decompress. The helpers are shared with
the service tests (uploads, tetrahedralization).
"""

from __future__ import annotations

import base64
import struct
import subprocess
import sys
import textwrap
import zlib

import pytest

from solver.errors import UnreadableFileError
from solver.io import read_mesh
from solver.io.bounds import ReadBounds
from solver.io.read import read_surface
from solver.limits import MAX_CELLS, MAX_EXPANDED_BYTES, MAX_POINTS

HUGE = 900_000_000_000


def vtu_blocks(points: int, header: list[int], blocks: list[bytes]) -> bytes:
    """A zlib VTU of one tet whose Points array carries the block ``header`` and the compressed ``blocks``."""
    head = struct.pack(f"<{len(header)}Q", *header)
    data = base64.b64encode(head).decode() + base64.b64encode(b"".join(blocks)).decode()
    return (
        '<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" header_type="UInt64" '
        'compressor="vtkZLibDataCompressor">\n<UnstructuredGrid>\n'
        f'<Piece NumberOfPoints="{points}" NumberOfCells="1">\n<Points>\n'
        f'<DataArray type="Float64" NumberOfComponents="3" format="binary">{data}</DataArray>\n'
        '</Points>\n<Cells>\n<DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 3</DataArray>\n'
        '<DataArray type="Int64" Name="offsets" format="ascii">4</DataArray>\n'
        '<DataArray type="UInt8" Name="types" format="ascii">10</DataArray>\n</Cells>\n</Piece>\n'
        '</UnstructuredGrid>\n</VTKFile>\n').encode()


def lying_vtu(real_mib: int) -> bytes:
    """Block headers declaring 4 blocks of 32 KiB (128 KiB in all) over zlib data of ``real_mib`` MiB of zeros."""
    block = zlib.compress(b"\0" * (real_mib << 20 >> 2))
    return vtu_blocks(4, [4, 32768, 32768] + [len(block)] * 4, [block] * 4)


def xdmf(reference: str, form: str = "HDF") -> bytes:
    return (f'<?xml version="1.0"?>\n<Xdmf Version="3.0"><Domain><Grid Name="g" GridType="Uniform">'
            f'<Topology TopologyType="Tetrahedron" NumberOfElements="1"><DataItem DataType="Int" '
            f'Dimensions="1 4" Format="XML" Precision="8">0 1 2 3</DataItem></Topology>'
            f'<Geometry GeometryType="XYZ"><DataItem DataType="Float" Dimensions="4 3" Format="{form}" '
            f'Precision="8">{reference}</DataItem></Geometry></Grid></Domain></Xdmf>\n').encode()


def sparse_h5(path, rows: int) -> None:
    """An HDF5 file with a chunked dataset of ``rows`` x 3 doubles, never written: a few kilobytes."""
    import h5py

    with h5py.File(path, "w") as f:
        f.create_dataset("points", shape=(rows, 3), dtype="f8", chunks=(1024, 3))


def crafted(tmp_path=None) -> dict[str, tuple[dict[str, bytes], str, str | None]]:
    """Name -> (files, error code, the bound it names: points, cells, bytes or None). The first file is the main one."""
    tet = b"0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n"
    out: dict[str, tuple[dict[str, bytes], str, str | None]] = {
        "medit_points": ({"a.mesh": b"MeshVersionFormatted 2\nDimension 3\nVertices\n%d\n0 0 0 0\nEnd\n" % HUGE},
                         "too_many_points", "points"),
        "medit_cells": ({"a.mesh": b"MeshVersionFormatted 2\nDimension 3\nVertices\n4\n" + tet
                         + b"Tetrahedra\n%d\n1 2 3 4 0\nEnd\n" % HUGE}, "too_many_cells", "cells"),
        # under the bounds, but 40M lines the reader would skip one by one in a file of 90 bytes
        "medit_skipped": ({"a.mesh": b"MeshVersionFormatted 2\nDimension 3\nRequiredVertices\n40000000\n1\nEnd\n"},
                          "truncated_file", None),
        "meshb_points": ({"a.meshb": struct.pack("<5i", 1, 2, 3, 0, 3) + struct.pack("<3i", 4, 0, 2**31 - 1)
                          + b"\0" * 64}, "too_many_points", "points"),
        "tetgen_points": ({"a.node": b"%d 3 0 0\n1 0 0 0\n" % HUGE, "a.ele": b"1 4 0\n1 1 2 3 4\n"},
                          "too_many_points", "points"),
        "tetgen_attributes": ({"a.node": b"4 3 %d 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n" % HUGE,
                               "a.ele": b"1 4 0\n1 1 2 3 4\n"}, "too_many_bytes", "bytes"),
        "tetgen_element_attributes": ({"a.node": b"4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n",
                                       "a.ele": b"1 4 %d\n1 1 2 3 4\n" % HUGE}, "too_many_bytes", "bytes"),
        "ply_vertices": ({"a.ply": b"ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                          b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                          b"0 0 0\n3 0 1 2\n" % HUGE}, "too_many_points", "points"),
        "off_faces": ({"a.off": b"OFF\n3 %d 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" % HUGE}, "too_many_cells", "cells"),
        "stl_binary": ({"a.stl": b"\0" * 80 + struct.pack("<I", 4_000_000_000) + b"\0" * 100},
                       "truncated_file", None),
        "vtu_block_header": ({"a.vtu": vtu_blocks(4, [1, 2**40, 2**40, 16], [zlib.compress(b"\0" * 96)])},
                             "too_many_bytes", "bytes"),
        "vtk_field": ({"a.vtk": b"# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n"
                       b"0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 4\n"
                       b"FIELD FieldData 1\nbig 4 %d double\n0 0 0 0\n" % HUGE}, "too_many_bytes", "bytes"),
        "gmsh_nodes": ({"a.msh": b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n40000000\n1 0 0 0\n$EndNodes\n"},
                       "truncated_file", None),
        "xdmf_outside": ({"a.xdmf": xdmf("../other/points.h5:/points")}, "external_reference", None),
        "xdmf_binary": ({"a.xdmf": xdmf("/etc/hostname", "Binary")}, "external_reference", None),
    }
    if tmp_path is not None:
        sparse_h5(tmp_path / "points.h5", 10**11)
        out["xdmf_hdf5"] = ({"a.xdmf": xdmf("points.h5:/points"), "points.h5": (tmp_path / "points.h5").read_bytes()},
                            "too_many_bytes", "bytes")
    return out


LIBRARY = {"points": MAX_POINTS, "cells": MAX_CELLS, "bytes": MAX_EXPANDED_BYTES}


@pytest.mark.parametrize("case", sorted(crafted()) + ["xdmf_hdf5"])
def test_a_file_declaring_more_than_it_may_expand_to_is_refused_naming_the_bound(tmp_path, case):
    import resource

    files, code, bound = crafted(tmp_path)[case]
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
        assert len(data) < 20_000 or name.endswith(".h5")  # a few hundred bytes declaring terabytes
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(tmp_path / next(iter(files)))
    assert e.value.code == code, e.value.message
    assert "MemoryError" not in e.value.message and "allocate" not in e.value.message
    if bound is not None:
        assert e.value.details["bound"] == LIBRARY[bound] and e.value.details["declared"] > LIBRARY[bound]
        assert e.value.details["setting"] in e.value.message and f"{LIBRARY[bound]:,}" in e.value.message
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 100_000  # KiB: nothing expanded


def test_su2_and_ugrid_headers_are_bounded(tmp_path):
    su2 = tmp_path / "a.su2"
    su2.write_bytes(b"NDIME= 3\nNELEM= 1\n10 0 1 2 3 0\nNPOIN= %d\n0 0 0 0\n" % HUGE)
    ugrid = tmp_path / "a.ugrid"
    ugrid.write_bytes(b"4 0 0 %d 0 0 0\n0 0 0\n" % HUGE)
    for path, code in ((su2, "too_many_points"), (ugrid, "too_many_cells")):
        with pytest.raises(UnreadableFileError) as e:
            read_mesh(path)
        assert e.value.code == code and e.value.details["declared"] == HUGE


def test_compressed_data_that_expands_past_its_block_headers_stops_at_the_bound(tmp_path):
    path = tmp_path / "liar.vtu"
    path.write_bytes(lying_vtu(8))  # 128 KiB declared, 8 MiB real
    bounds = ReadBounds(expanded_bytes=1 << 20, bytes_setting="THE_SETTING")
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(path, bounds=bounds)
    assert e.value.code == "too_many_bytes" and e.value.details["bound"] == 1 << 20
    assert "THE_SETTING" in e.value.message
    with pytest.raises(UnreadableFileError) as e:  # without a budget the same file is still read as before
        read_mesh(path)
    assert e.value.code != "too_many_bytes"


def test_the_bounds_are_a_parameter_of_every_reader(tmp_path):
    """A surface read for tetrahedralization takes the same bounds as a mesh."""
    off = tmp_path / "a.off"
    off.write_bytes(b"OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n")
    V, F = read_surface(off)
    assert V.shape == (4, 3) and F.shape == (4, 3)
    with pytest.raises(UnreadableFileError) as e:
        read_surface(off, bounds=ReadBounds(points=3, points_setting="SURFACE_POINTS"))
    assert e.value.code == "too_many_points" and e.value.details == {
        "file": "a.off", "declared": 4, "bound": 3, "setting": "SURFACE_POINTS"}


def test_a_reader_out_of_memory_is_a_typed_error_not_the_allocators_words(tmp_path):
    """Declared sizes within the bounds can still exceed the memory a process has: the error stays typed.

    A child process limits its address space, then reads a VTU whose honest block headers declare 480 MiB
    of zeros (under every bound) in 500 KiB of zlib.
    """
    block = zlib.compress(b"\0" * (1 << 20))
    path = tmp_path / "zeros.vtu"
    n = 480 * (1 << 20) // 24
    path.write_bytes(vtu_blocks(n, [480, 1 << 20, 1 << 20] + [len(block)] * 480, [block] * 480))
    code = textwrap.dedent(f"""
        import resource, sys
        from solver.errors import UnreadableFileError
        from solver.io import read_mesh
        import meshio.vtu._vtu
        with open("/proc/self/statm") as fh:
            used = int(fh.read().split()[0]) * resource.getpagesize()
        resource.setrlimit(resource.RLIMIT_AS, (used + (256 << 20), resource.RLIM_INFINITY))
        try:
            read_mesh({str(path)!r})
        except UnreadableFileError as e:
            print(e.code, e.details.get("setting"), "|", e.message)
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                       env={"PATH": "/usr/bin:/bin", "PYTHONPATH": ":".join(p for p in sys.path if p),
                            "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"})
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.startswith("too_large_to_read MAX_EXPANDED_BYTES"), r.stdout
    assert "Unable to allocate" not in r.stdout and "MemoryError" not in r.stdout


@pytest.mark.parametrize("name, data", [
    ("short.meshb", struct.pack("<4i", 1, 2, 3, 0)),  # a keyword with no count after it
    ("negative.meshb", struct.pack("<5i", 1, 2, 3, 0, 3) + struct.pack("<3i", 4, 0, -5)),  # a count below zero
    ("cut.meshb", struct.pack("<2i", 1, 2) + b"\1"),  # cut inside a keyword
    ("short.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex x\n"),  # a count that is no number
])
def test_a_malformed_header_is_named_by_the_reader_as_a_typed_error(tmp_path, name, data):
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(UnreadableFileError):
        read_mesh(str(path))


def _h5_with(path, kind: str, secret) -> None:
    """An HDF5 file whose /points is an external link, a virtual dataset or external raw storage to ``secret``."""
    import h5py
    import numpy as np

    with h5py.File(secret, "w") as f:
        f["points"] = np.arange(12.0).reshape(4, 3)
    with h5py.File(path, "w") as f:
        if kind == "link":
            f["points"] = h5py.ExternalLink(str(secret), "/points")
        elif kind == "virtual":
            layout = h5py.VirtualLayout(shape=(4, 3), dtype="f8")
            layout[:] = h5py.VirtualSource(str(secret), "points", shape=(4, 3))
            f.create_virtual_dataset("points", layout)
        else:
            raw = secret.with_suffix(".bin")
            raw.write_bytes(np.arange(12.0).tobytes())
            f.create_dataset("points", shape=(4, 3), dtype="<f8", external=[(str(raw), 0, 96)])


@pytest.mark.parametrize("kind", ["link", "virtual", "external"])
def test_hdf5_data_in_a_file_outside_the_upload_is_refused(tmp_path, kind):
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    mesh = tmp_path / "upload"
    mesh.mkdir()
    _h5_with(mesh / "points.h5", kind, outside / "secret.h5")
    (mesh / "a.xdmf").write_bytes(xdmf("points.h5:/points"))
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(mesh / "a.xdmf")
    assert e.value.code == "external_reference", e.value.message
    assert e.value.details["file"] == "points.h5" and "elsewhere" in e.value.details["reference"]


@pytest.mark.parametrize("reals, ints, version", [("f8", "i4", 3), ("f8", "i8", 4)])  # what meshio writes
def test_a_binary_medit_file_under_the_bounds_is_walked_and_read(tmp_path, reals, ints, version):
    import meshio
    import numpy as np

    from solver.testing import cube_mesh

    V, T = cube_mesh(3)
    V = V.astype(reals)
    path = tmp_path / "cube.meshb"
    meshio.write(path, meshio.Mesh(V, [("tetra", T.astype(ints))],
                                   cell_data={"medit:ref": [(np.arange(len(T)) % 3).astype(ints)]}))
    assert struct.unpack("<2i", path.read_bytes()[:8]) == (1, version)
    mesh = read_mesh(path)
    np.testing.assert_array_equal(mesh.V, V.astype(float))
    assert len(mesh.T) == len(T)
    # the walk sizes every keyword: a bound one below the file's counts is what refuses it
    for bounds, code in ((ReadBounds(points=len(V) - 1), "too_many_points"),
                         (ReadBounds(cells=len(T) - 1), "too_many_cells")):
        with pytest.raises(UnreadableFileError) as e:
            read_mesh(path, bounds=bounds)
        assert e.value.code == code and e.value.details["declared"] == (len(V) if "points" in code else len(T))


#: Every volume format meshio writes and tetmorph reads, with the writer's options (ASCII and binary).
WRITTEN = {"vtu": ("a.vtu", {}), "vtu_ascii": ("a.vtu", {"binary": False}), "vtk": ("a.vtk", {}),
           "vtk_ascii": ("a.vtk", {"binary": False}), "gmsh22": ("a.msh", {"file_format": "gmsh22", "binary": False}),
           "gmsh22_binary": ("a.msh", {"file_format": "gmsh22", "binary": True}),
           "gmsh41": ("a.msh", {"file_format": "gmsh", "binary": False}),
           "gmsh41_binary": ("a.msh", {"file_format": "gmsh", "binary": True}),
           "medit": ("a.mesh", {}), "medit_binary": ("a.meshb", {}), "tetgen": ("a.node", {}), "su2": ("a.su2", {}),
           "xdmf": ("a.xdmf", {}), "med": ("a.med", {}), "h5m": ("a.h5m", {}), "cgns": ("a.cgns", {}),
           "abaqus": ("a.inp", {}), "nastran": ("a.bdf", {}), "dolfin": ("a.xml", {}), "tecplot": ("a.dat", {})}


@pytest.mark.parametrize("case", sorted(WRITTEN))
def test_every_format_is_held_to_the_bounds_at_its_own_counts(tmp_path, case):
    """A mesh as its writer writes it reads at bounds equal to its counts, and is refused one below.

    Formats that declare counts are refused before reading ("declares"); the others once read
    ("holds"), under the same settings.
    """
    import meshio

    from solver.testing import cube_mesh

    V, T = cube_mesh(3)
    name, options = WRITTEN[case]
    path = tmp_path / name
    meshio.write(path, meshio.Mesh(V, [("tetra", T)]), **options)
    mesh = read_mesh(path, bounds=ReadBounds(points=len(V), cells=len(T)))
    assert len(mesh.V) == len(V) and len(mesh.T) == len(T)
    for bounds, code, count in ((ReadBounds(points=len(V) - 1), "too_many_points", len(V)),
                                (ReadBounds(cells=len(T) - 1), "too_many_cells", len(T))):
        with pytest.raises(UnreadableFileError) as e:
            read_mesh(path, bounds=bounds)
        assert e.value.code == code, e.value.message
        assert e.value.details["declared"] == count and e.value.details["bound"] == count - 1


def _binary_gmsh41(tmp_path) -> tuple[bytes, int, int]:
    import meshio

    from solver.testing import cube_mesh

    V, T = cube_mesh(3)
    path = tmp_path / "w.msh"
    meshio.write(path, meshio.Mesh(V, [("tetra", T)]), file_format="gmsh", binary=True)
    return path.read_bytes(), len(V), len(T)


@pytest.mark.parametrize("variant", ["4.1", "4", "4.10", "crlf"])
def test_binary_gmsh_headers_meshio_reads_as_4_1_are_bounded(tmp_path, variant):
    data, n_points, _ = _binary_gmsh41(tmp_path)
    if variant == "crlf":
        data = data.replace(b"$Nodes\n", b"$Nodes\r\n", 1)
    else:
        data = data.replace(b"\n4.1 1 8\n", f"\n{variant} 1 8\n".encode(), 1)
    path = tmp_path / "a.msh"
    path.write_bytes(data)
    assert len(read_mesh(path).V) == n_points  # the reader reads it
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(path, bounds=ReadBounds(points=n_points - 1))
    assert e.value.code == "too_many_points" and "declares" in e.value.message  # before reading


def test_a_binary_gmsh_element_block_larger_than_its_section_is_refused(tmp_path):
    data, _, n_cells = _binary_gmsh41(tmp_path)
    k = data.index(b"$Elements\n") + len(b"$Elements\n") + 4 * 8  # the section's four size_t, then block 1
    header = struct.unpack("<iiiQ", data[k:k + 20])
    assert header[3] == n_cells  # one tetra block
    path = tmp_path / "a.msh"
    path.write_bytes(data[:k] + struct.pack("<iiiQ", *header[:3], 10**12) + data[k + 20:])
    with pytest.raises(UnreadableFileError) as e:
        read_mesh(path)
    assert e.value.code == "too_many_cells" and e.value.details["declared"] == 10**12
    assert "more than the" in e.value.message


def test_a_damaged_hdf5_file_gets_a_typed_error(tmp_path):
    import meshio
    import numpy as np

    from solver.errors import SolverError
    from solver.testing import cube_mesh

    V, T = cube_mesh(2)
    clean = tmp_path / "clean.h5m"
    meshio.write(clean, meshio.Mesh(V, [("tetra", T)]))
    data = clean.read_bytes()
    rng = np.random.default_rng(7)
    untyped = []
    for k in range(60):  # a few bytes changed at random, as a broken transfer does
        damaged = bytearray(data)
        for at in rng.integers(0, len(data), 4):
            damaged[at] = int(rng.integers(0, 256))
        path = tmp_path / f"d{k}.h5m"
        path.write_bytes(bytes(damaged))
        try:
            read_mesh(path)
        except SolverError:
            pass
        except Exception as e:  # noqa: BLE001 - what the test counts
            untyped.append((k, type(e).__name__, str(e)[:80]))
    assert untyped == []
