"""``/v1/meshes``: upload (file or JSON arrays), list, describe, download, delete."""

from __future__ import annotations

import io
import json
import re
import zipfile
import zlib
from typing import Annotated, Any

import numpy as np
from fastapi import APIRouter, File, Form, Query, Request, Response, UploadFile
from pydantic.json_schema import SkipJsonSchema

from solver.constraints.features import feature_candidates, feature_region
from solver.constraints.selection import select
from solver.constraints.spec import parse_spec
from solver.constraints.symmetry_candidates import abaqus_cyclic, resolve_cyclic, symmetry_candidates
from solver.errors import InvalidMeshError, UnreadableFileError
from solver.io.element_sets import SET_FORMATS, deck_element_ids, deck_node_ids
from solver.io.patch_inp import node_labels
from solver.io.read_bounds import ReadBounds, too_many
from solver.mesh import mesh_from_arrays
from solver.ops.elements import check_tet_elements, check_tets
from solver.ops.unique import unique

from ..binary import encode_bundle
from ..errors import ServiceError
from ..formats import SURFACE_FORMATS, export_mesh, offered, resolve_format
from ..models.error import error_responses
from ..models.formats import MESH_FORMAT_VALUES, UPLOAD_FORMAT_VALUES
from ..models.mesh import MeshDoc, MeshSymmetry
from ..models.spec import check_selection_ids
from ..models.uploads import Band, MeshArrays
from .deps import MeshDep, OwnerDep, RegistryDep, safe_name
from .paging import PAGE_HEADERS, CursorQuery, LimitQuery, NameQuery, page

router = APIRouter(tags=["meshes"])

_AUTH = (401, 429)


def public(meta: dict[str, Any]) -> dict[str, Any]:
    """The mesh document returned to clients."""
    return {k: meta[k] for k in ("id", "name", "format", "files", "created", "info",
                                 "tetrahedralization") if k in meta}


#: Most folders deep the name of an uploaded file may reach (``include/nodes.inp`` is one).
MAX_FOLDER_DEPTH = 8
#: Most files a zip upload may hold (its expanded size is bounded by TETMORPH_MAX_FILE_EXPANDED_MB).
MAX_ZIP_FILES = 512
#: Names the service keeps beside the uploaded files in a mesh's folder.
_RESERVED = {"meta.json"}


def _outside(parts: list[str], text: str) -> bool:
    return text.startswith("/") or bool(re.match(r"^[A-Za-z]:", text)) or ".." in parts


def stored_name(name: str | None, default: str, under: str = "") -> str:
    """The name an uploaded file is stored under, relative to the mesh's folder.

    A relative folder is kept (``include/nodes.inp``: a file a deck includes
    from there), each part cleaned as :func:`~service.api.deps.safe_name`
    cleans a file name; the folder ``under`` (the main file's own, as
    uploaded) is taken off. A name that is absolute, climbs out with ``..``
    or nests deeper than :data:`MAX_FOLDER_DEPTH` keeps its base name only.

    Examples
    --------
    >>> stored_name("include/my nodes.inp", "x"), stored_name("../x/a.inp", "x"), stored_name("/etc/passwd", "x")
    ('include/my_nodes.inp', 'a.inp', 'passwd')
    >>> stored_name("model/include/n.inp", "x", under="model")
    'include/n.inp'
    """
    text = (name or "").replace("\\", "/")
    parts = [p for p in text.split("/") if p not in ("", ".")]
    if _outside(parts, text) or len(parts) > MAX_FOLDER_DEPTH + 1:
        return safe_name(name, default)
    clean = [safe_name(p, "_") for p in parts[:-1]] + [safe_name(parts[-1] if parts else "", default)]
    top = [p for p in under.split("/") if p]
    if top and clean[:len(top)] == top and len(clean) > len(top):
        clean = clean[len(top):]
    return "/".join(clean)


def _folder_of(name: str | None) -> str:
    """The folder a main file was uploaded from, cleaned as :func:`stored_name` cleans it ("" for none)."""
    stored = stored_name(name, "mesh")
    return stored.rsplit("/", 1)[0] if "/" in stored else ""


