"""Every format written back in place is one registered entry, and a new format is one module.

A format's entry (:class:`solver.io.registry.FileFormat`) holds its name, title,
extensions, sniffer, reader and in-place writer: :func:`format_of`,
:func:`detect_format`, :func:`describe`, :func:`read_mesh` and :func:`write_mesh`
find the format through it and nothing else.
"""

from __future__ import annotations

import re

import meshio
import numpy as np
import pytest

from solver.errors import UnreadableFileError
from solver.io import detect_format, format_of, mesh_from_meshio, read_mesh, write_mesh
from solver.io.formats import describe
from solver.io.patchers import PATCHERS, Patcher, patcher_for
from solver.io.registry import FORMATS, FileFormat, register_format
from solver.testing import cube_mesh

#: The formats meshio reads or writes that tetmorph writes back in place with a module of its own.
BUILT_IN = ("gmsh", "vtu", "vtk", "medit", "tetgen", "nastran")


def test_every_format_written_back_in_place_is_a_registered_format():
    assert set(BUILT_IN) | {"abaqus"} <= set(PATCHERS)
    for name, patcher in PATCHERS.items():
        f = FORMATS.get(name)
        assert f is not None, f"{name}: a patcher without a registered format"
        assert f.patcher is patcher, name
        assert describe(name) == f.title, name
        assert f.extensions and all(e.startswith(".") and e == e.lower() for e in f.extensions), name
        assert {e.lstrip(".") for e in f.extensions} == set(patcher.extensions), name
        assert f.aliases == patcher.aliases, name
        for ext in f.extensions:
            assert format_of(f"part{ext}") == name and format_of(f"DIR.X/PART{ext.upper()}") == name, ext
            assert format_of("part.dat", ext) == name and format_of("part.dat", ext.lstrip(".")) == name, ext
            assert patcher_for(f"part{ext}") is patcher, ext
        for key in (name, *f.aliases):
            assert format_of("part.dat", key) == name and patcher_for("part.dat", key) is patcher, key


@pytest.mark.parametrize("name", BUILT_IN)
def test_a_built_in_format_sniffs_the_files_it_writes(tmp_path, name):
    f = FORMATS[name]
    assert f.writes and f.sniff is not None and f.reads and f.refuses, name
    V, T = cube_mesh(2)
    path = tmp_path / f"cube{f.extensions[0]}"
    write_mesh(mesh_from_meshio(meshio.Mesh(V, [("tetra", T)])), V, path, file_format=name)
    data = path.read_bytes()
    assert detect_format(data[:8192], len(data)) == name
    mesh = read_mesh(path)
    assert mesh.file_format == name and mesh.raw is not None  # kept, to be written back in place
    np.testing.assert_allclose(mesh.V, V)


# ------------------------------------------------------------------ a new format, registered here

_NODE = re.compile(rb"^N ", re.MULTILINE)


def _sniff(head: bytes, size: int | None) -> bool:
    return head.startswith(b"TINYMESH ")


def _read(path: str, bounds: object) -> meshio.Mesh:
    rows = [ln.split() for ln in open(path, "rb").read().splitlines()[1:]]
    P = np.array([[float(x) for x in r[1:]] for r in rows if r[0] == b"N"])
    T = np.array([[int(x) for x in r[1:]] for r in rows if r[0] == b"T"])
    return meshio.Mesh(P, [("tetra", T)])


def _patch(raw: bytes, V: np.ndarray) -> bytes:
    lines = raw.splitlines(keepends=True)
    k = 0
    for i, line in enumerate(lines):
        if line.startswith(b"N "):
            old = np.array([float(x) for x in line.split()[1:]])
            if not np.array_equal(old, V[k]):
                lines[i] = b"N " + b" ".join(repr(float(x)).encode() for x in V[k]) + b"\n"
            k += 1
    return b"".join(lines)


def _tiny(V: np.ndarray, T: np.ndarray) -> bytes:
    rows = ["TINYMESH 1"] + [f"N {x!r} {y!r} {z!r}" for x, y, z in V.tolist()]
    rows += ["T " + " ".join(str(int(i)) for i in t) for t in T]
    return ("\n".join(rows) + "\n").encode()


def test_a_new_format_is_one_registered_entry(tmp_path):
    tiny = FileFormat(
        name="tinymesh", title="tiny test mesh (.tmx)", extensions=(".tmx",), aliases=("tiny",), sniff=_sniff,
        read=_read, writes=False, reads="N and T lines", refuses="nothing",
        patcher=Patcher("tinymesh", ("tiny",), ("tmx",), lambda raw, n: len(_NODE.findall(raw)) == n, _patch))
    V, T = cube_mesh(2)
    path = tmp_path / "cube.tmx"
    path.write_bytes(_tiny(V, T))
    beside = tmp_path / "notes.txt"
    beside.write_bytes(b"kept as it is\n")
    register_format(tiny)
    try:
        assert format_of(path) == "tinymesh" and format_of("x.dat", "tiny") == "tinymesh"
        assert detect_format(path.read_bytes(), path.stat().st_size) == "tinymesh"
        assert describe("tinymesh") == "tiny test mesh (.tmx)"
        mesh = read_mesh(path)
        assert mesh.file_format == "tinymesh" and mesh.raw == path.read_bytes() and len(mesh.T) == len(T)
        np.testing.assert_array_equal(mesh.V, V)

        unnamed = tmp_path / "cube.zzz"  # content told by the sniffer, named by the title
        unnamed.write_bytes(path.read_bytes())
        with pytest.raises(UnreadableFileError) as e:
            read_mesh(unnamed)
        assert e.value.code == "unknown_format" and e.value.details["detected"] == "tinymesh"
        assert "tiny test mesh (.tmx)" in e.value.message
        unnamed.unlink()

        before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
        P = mesh.V.copy()
        P[5] += [0.01, -0.02, 0.005]
        written = write_mesh(mesh, P, path)
        assert written.patched and written.files == [str(path)]
        after = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
        assert set(after) == set(before) and after["notes.txt"] == before["notes.txt"]
        old, new = before["cube.tmx"].splitlines(), after["cube.tmx"].splitlines()
        assert [k for k, (a, b) in enumerate(zip(old, new, strict=True)) if a != b] == [1 + 5]
        np.testing.assert_array_equal(read_mesh(path).V, P)
        assert write_mesh(mesh, mesh.V, path).patched and path.read_bytes() == before["cube.tmx"]
    finally:
        FORMATS.pop("tinymesh", None)
        PATCHERS.pop("tinymesh", None)
    assert format_of(path) is None and detect_format(path.read_bytes()) is None
