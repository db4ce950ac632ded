"""File formats the service reads and writes, by extension or name, and what each keeps.

Two kinds of formats are offered. The formats of :mod:`solver.io.registry`,
each written back in place by a module of its own (Gmsh, VTU, legacy VTK,
Medit, TetGen, Nastran, Abaqus/CAE decks with their includes, and the CAE
decks registered beside them), are looked up there first: their names,
aliases and extensions, their titles, what they read and refuse, and whether
a mesh of another format may be converted to them (``writes``); a format
that is written back in place only is offered for uploads and for the
download of a mesh read from it, never as the target of a conversion. The
meshio formats are offered when the libraries their reader and writer import
are installed (:data:`NEEDS`); :func:`measure` finds what each really
round-trips (node sets, quadratic tetrahedra, mixed elements) by writing and
reading small meshes, and :func:`capabilities` answers that table with the
registered formats' rows.

Examples
--------
>>> resolve_format("inp")
('abaqus', '.inp')
>>> resolve_format(None, "part.msh")
('gmsh', '.msh')
"""

from __future__ import annotations

import functools
import importlib.util
import io
import os
import re
import tempfile
import threading
import weakref
import zipfile
from pathlib import Path
from typing import Any

import meshio
import numpy as np

from solver.errors import InvalidMeshError, SolverError
from solver.io import PATCHERS, read_mesh, write_mesh
from solver.io.formats import a_format, describe
from solver.io.registry import FORMATS as REGISTERED
from solver.io.registry import FileFormat, by_extension, own_format
from solver.mesh import Mesh

from .errors import ServiceError

__all__ = ["resolve_format", "export_mesh", "check_export", "MESH_FORMATS", "SURFACE_FORMATS", "NEEDS", "available",
           "capabilities", "scrubbed", "offered", "registered", "in_place_only", "format_keys"]

#: Preferred extension of each meshio format the service knows.
MESH_FORMATS = {
    "abaqus": ".inp", "gmsh": ".msh", "gmsh22": ".msh", "vtu": ".vtu", "vtk": ".vtk",
    "medit": ".mesh", "tetgen": ".node", "nastran": ".bdf", "xdmf": ".xdmf", "ansys": ".msh",
    "avsucd": ".avs", "dolfin-xml": ".xml", "exodus": ".e", "flac3d": ".f3grid", "mdpa": ".mdpa",
    "med": ".med", "netgen": ".vol", "permas": ".dato", "su2": ".su2", "ugrid": ".ugrid",
    "cgns": ".cgns", "h5m": ".h5m", "hmf": ".hmf", "tecplot": ".dat",
}
#: The library meshio needs for a format (beyond meshio's own dependencies).
NEEDS = {"xdmf": "h5py", "med": "h5py", "h5m": "h5py", "cgns": "h5py", "hmf": "h5py", "exodus": "netCDF4"}
#: meshio readers that fail on valid files under numpy 2 (meshio 5.3.5 reads ASCII UGRID with
#: ``np.fromfile(sep=" ")``, which numpy 2 refuses where numpy 1 stopped at the next section): not offered.
BROKEN_ON_NUMPY2 = {"ugrid"}
#: Closed-surface formats accepted by the tetrahedralize resource.
SURFACE_FORMATS = {"stl": ".stl", "obj": ".obj", "ply": ".ply", "off": ".off"}
#: Formats whose meshio writer fails on decks with boundary faces next to their tets (a converted
#: Abaqus deck), found by tests/service/api/test_health.py::test_every_offered_format_downloads.
FAIL_WITH_FACES = {"flac3d", "med", "su2", "h5m"}
#: Formats written under one name and read under another.
_READ_AS = {"gmsh22": "gmsh"}
#: Preferred format of an ambiguous extension (after the registered formats' extensions).
_PREFERRED = {".msh": "gmsh"}


@functools.cache
def available(name: str) -> bool:
    """True if the libraries format ``name`` needs are installed (and read it with the installed numpy)."""
    if name in BROKEN_ON_NUMPY2 and int(np.__version__.split(".")[0]) >= 2:
        return False
    need = NEEDS.get(name)
    return need is None or importlib.util.find_spec(need) is not None


def registered() -> dict[str, FileFormat]:
    """The formats of :mod:`solver.io.registry` that the service reads: a reader of their own, or meshio's."""
    return {n: f for n, f in REGISTERED.items()
            if f.read is not None or n in meshio._helpers.reader_map}