def _unzip(data: bytes, bounds: ReadBounds, archive: str) -> tuple[dict[str, bytes], dict[str, str]]:
    """The files of a zip upload by the name each is stored under, and the name each had in the zip.

    Folder entries and ``__MACOSX/`` are left out, and one folder holding
    everything is taken off. The files and the bytes they expand to are
    counted from the zip's directory before anything is expanded, and the
    bytes again while expanding.

    Raises
    ------
    UnreadableFileError
        ``unreadable_file`` (not a zip, encrypted, damaged), ``too_many_files``, ``too_many_bytes``,
        ``include_outside`` (a member with an absolute path or ``..``).
    """
    try:
        z = zipfile.ZipFile(io.BytesIO(data))
    except (zipfile.BadZipFile, ValueError, OSError) as e:
        raise UnreadableFileError(f"{archive!r} is not a zip archive that can be read ({e})",
                                  code="unreadable_file", file=archive) from None
    with z:
        infos = [i for i in z.infolist() if not i.is_dir() and i.filename.split("/")[0] != "__MACOSX"]
        if len(infos) > MAX_ZIP_FILES:
            raise UnreadableFileError(f"{archive!r} holds {len(infos):,} files; an upload may hold at most "
                                      f"{MAX_ZIP_FILES}", code="too_many_files", file=archive,
                                      declared=len(infos), bound=MAX_ZIP_FILES)
        declared = sum(i.file_size for i in infos)
        if declared > bounds.expanded_bytes:
            raise too_many(archive, "bytes", declared, bounds)
        names = []
        for i in infos:
            text = i.filename.replace("\\", "/")
            parts = [p for p in text.split("/") if p not in ("", ".")]
            if _outside(parts, text) or not parts:
                raise UnreadableFileError(f"{archive!r} holds {i.filename!r}, a path outside the archive's "
                                          "folder; tetmorph stores an upload's files in its own folder only: "
                                          "give every file a path relative to the deck", code="include_outside",
                                          file=archive, include=i.filename[:200])
            if len(parts) > MAX_FOLDER_DEPTH + 2:  # one more: a folder holding everything is taken off below
                raise UnreadableFileError(f"{archive!r} holds {i.filename!r}, nested deeper than "
                                          f"{MAX_FOLDER_DEPTH} folders", code="unreadable_file", file=archive)
            names.append(parts)
        if len(names) > 1 and all(len(p) > 1 for p in names) and len({p[0] for p in names}) == 1:
            names = [p[1:] for p in names]  # the zip of one folder: its files relative to it
        files: dict[str, bytes] = {}
        given: dict[str, str] = {}
        left = bounds.expanded_bytes
        for i, parts in zip(infos, names, strict=True):
            clean = stored_name("/".join(parts), "file")
            if clean.count("/") + 1 != len(parts):
                raise UnreadableFileError(f"{archive!r} holds {i.filename!r}, nested deeper than "
                                          f"{MAX_FOLDER_DEPTH} folders", code="unreadable_file", file=archive)
            _no_clash(files, given, clean, i.filename, "file")
            try:
                with z.open(i) as fh:
                    body = fh.read(left + 1)
            except (zipfile.BadZipFile, RuntimeError, NotImplementedError, OSError, EOFError, zlib.error) as e:
                raise UnreadableFileError(f"{archive!r}: {i.filename!r} cannot be expanded ({e})",
                                          code="unreadable_file", file=archive) from None
            left -= len(body)
            if left < 0:
                raise too_many(archive, "bytes", bounds.expanded_bytes + 1 - left, bounds)
            files[clean], given[clean] = body, i.filename
    return files, given


def _deck_of(files: dict[str, bytes], format: str | None, allowed: dict[str, str], archive: str) -> str:
    """The file of a zip upload to read: the one file at its top level that is a mesh and no other file names."""
    top = [n for n in files if "/" not in n]
    want = resolve_format(format, None, allowed)[0] if format else None

    def fits(n: str) -> bool:
        try:
            return resolve_format(None, n, allowed)[0] == want if want else bool(resolve_format(None, n, allowed))
        except ServiceError:
            return False

    candidates = [n for n in top if fits(n)] or (top if want else [])
    if not candidates:
        raise ServiceError("unknown_format", f"{archive!r} holds no mesh file at its top level that its extension "
                           f"names (it holds {', '.join(sorted(files)[:20])}); pass format= or put the deck at "
                           "the top of the zip", filename=archive, files=sorted(files)[:50])
    lines = {m: _include_lines(files[m]) for m in candidates} if len(candidates) > 1 else {}
    named = {n for n in candidates for m in lines if m != n and n.lower().encode() in lines[m]}
    roots = [n for n in candidates if n not in named]
    if len(roots) > 1:  # TetGen's .node beside its .ele: the file of the format's own extension
        roots = [n for n in roots if n.lower().endswith(allowed[resolve_format(format, n, allowed)[0]])] or roots
    if len(roots) != 1:
        raise ServiceError("unknown_format", f"{archive!r} holds {len(roots or candidates)} files that could be the "
                           f"mesh ({', '.join(sorted(roots or candidates)[:20])}); upload the one to read as file= "
                           "and the others as companions=", filename=archive,
                           candidates=sorted(roots or candidates)[:50])
    return roots[0]


