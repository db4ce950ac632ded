"""``/v1/meshes``: upload (file or JSON arrays), list, describe, download, delete."""

from __future__ import annotations

import io
import json
import zipfile
from typing import Annotated, Any

import numpy as np
from fastapi import APIRouter, File, Form, Query, Request, Response, UploadFile
from pydantic.json_schema import SkipJsonSchema

from solver.constraints.features import feature_candidates, feature_region
from solver.constraints.selection import select
from solver.constraints.spec import parse_spec
from solver.constraints.symmetry_candidates import abaqus_cyclic, resolve_cyclic, symmetry_candidates
from solver.errors import InvalidMeshError
from solver.io.patch_inp import node_labels
from solver.mesh import mesh_from_arrays
from solver.ops.elements import check_tets
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


@router.post("/meshes", status_code=201, summary="Upload a mesh file", response_model=MeshDoc,
             responses=error_responses(*_AUTH, 413, 422, s422="unreadable or invalid mesh (the "
                                       "solver's typed code: inverted_input, non_finite_coordinates, "
                                       "unsupported_element, unknown_format, too_many_elements, ...)"))
async def upload_mesh(
    file: Annotated[UploadFile, File(description="The mesh: .inp, .msh, .vtu, .vtk, .mesh, "
                                                 ".node (with its .ele), .bdf, ...; or a triangle surface "
                                                 "(.stl, .obj, .ply, .off) for SPEC targets")],
    owner: OwnerDep, reg: RegistryDep,
    companions: Annotated[list[UploadFile] | SkipJsonSchema[None], File(
        description="Files read together with the main one (TetGen's .ele)")] = None,
    format: Annotated[str | SkipJsonSchema[None], Form(
        max_length=40, description="format name or extension, when the file name does not tell",
        json_schema_extra={"enum": UPLOAD_FORMAT_VALUES})] = None,
    name: Annotated[str | None, Form(max_length=200)] = None,
) -> dict[str, Any]:
    """Store and validate a mesh file; answer its counts, element types, sets and quality."""
    main = safe_name(file.filename, "mesh")
    fmt, ext = resolve_format(format, main, {**offered(), **SURFACE_FORMATS})  # triangle surfaces: targets
    if not main.lower().endswith(ext):
        main = f"{main}{ext}"
    files = {main: await file.read()}  # body size already bounded by the BodyLimit middleware
    given = {main: file.filename}
    for c in companions or []:
        if c.filename:
            clean = safe_name(c.filename, "companion")
            if clean in files:  # two uploads that store under one name: one would silently replace the other
                raise ServiceError("duplicate_file_name", f"the uploads {given[clean]!r} and {c.filename!r} are "
                                   f"both stored as {clean!r}; rename one", field="companions", stored=clean,
                                   files=[given[clean], c.filename])
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
    """The uploaded file(s) unchanged: one file as is, several (TetGen) as a zip of the originals."""
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
                             "description": "the file (a zip when the format has several files)"},
                       **error_responses(*_AUTH, 404, 422)})
async def download_mesh(
    meta: MeshDep, reg: RegistryDep,
    format: Annotated[str | None, Query(max_length=40, json_schema_extra={"enum": MESH_FORMAT_VALUES},
                                        description="format name or extension (GET "
                                        "/v1/formats); omit for the upload byte for byte (TetGen: a zip "
                                        "of its two files; JSON arrays: VTU)")] = None,
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
    ``set:NAME`` uint32 vertex ids for every named set of the file, and for an
    Abaqus deck ``labels`` uint32 (n,), the deck's own node number of each vertex. For
    hexahedra, wedges and pyramids ``T`` also holds their corner tetrahedra
    (:func:`solver.ops.elements.check_tets`): one of them inverts exactly when its
    element does, which is what the viewer shows.
    """
    mesh = await reg.catalogue.mesh(meta)

    def pack() -> bytes:
        arrays: dict[str, np.ndarray] = {"V": mesh.V.astype(np.float32), "F": mesh.F.astype(np.uint32),
                  "T": check_tets(mesh.T, mesh.cells).astype(np.uint32), "boundary": mesh.boundary.astype(np.uint8)}
        for name, ids in mesh.sets.items():
            arrays[f"set:{name}"] = np.asarray(ids, np.uint32)
        if mesh.file_format == "abaqus" and mesh.raw:
            labels = node_labels(mesh.raw)
            if labels.shape == (mesh.n,) and labels.min() >= 0 and labels.max() < 2**32:
                arrays["labels"] = labels.astype(np.uint32)
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