def in_place_only(name: str | None) -> bool:
    """True for a registered format that is written back in place only (``writes=False``), never converted to.

    Examples
    --------
    >>> in_place_only("abaqus"), in_place_only("vtu")
    (False, False)
    """
    f = REGISTERED.get(name or "")
    return f is not None and not f.writes


def offered() -> dict[str, str]:
    """The mesh formats this installation reads and writes: format name to its extension.

    The measured meshio formats whose libraries are present, and the registered
    formats (those written back in place only included: a mesh read from one
    downloads in it).
    """
    return {r["name"]: r["extension"] for r in capabilities() if r["available"]}


def format_keys(allowed: dict[str, str]) -> set[str]:
    """Every name, alias and extension (lower case, without the dot) that means a format of ``allowed``.

    Examples
    --------
    >>> sorted(format_keys({"abaqus": ".inp", "stl": ".stl"}))
    ['abaqus', 'inp', 'stl']
    """
    keys = set(allowed) | {e.lstrip(".") for e in allowed.values()}
    for name in allowed:
        f = REGISTERED.get(name)
        if f is not None:
            keys |= set(f.aliases) | {e.lstrip(".") for e in f.extensions}
    return keys


def _own_extension(f: FileFormat, key: str, allowed: dict[str, str]) -> str:
    """The extension a registered format is written with when asked for by ``key`` (its own when an extension)."""
    ext = key if key.startswith(".") else "." + key
    return ext if ext in f.extensions else allowed[f.name]


def resolve_format(fmt: str | None, filename: str | None = None,
                   allowed: dict[str, str] | None = None) -> tuple[str, str]:
    """Resolve a format given by name or extension, or from a file name.

    Parameters
    ----------
    fmt : str, optional
        meshio format name (``"abaqus"``) or extension (``"inp"``, ``".inp"``).
    filename : str, optional
        Used when ``fmt`` is not given.
    allowed : dict, optional
        Format name to extension; defaults to the offered mesh formats.

    Returns
    -------
    (format, extension)

    Raises
    ------
    ServiceError
        422 ``unknown_format`` naming the accepted formats (and the missing
        library of a known format this installation cannot handle).
    """
    allowed = allowed or offered()
    known = ", ".join(sorted(format_keys(allowed)))

    def missing(name: str) -> ServiceError:
        return ServiceError("unknown_format", f"format {name!r} needs the Python package {NEEDS[name]!r}, "
                            f"which this installation lacks; accepted: {known}", format=name,
                            needs=NEEDS[name])

    if fmt:
        key = fmt.strip().lower()
        own = own_format(key)  # the registry first, as solver.io.formats.format_of reads it
        if own is not None and own.name in allowed:
            return own.name, _own_extension(own, key, allowed)
        if key in allowed:
            return key, allowed[key]
        if key in MESH_FORMATS and allowed is not SURFACE_FORMATS and not available(key):
            raise missing(key)
        ext = key if key.startswith(".") else "." + key
        names = [n for n in meshio.extension_to_filetypes.get(ext, []) if n in allowed]
        if names:
            return _PREFERRED.get(ext, names[0]), ext
        raise ServiceError("unknown_format", f"unknown format {fmt!r}; accepted: {known}", format=fmt[:40])
    if filename:
        name_l = filename.lower()
        own = by_extension(name_l)
        if own is not None and own.name in allowed:
            return own.name, max((e for e in own.extensions if name_l.endswith(e)), key=len)
        for ext in sorted(meshio.extension_to_filetypes, key=len, reverse=True):
            if name_l.endswith(ext):
                names = [n for n in meshio.extension_to_filetypes[ext] if n in allowed]
                if names:
                    return _PREFERRED.get(ext, names[0]), ext
        surfaces = ""
        if {"stl", "obj"} <= set(allowed) and len(allowed) > len(SURFACE_FORMATS):
            surfaces = ("; a surface is accepted too, as STL or OBJ (or PLY, OFF), and can be tetrahedralized into "
                        "a volume mesh (POST /v1/tetrahedralize; Tetrahedralize in the editor)")
        raise ServiceError("unknown_format", f"cannot tell the format of {filename!r} from its extension; "
                           f"pass format= (accepted: {known}){surfaces}", filename=filename)
    raise ServiceError("unknown_format", "no file name and no format given")