def _include_lines(body: bytes, most: int = 10_000) -> bytes:
    """The lines of a file that may name files it includes, lower case: each line with ``include`` and the next."""
    low = body.lower()
    out: list[bytes] = []
    pos = low.find(b"include")
    while pos >= 0 and len(out) < most:
        start = low.rfind(b"\n", 0, pos) + 1
        end = low.find(b"\n", pos)
        end = -1 if end < 0 else low.find(b"\n", end + 1)
        end = len(low) if end < 0 else end
        out.append(low[start:end])
        pos = low.find(b"include", end)
    return b"\n".join(out)


def _no_clash(files: dict[str, Any], given: dict[str, str], clean: str, original: str | None, field: str) -> None:
    """Refuse a file stored under a name another file, a folder of another file or the service's record takes."""
    other = given.get(clean)
    if other is None:
        other = next((given[n] for n in files if n.startswith(clean + "/") or clean.startswith(n + "/")), None)
    if other is not None:  # two uploads that store under one name: one would silently replace the other
        raise ServiceError("duplicate_file_name", f"the uploads {other!r} and {original!r} are both stored as "
                           f"{clean!r} (or one as a folder of the other); rename one", field=field, stored=clean,
                           files=[other, original])
    if clean in _RESERVED:
        raise ServiceError("duplicate_file_name", f"the upload {original!r} would be stored as {clean!r}, the "
                           "name of the service's own record of the mesh; rename it", field=field, stored=clean,
                           files=[original, clean])


@router.post("/meshes", status_code=201, summary="Upload a mesh file", response_model=MeshDoc,
             responses=error_responses(*_AUTH, 413, 422, s422="unreadable or invalid mesh (the "
                                       "solver's typed code: inverted_input, non_finite_coordinates, "
                                       "unsupported_element, unknown_format, too_many_elements, "
                                       "include_missing, include_outside, ...)"))
async def upload_mesh(
    file: Annotated[UploadFile, File(description="The mesh: .inp, .msh, .vtu, .vtk, .mesh, "
                                                 ".node (with its .ele), .bdf, .cdb, .k, ...; or a triangle surface "
                                                 "(.stl, .obj, .ply, .off) for SPEC targets; or a .zip of a deck "
                                                 "and the files it includes")],
    owner: OwnerDep, reg: RegistryDep,
    companions: Annotated[list[UploadFile] | SkipJsonSchema[None], File(
        description="Files read together with the main one: TetGen's .ele, the files a deck includes (under "
                    "their names relative to the deck's folder, folders kept: include/nodes.inp)")] = None,
    format: Annotated[str | SkipJsonSchema[None], Form(
        max_length=40, description="format name or extension, when the file name does not tell",
        json_schema_extra={"enum": UPLOAD_FORMAT_VALUES})] = None,
    name: Annotated[str | None, Form(max_length=200)] = None,
) -> dict[str, Any]:
    """Store and validate a mesh file; answer its counts, element types, sets and quality.

    A deck that includes other files (``*INCLUDE``) comes with them: as
    ``companions`` under their paths relative to the deck, or all in one
    ``.zip``. They are stored in the mesh's own folder, and the deck reads
    nothing outside it.
    """
    allowed = {**offered(), **SURFACE_FORMATS}  # triangle surfaces: targets
    data = await file.read()  # body size already bounded by the BodyLimit middleware
    files: dict[str, bytes]
    given: dict[str, str]
    under = ""
    if (file.filename or "").lower().endswith(".zip"):
        archive = safe_name(file.filename, "upload.zip")
        files, given = await reg.run(_unzip, data, reg.settings.read_bounds(), archive)
        main = _deck_of(files, format, allowed, archive)
        fmt, ext = resolve_format(format, main, allowed)
    else:
        main = safe_name(file.filename, "mesh")
        under = _folder_of(file.filename)
        fmt, ext = resolve_format(format, main, allowed)
        files, given = {main: data}, {main: file.filename or main}
    if not main.lower().endswith(ext):
        body, original = files.pop(main), given.pop(main)
        main = f"{main}{ext}"
        _no_clash(files, given, main, original, "file")
        files[main], given[main] = body, original
    for c in companions or []:
        if c.filename:
            clean = stored_name(c.filename, "companion", under)
            _no_clash(files, given, clean, c.filename, "companions")
            files[clean], given[clean] = await c.read(), c.filename
    if fmt == "tetgen" and main.endswith(".node"):
        ele = main[:-5] + ".ele"
        if ele not in files:
            raise InvalidMeshError(f"a TetGen mesh needs {ele!r} next to {main!r}: upload it as "
                                   "a companion file", code="missing_companion", missing=ele)
    meta = await reg.catalogue.add(owner, name or main, fmt, files, main)
    return public(meta)


