"""``/v1/tetrahedralize`` and ``/v1/jobs``: a closed surface in, a stored tet mesh out (fTetWild).

fTetWild runs in a worker process (:mod:`service.state.jobs`) with a time
limit. POST answers 201 with the mesh when the job ends within
``job_wait_s``, else 202 with the job (poll ``GET /v1/jobs/{id}``; cancel with
``DELETE``). Surfaces that cannot work (open, too large, bad indices) answer
422 before any worker starts.
"""

from __future__ import annotations

import asyncio
import os
import tempfile
from typing import Annotated, Any

import numpy as np
from fastapi import APIRouter, File, Form, Path, Request, UploadFile
from pydantic import Field
from pydantic.json_schema import SkipJsonSchema

from solver.errors import MAX_IDS, InvalidMeshError, SolverError, format_ids
from solver.io.bounds import ReadBounds
from solver.io.read import read_surface
from solver.io.tetrahedralize import open_edges
from solver.limits import COORD_MAX
from solver.mesh import mesh_from_arrays

from ..errors import ServiceError, error_from_dict
from ..formats import SURFACE_FORMATS, resolve_format, scrubbed
from ..models.error import error_responses
from ..models.formats import SURFACE_FORMAT_VALUES
from ..models.mesh import MeshDoc
from ..models.service import JobDoc
from ..state import tetra_worker
from ..state.jobs import Job, JobRunner
from .deps import OwnerDep, RegistryDep, safe_name
from .meshes import public
from .responses import JSONResponse

router = APIRouter(tags=["meshes"])