def scrubbed(e: SolverError, *folders: str | os.PathLike[str]) -> SolverError:
    """The error with server paths (the data or a temporary directory) cut from its message and details."""

    def clean(text: str) -> str:
        for d in folders:
            text = text.replace(os.fspath(d).rstrip("/") + "/", "")
        return re.sub(r"/\S*/(tetmorph-[\w-]+|tmp\w*)/", "", text)

    def walk(v: Any) -> Any:
        if isinstance(v, str):
            return clean(v)
        if isinstance(v, dict):
            return {k: walk(x) for k, x in v.items()}
        if isinstance(v, list):
            return [walk(x) for x in v]
        return v

    msg = clean(e.message)
    if msg != e.message:
        e.message = msg
        e.args = (msg,)
    e.details = walk(e.details)
    return e


def export_mesh(mesh: Mesh, V: np.ndarray, fmt: str, stem: str, quality: bool = False, lossy: bool = False
                ) -> tuple[bytes, str, str, list[dict[str, Any]]]:
    """Write ``mesh`` with positions ``V`` in a format, as bytes.

    With ``quality`` the per-element metrics are written as cell data where
    the format stores it. Formats that write several files (TetGen ``.node``
    + ``.ele``) come back as one zip archive. A format that cannot hold
    something the mesh carries (sets, an element type) is refused unless
    ``lossy``; then the losses come back as the fourth value.

    A deck written back to its own format with the files it includes comes
    back as a zip too, each included file under its path relative to the deck
    (``include/nodes.inp``).

    Returns
    -------
    (body, filename, media_type, dropped)

    Raises
    ------
    InvalidMeshError
        meshio cannot write the mesh in that format, ``lossy_write`` (no server path in the message), or
        ``unwritable_format`` for a format written back in place only and a mesh read from another.
    """
    name, ext = resolve_format(fmt)
    refuse_conversion(mesh, name)
    while f"{stem}{ext}" in mesh.companions:  # the deck would be written over a file it includes
        stem += "_deck"
    with tempfile.TemporaryDirectory(prefix="tetmorph-export-") as tmp:
        path = Path(tmp) / f"{stem}{ext}"
        try:
            written = write_mesh(mesh, V, path, file_format=name, quality=quality, lossy=lossy)
        except SolverError as e:
            raise scrubbed(e, tmp) from None
        dropped = list(written.dropped) if written is not None else []
        files = sorted(p for p in Path(tmp).rglob("*") if p.is_file())
        if len(files) == 1:
            return files[0].read_bytes(), files[0].name, "application/octet-stream", dropped
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
            for p in files:
                z.write(p, arcname=p.relative_to(tmp).as_posix())
        return buf.getvalue(), f"{stem}.{name}.zip", "application/zip", dropped


def refuse_conversion(mesh: Mesh, name: str) -> None:
    """Refuse to write ``mesh`` in a format that is written back in place only, unless it was read from it.

    Raises
    ------
    InvalidMeshError
        422 ``unwritable_format`` (details ``format``, ``mesh_format``, ``in_place_only``).
    """
    if not in_place_only(name) or mesh.file_format == name:
        return
    own = REGISTERED[name]
    source = mesh.file_format if mesh.file_format not in (None, "arrays") else None
    was = f"was read from {a_format(source)}" if source else "was given as arrays"
    converts = sorted(n for n, f in REGISTERED.items() if f.writes) + ["vtu", "gmsh"]
    raise InvalidMeshError(
        f"{describe(name)} is written back only to decks read from it (the deck patched in place); this mesh "
        f"{was}. Download it in its own format, or convert it to a format that takes other meshes "
        f"({', '.join(dict.fromkeys(converts))}, ...: GET /v1/formats, converts_to)",
        code="unwritable_format", format=name, title=own.title, mesh_format=mesh.file_format, in_place_only=True)


#: Per mesh, the ``(format, quality, lossy)`` answers :func:`check_export` found writable.
_WRITABLE: weakref.WeakKeyDictionary[Mesh, set[tuple[str, bool, bool]]] = weakref.WeakKeyDictionary()
_WRITABLE_LOCK = threading.Lock()