@router.post("/meshes/arrays", status_code=201, summary="Upload a mesh as JSON arrays",
             response_model=MeshDoc, responses=error_responses(*_AUTH, 413, 422))
async def upload_arrays(body: MeshArrays, owner: OwnerDep, reg: RegistryDep) -> dict[str, Any]:
    """Store a mesh given as vertex and tetrahedron arrays."""
    n = len(body.vertices)
    if body.tetrahedra is not None and len(body.tetrahedra) > reg.settings.max_elements:
        raise ServiceError("too_many_elements", f"the mesh has {len(body.tetrahedra)} tetrahedra; the "
                           f"limit is {reg.settings.max_elements}", elements=len(body.tetrahedra),
                           limit=reg.settings.max_elements)
    for what, rows in (("tetrahedra", body.tetrahedra), ("triangles", body.triangles)):
        bad = [k for k, r in enumerate(rows or []) if not all(0 <= i < n for i in r)]
        if bad:
            raise InvalidMeshError(f"{what} {bad[:10]} have vertex ids outside [0, {n})",
                                   code="index_out_of_range", field=what, rows=bad[:10])
    for k, ids in body.sets.items():
        bad = [i for i in ids if not 0 <= i < n]
        if bad:
            raise InvalidMeshError(f"set {k!r} has vertex ids outside [0, {n}): {bad[:10]}",
                                   code="index_out_of_range", set=k)
    V = np.asarray(body.vertices, dtype=np.float64).reshape(-1, 3)  # rows checked by the model
    mesh = mesh_from_arrays(V, body.tetrahedra or None, body.triangles or None, sets=body.sets)
    meta = await reg.catalogue.add_arrays(owner, body.name or "arrays", mesh)
    return public(meta)


@router.get("/meshes", summary="List your meshes", response_model=list[MeshDoc],
            responses={200: {"headers": PAGE_HEADERS}, **error_responses(*_AUTH, 422)})
def list_meshes(owner: OwnerDep, reg: RegistryDep, request: Request, response: Response,
                limit: LimitQuery = 100, cursor: CursorQuery = None, name: NameQuery = None
                ) -> list[dict[str, Any]]:
    """The caller's meshes, oldest first, ``limit`` at a time; ``name`` filters by substring."""
    metas = [m for m in reg.catalogue.owned(owner) if name is None or name in str(m.get("name", ""))]
    return [public(m) for m in page(metas, lambda m: (m.get("created", 0.0), m["id"]), limit, cursor,
                                    request, response)]


@router.get("/meshes/{mesh_id}", summary="Describe a mesh", response_model=MeshDoc,
            responses=error_responses(*_AUTH, 404))
def get_mesh(meta: MeshDep) -> dict[str, Any]:
    """Counts, element types, sets, quality summary."""
    return public(meta)


def _originals(reg: Any, meta: dict[str, Any]) -> tuple[bytes, str, str]:
    """The uploaded file(s) unchanged: one file as is, several (TetGen, a deck and its includes) as a zip.

    Each file is under its stored name: an included file under its path relative to the deck.
    """
    d = reg.store.mesh_dir(meta["id"])
    if len(meta["files"]) == 1:
        return (d / meta["file"]).read_bytes(), meta["file"], "application/octet-stream"
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for f in meta["files"]:
            z.write(d / f, arcname=f)
    return buf.getvalue(), meta["file"].rsplit(".", 1)[0] + ".zip", "application/zip"


@router.get("/meshes/{mesh_id}/file", summary="Download a mesh",
            responses={200: {"content": {"application/octet-stream": {}, "application/zip": {}},
                             "description": "the file (a zip when the format has several files, or the deck "
                                            "includes files: each under its path relative to the deck)"},
                       **error_responses(*_AUTH, 404, 422)})