def _read_surface(data: bytes, fmt: str, ext: str, max_triangles: int, bounds: ReadBounds
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The surface's points and triangles, read with the same checks and bounds as an uploaded mesh."""
    with tempfile.TemporaryDirectory(prefix="tetmorph-surface-") as tmp:
        path = os.path.join(tmp, "surface" + ext)
        with open(path, "wb") as f:
            f.write(data)
        try:
            V, F = read_surface(path, fmt, bounds=bounds)
        except SolverError as e:
            raise scrubbed(e, tmp) from None
    if V.ndim != 2 or V.shape[1] != 3:
        raise InvalidMeshError(f"surface points have shape {V.shape}; need (n, 3)", code="bad_shape")
    if len(F) > max_triangles:
        raise ServiceError("too_many_triangles", f"the surface has {len(F)} triangles; this service "
                           f"tetrahedralizes at most {max_triangles}", triangles=int(len(F)), limit=max_triangles)
    if not np.isfinite(V).all():
        raise InvalidMeshError("surface has non-finite coordinates", code="non_finite")
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise InvalidMeshError(f"triangle indices span [{F.min()}, {F.max()}] but there are {len(V)} vertices",
                               code="index_out_of_range")
    used = np.unique(F)
    huge = used[(np.abs(V[used]) > COORD_MAX).any(1)]
    if huge.size:  # the bound of meshes and documents; fTetWild's envelope would overflow long before
        raise InvalidMeshError(f"{huge.size} surface vertices have a coordinate beyond +-{COORD_MAX:g}; first "
                               f"vertices {format_ids(huge)}, e.g. vertex {huge[0]} = {V[huge[0]].tolist()}",
                               code="coordinates_out_of_range", vertices=huge[:MAX_IDS].tolist(), bound=COORD_MAX)
    return V, F


def _job_error(job: Job) -> Exception:
    return error_from_dict(job.error or {"code": "worker_failed", "message": "the job failed"})


@router.post("/tetrahedralize", status_code=201, response_model=MeshDoc,
             summary="Tetrahedralize a closed surface (STL / OBJ / PLY / OFF)",
             responses={202: {"model": JobDoc, "description": "still running: poll GET /v1/jobs/{id}"},
                        **error_responses(401, 413, 422, 429, 500, s422="unreadable, open or too large "
                                          "surface, bad options, or job_time_limit")})
async def tetrahedralize(
    request: Request,
    file: Annotated[UploadFile, File(description="closed triangle surface")],
    owner: OwnerDep, reg: RegistryDep,
    format: Annotated[str | SkipJsonSchema[None], Form(
        max_length=10, description="stl, obj, ply or off; default from the file name",
        json_schema_extra={"enum": SURFACE_FORMAT_VALUES})] = None,
    edge_length: Annotated[Annotated[float, Field(gt=0, le=COORD_MAX, allow_inf_nan=False)] | SkipJsonSchema[None],
                           Form(description="absolute target edge length")] = None,
    edge_length_fac: Annotated[float, Form(gt=0, le=1, allow_inf_nan=False, description="target edge "
                                           "length / bounding-box diagonal")] = 0.05,
    epsilon: Annotated[float, Form(gt=0, le=0.1, allow_inf_nan=False,
                                   description="envelope / bounding-box diagonal")] = 1e-3,
    optimize: Annotated[bool, Form()] = True,
    allow_open: Annotated[bool, Form(description="accept border edges")] = False,
    name: Annotated[str | None, Form(max_length=200)] = None,
) -> JSONResponse:
    """Fill the surface with tetrahedra in a worker process, orient them positively, store the mesh."""
    settings = request.app.state.settings
    jobs: JobRunner = request.app.state.jobs
    fname = safe_name(file.filename, "surface")
    fmt, ext = resolve_format(format, fname, allowed=SURFACE_FORMATS)
    data = await file.read()  # bounded by the BodyLimit middleware
    V, F = await reg.run(_read_surface, data, fmt, ext, settings.tetra_max_triangles, settings.read_bounds())
    opened = await reg.run(open_edges, F)
    if opened.size and not allow_open:
        raise InvalidMeshError(
            f"the surface is not closed: {len(opened)} edges are not shared by exactly two triangles "
            f"(first {opened[:3].tolist()}); close it, or pass allow_open", code="open_surface",
            open_edges=int(len(opened)))
    options = {"edge_length": edge_length, "edge_length_fac": edge_length_fac, "epsilon": epsilon,
               "optimize": optimize, "allow_open": allow_open}

    async def store(msg: Any) -> dict[str, Any]:
        _, Vt, Tt, info = msg
        mesh = await reg.run(mesh_from_arrays, Vt, Tt)
        info.update({"edge_length": edge_length, "edge_length_fac": edge_length_fac, "epsilon": epsilon,
                     "source": fname})
        meta = await reg.catalogue.add_arrays(owner, name or fname.rsplit(".", 1)[0] + ".tet", mesh,
                                         {"tetrahedralization": info})
        return public(meta)

    async def unstore(doc: dict[str, Any]) -> None:  # cancelled while it was being stored
        reg.catalogue.delete(owner, doc["id"], [])

    job = jobs.submit(owner, tetra_worker.run, (V, F, options), store, unstore)
    assert job.task is not None
    try:
        await asyncio.wait_for(asyncio.shield(job.task), settings.job_wait_s)
    except TimeoutError:
        pass
    if job.status == "done" and job.result is not None:
        return JSONResponse(job.result, status_code=201, headers={"Location": f"/v1/meshes/{job.result['id']}"})
    if job.status == "failed":
        raise _job_error(job)
    return JSONResponse(job.doc(), status_code=202, headers={"Location": f"/v1/jobs/{job.id}"})


JobId = Annotated[str, Path(max_length=64, description="id from POST /v1/tetrahedralize")]


@router.get("/jobs/{job_id}", summary="Status of a tetrahedralization job", response_model=JobDoc,
            responses=error_responses(401, 404, 429))
def get_job(job_id: JobId, request: Request, owner: OwnerDep) -> dict[str, Any]:
    """Status, stage, elapsed time; the mesh when done, the error when failed."""
    return request.app.state.jobs.get(owner, job_id).doc()


@router.delete("/jobs/{job_id}", summary="Cancel a tetrahedralization job", response_model=JobDoc,
               responses=error_responses(401, 404, 409, 429, s409="the job has finished (job_finished)"))
def cancel_job(job_id: JobId, request: Request, owner: OwnerDep) -> dict[str, Any]:
    """Kill the job's worker process; nothing is stored."""
    jobs: JobRunner = request.app.state.jobs
    job = jobs.get(owner, job_id)
    jobs.cancel(job)
    return job.doc()


__all__ = ["router"]
