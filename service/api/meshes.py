"""``/v1/meshes``: upload (file or JSON arrays), describe, download, delete."""

from __future__ import annotations

from typing import Annotated, Any

import numpy as np
from fastapi import APIRouter, File, Form, Query, Response, UploadFile
from pydantic import BaseModel, Field

from solver.constraints.features import feature_candidates, feature_region
from solver.constraints.selection import select
from solver.constraints.spec import parse_spec
from solver.errors import InvalidMeshError
from solver.mesh import mesh_from_arrays
from solver.ops.elements import check_tets

from ..binary import encode_bundle
from ..errors import ServiceError
from ..formats import MESH_FORMATS, export_mesh, resolve_format
from ..registry import Registry
from .deps import Owner, Reg, safe_name

router = APIRouter(tags=["meshes"])


class MeshArrays(BaseModel):
    """A tet mesh (or a triangle surface) as JSON arrays, 0-based indices."""

    vertices: list[Annotated[list[float], Field(min_length=3, max_length=3)]] = Field(
        ..., description="(n, 3) vertex positions")
    tetrahedra: list[Annotated[list[int], Field(min_length=4, max_length=4)]] | None = Field(
        None, description="(m, 4) vertex indices")
    triangles: list[Annotated[list[int], Field(min_length=3, max_length=3)]] | None = Field(
        None, description="(k, 3) vertex indices of a surface-only mesh")
    sets: dict[str, list[int]] = Field(default_factory=dict, description="named vertex sets")
    name: str | None = None


def public(meta: dict[str, Any]) -> dict[str, Any]:
    """The mesh document returned to clients."""
    return {k: meta[k] for k in ("id", "name", "format", "files", "created", "info",
                                 "tetrahedralization") if k in meta}


@router.post("/meshes", status_code=201, summary="Upload a tet mesh file")
async def upload_mesh(
    file: Annotated[UploadFile, File(description="The mesh: .inp, .msh, .vtu, .vtk, .mesh, "
                                                 ".node (with its .ele), .bdf, ...")],
    companions: Annotated[list[UploadFile] | None, File(
        description="Files read together with the main one (TetGen's .ele)")] = None,
    format: Annotated[str | None, Form(description="meshio format name or extension, when the "
                                                   "file name does not tell")] = None,
    name: Annotated[str | None, Form()] = None,
    owner: str = Owner, reg: Registry = Reg,
) -> dict[str, Any]:
    """Store and validate a mesh file; answer its counts, element types, sets and quality."""
    main = safe_name(file.filename, "mesh")
    fmt, ext = resolve_format(format, main)
    if not main.lower().endswith(ext):
        main = f"{main}{ext}"
    files = {main: await file.read()}  # body size already bounded by the BodyLimit middleware
    for c in companions or []:
        if c.filename:
            files[safe_name(c.filename, "companion")] = await c.read()
    if fmt == "tetgen" and main.endswith(".node"):
        ele = main[:-5] + ".ele"
        if ele not in files:
            raise InvalidMeshError(f"a TetGen mesh needs {ele!r} next to {main!r}: upload it as "
                                   "a companion file", code="missing_companion", missing=ele)
    meta = await reg.add_mesh(owner, name or main, fmt, files, main)
    return public(meta)


@router.post("/meshes/arrays", status_code=201, summary="Upload a mesh as JSON arrays")
async def upload_arrays(body: MeshArrays, owner: str = Owner, reg: Registry = Reg) -> dict[str, Any]:
    """Store a mesh given as vertex and tetrahedron arrays."""
    V = np.asarray(body.vertices, dtype=np.float64).reshape(-1, 3)  # rows checked by the model
    if body.tetrahedra is not None and len(body.tetrahedra) > reg.settings.max_elements:
        raise ServiceError(422, f"the mesh has {len(body.tetrahedra)} tetrahedra; the limit is "
                           f"{reg.settings.max_elements}", code="too_many_elements")
    for k, ids in body.sets.items():
        bad = [i for i in ids if not 0 <= i < len(V)]
        if bad:
            raise InvalidMeshError(f"set {k!r} has vertex ids outside [0, {len(V)}): {bad[:10]}",
                                   code="index_out_of_range", set=k)
    mesh = mesh_from_arrays(V, body.tetrahedra or None, body.triangles or None, sets=body.sets)
    meta = await reg.add_mesh_arrays(owner, body.name or "arrays", mesh)
    return public(meta)


@router.get("/meshes", summary="List your meshes")
def list_meshes(owner: str = Owner, reg: Registry = Reg) -> list[dict[str, Any]]:
    """Every mesh of the caller's key."""
    return [public(m) for m in reg.list_meshes(owner)]


@router.get("/meshes/{mesh_id}", summary="Describe a mesh")
def get_mesh(mesh_id: str, owner: str = Owner, reg: Registry = Reg) -> dict[str, Any]:
    """Counts, element types, sets, quality summary."""
    return public(reg.mesh_meta(owner, mesh_id))


@router.get("/meshes/{mesh_id}/file", summary="Download a mesh",
            responses={200: {"content": {"application/octet-stream": {}}}})
