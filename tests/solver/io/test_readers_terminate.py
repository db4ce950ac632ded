"""Every reader ends on every cut and every flipped byte of a valid file: with a mesh or a typed error.

For each format tetmorph reads (the meshio formats the service offers, the surface formats and the
formats registered in :mod:`solver.io.registry`), a small valid file (a cube of 48 tetrahedra) is cut
at several fractions of its length and one byte short, and has single bytes flipped at seeded
offsets. Each such file is read by :func:`solver.read_mesh` in a child process that the test stops
when a read runs past its time bound: a read that never returns is a failure naming the format, the
case and the byte offset, as is any exception that is not a :class:`~solver.errors.SolverError`.
"""

from __future__ import annotations

import io
import multiprocessing
import multiprocessing.connection
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import meshio
import numpy as np
import pytest

from service.formats import MESH_FORMATS, SURFACE_FORMATS, available
from solver import read_mesh
from solver.errors import SolverError, UnreadableFileError
from solver.io import mesh_from_meshio, write_mesh
from solver.io.guarded import MAX_END_READS, guarded_open, stop_at_end
from solver.io.registry import FORMATS
from solver.testing import cube_mesh

pytestmark = pytest.mark.fuzz

#: Where each valid file is cut, as fractions of its length (and one byte short of it).
FRACTIONS = (0.1, 0.3, 0.5, 0.7, 0.9, 0.97)
#: Single-byte flips per file, seeded 0 .. FLIPS - 1.
FLIPS = 12
#: Seconds one read may take (a cube of 48 tetrahedra reads in milliseconds).
READ_S = 8.0
#: Seconds all the reads of one format may take together.
BATCH_S = 20.0


# ------------------------------------------------------------------ the valid files


def _cube() -> tuple[np.ndarray, np.ndarray]:
    return cube_mesh(2)


def _boundary(T: np.ndarray) -> np.ndarray:
    """The triangles of the faces of ``T`` that only one tetrahedron holds."""
    faces = np.concatenate([T[:, [1, 2, 3]], T[:, [0, 3, 2]], T[:, [0, 1, 3]], T[:, [0, 2, 1]]])
    keys = np.sort(faces, axis=1)
    _, first, counts = np.unique(keys, axis=0, return_index=True, return_counts=True)
    return faces[np.sort(first[counts == 1])]


def _cdb(path: Path) -> None:
    """An Ansys MAPDL archive of the cube: one NBLOCK, a SOLID EBLOCK of SOLID285 tetrahedra."""
    V, T = _cube()
    rows = ["/COM,cube of 48 tetrahedra", "ET,       1,285",
            f"NBLOCK,6,SOLID,{len(V):10d},{len(V):10d}", "(3i8,6e20.13)"]
    rows += [f"{i + 1:8d}{0:8d}{0:8d}" + "".join(f"{x:20.13E}" for x in p) for i, p in enumerate(V)]
    rows += ["N,R5.3,LOC,       -1,", f"EBLOCK,19,SOLID,{len(T):10d},{len(T):10d}", "(19i8)"]
    rows += ["".join(f"{v:8d}" for v in (1, 1, 1, 1, 0, 0, 0, 0, 4, 0, e + 1, *(t + 1))) for e, t in enumerate(T)]
    rows += [f"{-1:8d}", "FINISH"]
    path.write_text("\n".join(rows) + "\n")


def _lsdyna(path: Path) -> None:
    """An LS-DYNA keyword deck of the cube: ``*NODE`` (I8, 3E16) and one-card ``*ELEMENT_SOLID`` tetrahedra."""
    V, T = _cube()
    rows = ["*KEYWORD", "*NODE"]
    rows += [f"{i + 1:8d}" + "".join(f"{x:16.8f}" for x in p) for i, p in enumerate(V)]
    rows += ["*ELEMENT_SOLID"]
    rows += ["".join(f"{v:8d}" for v in (e + 1, 1, *(t + 1), *[t[3] + 1] * 4)) for e, t in enumerate(T)]
    rows += ["*END"]
    path.write_text("\n".join(rows) + "\n")


#: Writers of the registered formats that meshio does not write, from what their readers document.
OWN_WRITERS: dict[str, Callable[[Path], None]] = {"ansys-cdb": _cdb, "lsdyna": _lsdyna}


def _formats() -> list[str]:
    names = [n for n in MESH_FORMATS if available(n)] + sorted(SURFACE_FORMATS)
    return names + sorted(n for n in FORMATS if n not in names)