def check_export(mesh: Mesh, fmt: str, quality: bool = False, lossy: bool = False) -> tuple[str, str]:
    """Refuse a file answer the format cannot write for this mesh, before anything is solved or committed.

    What a format can hold (sets, element types, boundary faces next to the
    tets) depends on the mesh, not on its positions, so the rest shape is
    written once to a temporary directory and thrown away; a pair found
    writable is remembered for as long as the mesh is held.

    Returns
    -------
    (format, extension)
        As :func:`resolve_format`.

    Raises
    ------
    ServiceError
        ``unknown_format``.
    LossyWriteError, InvalidMeshError
        ``lossy_write`` (unless ``lossy``), ``unwritable_format`` (a format written back in place only, and
        a mesh read from another): the errors :func:`export_mesh` would raise after the solve.
    """
    name, ext = resolve_format(fmt)
    refuse_conversion(mesh, name)
    key = (name, quality, lossy)
    with _WRITABLE_LOCK:
        known = key in _WRITABLE.get(mesh, ())
    if not known:
        export_mesh(mesh, mesh.V, name, "check", quality, lossy)
        with _WRITABLE_LOCK:
            _WRITABLE.setdefault(mesh, set()).add(key)
    return name, ext


def _probe_meshes() -> dict[str, meshio.Mesh]:
    """Tiny meshes for the round trips: linear tets with a node set, tetra10, a hexahedron beside tets."""
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1.0]])
    T = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])
    lin = meshio.Mesh(P, [("tetra", T)], point_sets={"TOP": np.array([3, 4])})
    mids = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
    Q = np.vstack([P[:4], [(P[a] + P[b]) / 2 for a, b in mids]])
    quad = meshio.Mesh(Q, [("tetra10", np.arange(10)[None])])
    H = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1],
                  [0.5, 0.5, 2.0]])
    mixed = meshio.Mesh(H, [("hexahedron", np.arange(8)[None]), ("pyramid", np.array([[4, 5, 6, 7, 8]]))])
    return {"tets": lin, "quadratic": quad, "mixed": mixed}


def _round_trip(src: meshio.Mesh, name: str, ext: str, tmp: Path) -> Mesh | None:
    """Read ``src`` as a service mesh, write it as ``name``, read it back; None if any step fails."""
    sets = {k: np.asarray(v) for k, v in src.point_sets.items()}  # meshio's VTU writer drops them from src
    a = tmp / f"src_{name}.vtu"
    meshio.write(a, src)
    sub = tmp / name
    sub.mkdir(exist_ok=True)
    b = sub / f"probe{ext}"
    try:
        m = read_mesh(a)
        write_mesh(m, m.V, b, file_format=name, point_sets=sets or None)
        return read_mesh(b, _READ_AS.get(name, name))
    except (Exception, SystemExit):  # noqa: BLE001 - a failed round trip is the answer (meshio may exit)
        return None


_PROBES = ("tets", "quadratic", "mixed")
#: Seconds one round trip may take.
PROBE_TIMEOUT_S = 20.0


def _probe(name: str, kind: str, tmp: Path) -> bool:
    """One round trip of probe mesh ``kind`` through format ``name``."""
    src = _probe_meshes()[kind]
    back = _round_trip(src, name, MESH_FORMATS[name], tmp)
    if back is None:
        return False
    if kind == "tets":
        return back.T.shape[0] == 2
    if kind == "quadratic":
        return back.info().get("element_order") == 2
    return back.elements == 2


def _probe_all(skip: set[tuple[str, str]]) -> None:
    """Child process: print one JSON line ``[name, kind, ok, sets]`` per probe not in ``skip``."""
    import json
    import sys

    with tempfile.TemporaryDirectory(prefix="tetmorph-probe-") as d:
        for name in MESH_FORMATS:
            if not available(name):
                continue
            for kind in _PROBES:
                if (name, kind) in skip:
                    continue
                print(json.dumps([name, kind, None, None]), flush=True)  # started: a crash blames it
                sets = False
                ok = _probe(name, kind, Path(d))
                if ok and kind == "tets":
                    back = _round_trip(_probe_meshes()["tets"], name, MESH_FORMATS[name], Path(d))
                    sets = back is not None and sorted(np.asarray(back.sets.get("TOP", [])).tolist()) == [3, 4]
                print(json.dumps([name, kind, ok, sets]), flush=True)
    sys.stdout.flush()


#: Where ``python -m service.formats`` writes what :func:`measure` found.
MEASURED = Path(__file__).with_name("format_table.py")