async def download_mesh(
    meta: MeshDep, reg: RegistryDep,
    format: Annotated[str | None, Query(max_length=40, json_schema_extra={"enum": MESH_FORMAT_VALUES},
                                        description="format name or extension (GET "
                                        "/v1/formats); omit for the upload byte for byte (TetGen, a deck "
                                        "with its includes: a zip of the files; JSON arrays: VTU)")] = None,
    lossy: Annotated[bool, Query(description="write what the format can hold when it cannot hold everything "
                                 "(sets, element types); X-Tetmorph-Dropped lists the rest. Without it such a "
                                 "conversion answers 422 lossy_write")] = False,
) -> Response:
    """The uploaded file unchanged, or the mesh converted to another format."""
    if format is None and meta["format"] != "arrays":
        body, fname, media = await reg.run(_originals, reg, meta)
        return _file(body, fname, media)
    mesh = await reg.catalogue.mesh(meta)
    fmt = format or "vtu"
    stem = safe_name(meta["name"].rsplit(".", 1)[0], "mesh")
    body, fname, media, dropped = await reg.run(export_mesh, mesh, mesh.V, fmt, stem, False, lossy)
    resp = _file(body, fname, media)
    if dropped:
        resp.headers["X-Tetmorph-Dropped"] = json.dumps(dropped, separators=(",", ":"))
    return resp


@router.get("/meshes/{mesh_id}/geometry", summary="Vertices, boundary faces, tets and sets, binary",
            responses={200: {"content": {"application/octet-stream": {}}},
                       **error_responses(*_AUTH, 404)})
async def mesh_geometry(meta: MeshDep, reg: RegistryDep) -> Response:
    """The mesh for a viewer, as one TMG1 bundle (see ``service.binary.encode_bundle``).

    Arrays: ``V`` float32 (n, 3) rest positions, ``F`` uint32 (k, 3) outward
    boundary faces, ``T`` uint32 (m, 4) tetrahedra, ``boundary`` uint8 (n,),
    ``set:NAME`` uint32 vertex ids for every named set of the file; for an
    Abaqus, Nastran, Ansys CDB or LS-DYNA deck ``labels`` uint32 (n,), the deck's own
    node number of each vertex, and ``element_labels`` uint32 (one per row of ``T``),
    the deck's number of the element the row belongs to. For
    hexahedra, wedges and pyramids ``T`` also holds their corner tetrahedra
    (:func:`solver.ops.elements.check_tets`): one of them inverts exactly when its
    element does, which is what the viewer shows; ``tet_element`` uint32 (rows of
    ``T``,) then names the element of each row. ``element_ids`` uint32 (elements,):
    the deck's id of each element, where they are not 1, 2, ... (the ids the quality
    check answers, :func:`solver.io.element_sets.deck_element_ids`).
    """
    mesh = await reg.catalogue.mesh(meta)

    def pack() -> bytes:
        T = check_tets(mesh.T, mesh.cells)
        arrays: dict[str, np.ndarray] = {"V": mesh.V.astype(np.float32), "F": mesh.F.astype(np.uint32),
                  "T": T.astype(np.uint32), "boundary": mesh.boundary.astype(np.uint8)}
        if len(T) != len(mesh.T):
            arrays["tet_element"] = check_tet_elements(mesh.T, mesh.cells).astype(np.uint32)
        ids = deck_element_ids(mesh)
        if len(ids) and not np.array_equal(ids, np.arange(1, len(ids) + 1)) and 0 <= ids.min() and ids.max() < 2**32:
            arrays["element_ids"] = ids.astype(np.uint32)
        for name, ids in mesh.sets.items():
            arrays[f"set:{name}"] = np.asarray(ids, np.uint32)
        labels = node_labels(mesh.raw) if mesh.file_format == "abaqus" and mesh.raw else deck_node_ids(mesh)
        if labels is not None and labels.shape == (mesh.n,) and mesh.n and labels.min() >= 0 and labels.max() < 2**32:
            arrays["labels"] = labels.astype(np.uint32)
        if mesh.file_format in SET_FORMATS and mesh.elements:
            eids = deck_element_ids(mesh)
            if eids.min() >= 0 and eids.max() < 2**32:
                arrays["element_labels"] = eids[check_tet_elements(mesh.T, mesh.cells)].astype(np.uint32)
        lo, hi = mesh.V[mesh.referenced].min(0), mesh.V[mesh.referenced].max(0)
        return encode_bundle(arrays, {"mesh_id": meta["id"], "name": meta.get("name"), "n": mesh.n,
                                      "elements": mesh.elements,
                                      "sets": sorted(mesh.sets), "bbox": [lo.tolist(), hi.tolist()]})

    return Response(await reg.run(pack), media_type="application/octet-stream")