def _extension(name: str) -> str:
    if name in MESH_FORMATS:
        return MESH_FORMATS[name]
    if name in SURFACE_FORMATS:
        return SURFACE_FORMATS[name]
    return FORMATS[name].extensions[0]


def _write_valid(name: str, folder: Path) -> list[Path]:
    """The valid file of format ``name`` in ``folder``: the files to damage, the main one first."""
    path = folder / f"cube{_extension(name)}"
    V, T = _cube()
    if name == "tetgen":
        mesh = mesh_from_meshio(meshio.Mesh(V, [("tetra", T)]))
        write_mesh(mesh, V, path, file_format="tetgen")
        return [path, path.with_suffix(".ele")]
    if name in OWN_WRITERS:
        OWN_WRITERS[name](path)
        return [path]
    if name not in meshio._helpers._writer_map:
        pytest.skip(f"{name!r} is registered with a reader of tetmorph's own but neither meshio nor this test "
                    "writes it: add a writer of its valid file to OWN_WRITERS")
    if name in SURFACE_FORMATS:
        F = _boundary(T)
        used = np.unique(F)
        renumber = np.full(len(V), -1)
        renumber[used] = np.arange(len(used))
        m = meshio.Mesh(V[used], [("triangle", renumber[F])])
    else:
        m = meshio.Mesh(V, [("tetra", T)])
    meshio.write(path, m, file_format=name)
    return [path]


# ------------------------------------------------------------------ the damaged files


@dataclass(frozen=True)
class Case:
    """One damaged copy of the valid files: ``target`` cut at ``offset`` or its byte there flipped."""

    label: str
    target: str
    offset: int
    folder: str
    main: str

    def where(self) -> str:
        return f"{self.label} of {self.target}" + (f" at byte {self.offset}" if self.offset >= 0 else "")


def _cases(files: list[Path], root: Path) -> list[Case]:
    """The valid files (case 0, which must read as a mesh), then every cut and flip of each file to damage."""
    cases: list[Case] = []

    def copy(label: str, target: Path, offset: int, data: bytes | None) -> None:
        folder = root / f"case{len(cases)}"
        folder.mkdir()
        for f in files[0].parent.iterdir():
            shutil.copy(f, folder / f.name)
        if data is not None:
            (folder / target.name).write_bytes(data)
        cases.append(Case(label, target.name, offset, str(folder), files[0].name))

    copy("valid file", files[0], -1, None)
    for target in files:
        raw = target.read_bytes()
        for frac in FRACTIONS:
            cut = int(len(raw) * frac)
            copy(f"cut at {frac:.0%}", target, cut, raw[:cut])
        copy("cut one byte short", target, len(raw) - 1, raw[:-1])
        for k in range(FLIPS):
            rng = np.random.default_rng(k)
            at = int(rng.integers(len(raw)))
            damaged = bytearray(raw)
            damaged[at] ^= int(rng.integers(1, 256))
            copy(f"byte flip (seed {k})", target, at, bytes(damaged))
    return cases


# ------------------------------------------------------------------ the reads, in a child process


def _outcome(path: str, name: str) -> tuple[str, str]:
    """``("mesh", "n nodes")``, ``("typed", "type: code: message")`` or ``("untyped", "type: message")``."""
    try:
        mesh = read_mesh(path, file_format=name)
    except SolverError as e:
        return "typed", f"{type(e).__name__}: {e.code}: {e.message}"
    except BaseException as e:  # noqa: BLE001 - what the test reports
        return "untyped", f"{type(e).__name__}: {str(e)[:300]}"
    return "mesh", f"{len(mesh.V)} nodes"


def _reader(conn: multiprocessing.connection.Connection, name: str, cases: list[tuple[int, str]]) -> None:
    for i, path in cases:
        conn.send(("start", i, ""))
        kind, what = _outcome(path, name)
        conn.send((kind, i, what))
    conn.close()