@functools.cache
def capabilities() -> tuple[dict[str, Any], ...]:
    """The formats table of GET /v1/formats: :data:`MEASURED` and the registered formats, as offered here.

    A meshio format whose library is missing here is listed with ``available``
    false and is not offered. A registered format comes from
    :mod:`solver.io.registry`: its measured row where it has one (``abaqus``),
    else a row of what the registry says, with ``sets``, ``quadratic`` and
    ``mixed`` None (not measured: written back in place, the file keeps
    everything but the coordinates of the nodes that moved).

    Every row says whether a morph is written back ``in_place`` (the file
    patched, nothing else changed) and whether a mesh of another format
    ``converts_to`` it; ``write`` is ``converts_to``. A format with
    ``in_place`` and not ``converts_to`` is written back only to decks read
    from it.
    """
    from .format_table import TABLE

    rows: list[dict[str, Any]] = TABLE["formats"]  # type: ignore[assignment]
    own = registered()
    out = []
    for r in rows:
        ok = available(r["name"])
        ok = ok and r["name"] not in FAIL_WITH_FACES
        write = ok and r["write"] and not in_place_only(r["name"])
        out.append({**r, "available": ok and r["read"] and (write or r["name"] in PATCHERS),
                    "read": ok and r["read"], "write": write, **_row_extras(r["name"], ok and r["read"], write)})
    measured = {r["name"] for r in rows}
    for name, f in own.items():
        if name in measured:
            continue
        out.append({"name": name, "extension": f.extensions[0], "needs": None, "available": True, "read": True,
                    "write": f.writes, "sets": None, "quadratic": None, "mixed": None,
                    **_row_extras(name, True, f.writes)})
    return tuple(out)


def _row_extras(name: str, read: bool, write: bool) -> dict[str, Any]:
    """The fields of a format's row beyond the measured ones: its title, extensions, and how it is written."""
    f = REGISTERED.get(name)
    return {"title": describe(name),
            "extensions": list(f.extensions) if f is not None else [MESH_FORMATS.get(name, "")],
            "in_place": read and name in PATCHERS, "converts_to": write,
            "reads": (f.reads or None) if f is not None else None,
            "refuses": (f.refuses or None) if f is not None else None}


def measure() -> tuple[dict[str, Any], ...]:
    """What each known format does here, measured by round trips of tiny meshes.

    The round trips run in a child process (some meshio writers end the
    process on meshes they cannot hold); a probe that ends it counts as failed.

    Returns
    -------
    tuple of dict
        ``{"name", "extension", "available", "needs", "read", "write", "sets",
        "quadratic", "mixed"}`` per format; ``sets`` means a node set survives
        the round trip, ``quadratic`` a tetra10 element, ``mixed`` a pyramid on
        a hexahedron.
    """
    import json
    import selectors
    import subprocess
    import sys

    results: dict[tuple[str, str], tuple[bool, bool]] = {}
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    for _ in range(3 * len(MESH_FORMATS)):
        code = f"from service.formats import _probe_all; _probe_all(set({sorted(results)!r}))"
        proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True, env=env)
        assert proc.stdout is not None
        sel = selectors.DefaultSelector()
        sel.register(proc.stdout, selectors.EVENT_READ)
        started: tuple[str, str] | None = None
        while True:
            if not sel.select(timeout=PROBE_TIMEOUT_S):  # a probe that hangs counts as failed
                proc.kill()
                break
            line = proc.stdout.readline()
            if not line:
                break
            try:
                name, kind, ok, sets = json.loads(line)
            except ValueError:
                continue
            if ok is None:
                started = (name, kind)
            else:
                results[(name, kind)] = (bool(ok), bool(sets))
                started = None
        proc.wait()
        sel.close()
        proc.stdout.close()
        if started is None:
            break
        results[started] = (False, False)
    out = []
    for name, ext in MESH_FORMATS.items():
        ok_t, sets = results.get((name, "tets"), (False, False))
        out.append({"name": name, "extension": ext, "available": available(name), "needs": NEEDS.get(name),
                    "read": ok_t, "write": ok_t, "sets": sets and ok_t,
                    "quadratic": ok_t and results.get((name, "quadratic"), (False, False))[0],
                    "mixed": ok_t and results.get((name, "mixed"), (False, False))[0]})
    return tuple(out)


if __name__ == "__main__":  # python -m service.formats: measure and write MEASURED
    import json

    table = {"meshio": meshio.__version__, "formats": [
        {k: v for k, v in r.items() if k != "available"} for r in measure()]}
    head = '"""What each mesh format keeps, measured by ``python -m service.formats`` (do not edit)."""\n\n'
    MEASURED.write_text(head +
                        f"TABLE = {json.dumps(table, indent=1)}\n".replace("true", "True").replace("false", "False")
                        .replace("null", "None"))
    print(MEASURED, "written")