@router.get("/meshes/{mesh_id}/features", summary="Form-feature candidates of a mesh",
            responses=error_responses(*_AUTH, 404, 422))
async def mesh_features(
    meta: MeshDep, reg: RegistryDep,
    angle: Annotated[float, Query(gt=0, lt=180, description="sharp-edge dihedral angle, degrees")] = 30.0,
    tol: Annotated[float, Query(gt=0, le=0.1, description="fit tolerance relative to a patch's size")
                   ] = 1e-3,
    ids: Annotated[bool, Query(description="include each candidate's vertex ids (a SPEC selection)")
                   ] = False,
) -> list[dict[str, Any]]:
    """Boundary patches between sharp edges fitted as hole / boss / plane / other (docs/guide/features.md)."""
    mesh = await reg.catalogue.mesh(meta)
    cands = await reg.run(feature_candidates, mesh, angle, tol)
    out = [c.to_dict() for c in cands]
    if not ids:
        for c in out:
            c.pop("selection")
    return out


@router.get("/meshes/{mesh_id}/symmetry", summary="Mirror planes and cyclic symmetry of a mesh",
            response_model=MeshSymmetry,
            responses=error_responses(*_AUTH, 404, 422, s422="surface_not_volume: the mesh is a triangle "
                                      "surface (no volume elements to keep symmetric)"))
async def mesh_symmetry(meta: MeshDep, reg: RegistryDep) -> dict[str, Any]:
    """Candidate ``SPEC.symmetry`` planes and the deck's ``SPEC.cyclic`` entries, as ``tetmorph info`` lists them."""
    mesh = await reg.catalogue.mesh(meta)
    if mesh.is_surface:
        raise InvalidMeshError(f"mesh {meta['id']} is a triangle surface ({mesh.surface.shape[0]} triangles), "
                               "not a volume mesh: tetrahedralize it first (POST /v1/tetrahedralize)",
                               code="surface_not_volume", field="mesh_id", mesh_id=meta["id"])

    def find() -> dict[str, Any]:
        return {"planes": symmetry_candidates(mesh),
                "cyclic": [resolve_cyclic(mesh, e) for e in abaqus_cyclic(mesh.raw)]}

    return await reg.run(find)


@router.post("/meshes/{mesh_id}/feature-region", summary="Min-cut feature region inside a band",
             responses=error_responses(*_AUTH, 404, 422, s422="malformed selection, or "
                                       "band_not_separating: the band does not split the surface in two"))
async def mesh_feature_region(meta: MeshDep, body: Band, reg: RegistryDep) -> dict[str, Any]:
    """The region the minimum cut through the band separates (Form features §4.3)."""
    mesh = await reg.catalogue.mesh(meta)
    sels = {f"band{k}": sel for k, sel in enumerate(body.dump())}
    parse_spec({"selections": sels, "fixed": list(sels)})  # 422 on a malformed selection
    for name, sel in sels.items():
        check_selection_ids(sel, mesh.n, f"band[{name[4:]}]")

    def region() -> dict[str, Any]:
        band = unique(np.concatenate([select(mesh, sel, name) for name, sel in sels.items()]))
        r = feature_region(mesh, band)
        return {"vertices": int(r["ids"].size), "faces": int(r["faces"].size), "area": r["area"],
                "cut_edges": int(r["cut_edges"].shape[0]), "selection": {"ids": r["ids"].tolist()}}

    return await reg.run(region)


@router.delete("/meshes/{mesh_id}", status_code=204, summary="Delete a mesh",
               responses=error_responses(*_AUTH, 404, 409, s409="sessions use the mesh (mesh_in_use)"))
def delete_mesh(meta: MeshDep, owner: OwnerDep, reg: RegistryDep) -> Response:
    """Remove a mesh (409 while a session uses it)."""
    reg.delete_mesh(owner, meta["id"])
    return Response(status_code=204)


def _file(data: bytes, filename: str, media: str) -> Response:
    return Response(data, media_type=media,
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})