def _read_all(name: str, cases: list[Case]) -> dict[int, tuple[str, str]]:
    """The outcome of each case: read in order by child processes, each read within ``READ_S``.

    A read that runs past its bound is stopped with its child (``"hang"``) and the next child goes on
    with the following case, while the batch's ``BATCH_S`` last; cases left then are ``"not run"``.
    """
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload([__name__])
    todo = [(i, str(Path(c.folder) / c.main)) for i, c in enumerate(cases)]
    out: dict[int, tuple[str, str]] = {}
    deadline = time.monotonic() + BATCH_S
    while todo and time.monotonic() < deadline:
        here, there = ctx.Pipe(duplex=False)
        child = ctx.Process(target=_reader, args=(there, name, todo), daemon=True)
        child.start()
        there.close()
        current: int | None = None
        began = time.monotonic()
        try:
            while todo:
                limit = min(deadline, began + READ_S) if current is not None else deadline
                if not here.poll(max(0.0, limit - time.monotonic())):
                    if current is not None:
                        out[current] = ("hang", f"no answer within {min(READ_S, time.monotonic() - began):.0f} s")
                        todo = [t for t in todo if t[0] != current]
                    break
                try:
                    kind, i, what = here.recv()
                except EOFError:  # the child ended without answering: it crashed
                    child.join(5)
                    if current is None:
                        out.update((j, ("crash", f"the reading process exited ({child.exitcode})")) for j, _ in todo)
                        todo = []
                    else:
                        out[current] = ("crash", f"the reading process exited ({child.exitcode})")
                        todo = [t for t in todo if t[0] != current]
                    break
                if kind == "start":
                    current, began = i, time.monotonic()
                else:
                    out[i] = (kind, what)
                    todo = [t for t in todo if t[0] != i]
                    current = None
        finally:
            if child.is_alive():
                child.kill()
            child.join(5)
            here.close()
    out.update((i, ("not run", f"the {BATCH_S:.0f} s of the format's batch were spent")) for i, _ in todo)
    return out


@pytest.mark.parametrize("name", _formats())
def test_every_cut_and_flipped_byte_reads_or_is_refused_typed(tmp_path, name):
    valid = tmp_path / "valid"
    valid.mkdir()
    files = _write_valid(name, valid)
    cases = _cases(files, tmp_path)
    out = _read_all(name, cases)
    assert out[0][0] == "mesh", f"{name}: the valid file does not read: {out[0]}"
    bad = [f"{name}: {cases[i].where()}: {kind}: {what}" for i, (kind, what) in sorted(out.items())
           if kind not in ("mesh", "typed")]
    assert not bad, f"{len(bad)} of {len(cases)} reads of {name} files did not end typed:\n" + "\n".join(bad)


@pytest.mark.parametrize("name,fraction", [("mdpa", 0.1), ("mdpa", 0.5), ("tecplot", 0.5), ("tecplot", 0.97)])
def test_a_reader_that_loops_at_the_end_of_a_cut_file_is_refused_as_truncated(tmp_path, name, fraction):
    valid = tmp_path / "valid"
    valid.mkdir()
    files = _write_valid(name, valid)
    raw = files[0].read_bytes()
    cut = tmp_path / "cut"
    cut.mkdir()
    (cut / files[0].name).write_bytes(raw[: int(fraction * len(raw))])
    out = _read_all(name, [Case(f"cut at {fraction:.0%}", files[0].name, 0, str(cut), files[0].name)])
    kind, what = out[0]
    assert kind == "typed" and what.startswith("UnreadableFileError: truncated_file: "), out
    assert f"{files[0].name!r} ends before its reader" in what and "truncated" in what, what


def test_files_opened_outside_a_guarded_read_are_the_built_in_ones(tmp_path):
    p = tmp_path / "f.txt"
    with guarded_open(p, "w") as f:
        assert type(f) is io.TextIOWrapper
        f.write("one line\n")
    with guarded_open(p, "rb") as f:
        assert type(f) is io.BufferedReader
    with stop_at_end("mdpa"), guarded_open(p, "a") as f:  # written: never guarded
        assert type(f) is io.TextIOWrapper


@pytest.mark.parametrize("mode", ["r", "rb"])
def test_a_guarded_file_read_at_its_end_too_often_stops_the_read(tmp_path, mode):
    p = tmp_path / "part.dat"
    p.write_text("BEGIN\n1 2 3\n")
    with stop_at_end("tecplot"), guarded_open(p, mode) as f:  # a reader ending at the end: untouched
        assert f.read() and not f.read() and not f.readline() and f.name == str(p)
        f.seek(0)
        assert [line.strip() for line in f] == (["BEGIN", "1 2 3"] if mode == "r" else [b"BEGIN", b"1 2 3"])
    with pytest.raises(UnreadableFileError) as e, stop_at_end("tecplot"), guarded_open(p, mode) as f:
        for _ in range(min(2 * MAX_END_READS, 100_000)):  # a bounded loop, guarded or not
            f.readline()
    assert e.value.code == "truncated_file" and e.value.details["file"] == "part.dat"
    assert e.value.details["reads"] == MAX_END_READS + 1


def test_the_formats_include_the_registered_and_surface_ones():
    names = _formats()
    assert set(FORMATS) <= set(names) and set(SURFACE_FORMATS) <= set(names)
    assert {"mdpa", "tecplot", "tetgen", "vtu"} <= set(names)