async def download_mesh(
    mesh_id: str,
    format: Annotated[str | None, Query(description="format name or extension; omit for the "
                                        f"uploaded file byte for byte. One of {sorted(MESH_FORMATS)}")
                      ] = None,
    owner: str = Owner, reg: Registry = Reg,
) -> Response:
    """The uploaded file unchanged, or the mesh converted to another format."""
    meta = reg.mesh_meta(owner, mesh_id)
    if format is None and meta["format"] != "arrays" and len(meta["files"]) == 1:
        data = reg.mesh_file(meta).read_bytes()
        return _file(data, meta["file"], "application/octet-stream")
    mesh = await reg.mesh(meta)
    fmt = format or "vtu"
    stem = safe_name(meta["name"].rsplit(".", 1)[0], "mesh")
    body, fname, media = await reg.run(export_mesh, mesh, mesh.V, fmt, stem)
    return _file(body, fname, media)


@router.get("/meshes/{mesh_id}/geometry", summary="Vertices, boundary faces, tets and sets, binary",
            responses={200: {"content": {"application/octet-stream": {}}}})
async def mesh_geometry(mesh_id: str, owner: str = Owner, reg: Registry = Reg) -> Response:
    """The mesh for a viewer, as one TMG1 bundle (see ``service.binary.encode_bundle``).

    Arrays: ``V`` float32 (n, 3) rest positions, ``F`` uint32 (k, 3) outward
    boundary faces, ``T`` uint32 (m, 4) tetrahedra, ``boundary`` uint8 (n,),
    and ``set:NAME`` uint32 vertex ids for every named set of the file. For
    hexahedra, wedges and pyramids ``T`` also holds their corner tetrahedra
    (:func:`solver.ops.elements.check_tets`): one of them inverts exactly when its
    element does, which is what the viewer shows.
    """
    meta = reg.mesh_meta(owner, mesh_id)
    mesh = await reg.mesh(meta)

    def pack() -> bytes:
        arrays = {"V": mesh.V.astype(np.float32), "F": mesh.F.astype(np.uint32),
                  "T": check_tets(mesh.T, mesh.cells).astype(np.uint32), "boundary": mesh.boundary.astype(np.uint8)}
        for name, ids in mesh.sets.items():
            arrays[f"set:{name}"] = np.asarray(ids, np.uint32)
        lo, hi = mesh.V[mesh.referenced].min(0), mesh.V[mesh.referenced].max(0)
        return encode_bundle(arrays, {"mesh_id": meta["id"], "name": meta.get("name"), "n": mesh.n,
                                      "elements": mesh.elements,
                                      "sets": sorted(mesh.sets), "bbox": [lo.tolist(), hi.tolist()]})

    return Response(await reg.run(pack), media_type="application/octet-stream")


@router.get("/meshes/{mesh_id}/features", summary="Form-feature candidates of a mesh")
async def mesh_features(
    mesh_id: str,
    angle: Annotated[float, Query(gt=0, lt=180, description="sharp-edge dihedral angle, degrees")] = 30.0,
    tol: Annotated[float, Query(gt=0, le=0.1, description="fit tolerance relative to a patch's size")
                   ] = 1e-3,
    ids: Annotated[bool, Query(description="include each candidate's vertex ids (a SPEC selection)")
                   ] = False,
    owner: str = Owner, reg: Registry = Reg,
) -> list[dict[str, Any]]:
    """Boundary patches between sharp edges fitted as hole / boss / plane / other (see README)."""
    mesh = await reg.mesh(reg.mesh_meta(owner, mesh_id))
    cands = await reg.run(feature_candidates, mesh, angle, tol)
    out = [c.to_dict() for c in cands]
    if not ids:
        for c in out:
            c.pop("selection")
    return out


class Band(BaseModel):
    """Selections whose union is a band around a feature's border."""

    band: list[dict[str, Any]] = Field(min_length=1, description="SELECTION documents (as in a SPEC)")


@router.post("/meshes/{mesh_id}/feature-region", summary="Min-cut feature region inside a band")
async def mesh_feature_region(mesh_id: str, body: Band, owner: str = Owner,
                              reg: Registry = Reg) -> dict[str, Any]:
    """The region the minimum cut through the band separates (Form features §4.3)."""
    mesh = await reg.mesh(reg.mesh_meta(owner, mesh_id))
    sels = {f"band{k}": sel for k, sel in enumerate(body.band)}
    parse_spec({"selections": sels, "fixed": list(sels)})  # 422 on a malformed selection

    def region() -> dict[str, Any]:
        band = np.unique(np.concatenate([select(mesh, sel, name) for name, sel in sels.items()]))
        r = feature_region(mesh, band)
        return {"vertices": int(r["ids"].size), "faces": int(r["faces"].size), "area": r["area"],
                "cut_edges": int(r["cut_edges"].shape[0]), "selection": {"ids": r["ids"].tolist()}}

    return await reg.run(region)


@router.delete("/meshes/{mesh_id}", status_code=204, summary="Delete a mesh")
def delete_mesh(mesh_id: str, owner: str = Owner, reg: Registry = Reg) -> Response:
    """Remove a mesh (409 while a session uses it)."""
    reg.delete_mesh(owner, mesh_id)
    return Response(status_code=204)


def _file(data: bytes, filename: str, media: str) -> Response:
    return Response(data, media_type=media,
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})
