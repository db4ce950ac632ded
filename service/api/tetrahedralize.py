"""``/v1/tetrahedralize`` and ``/v1/jobs``: a closed surface in, a stored tet mesh out (fTetWild).

fTetWild runs in a worker process (:mod:`service.state.jobs`) with a time
limit. POST answers 201 with the mesh when the job ends within
``job_wait_s``, else 202 with the job (poll ``GET /v1/jobs/{id}``; cancel with
``DELETE``); ``wait=false`` answers 202 at once, for a client that shows the
job's stages and offers to cancel it. Surfaces and options that cannot work
(open, too large, bad indices, an edge length outside the bounds of
:mod:`solver.limits`) answer 422 before any worker starts.
"""

from __future__ import annotations

import asyncio
from typing import Annotated, Any

from fastapi import APIRouter, File, Form, Path, Request, UploadFile
from pydantic import Field
from pydantic.json_schema import SkipJsonSchema

from solver.errors import InvalidMeshError
from solver.io.tetrahedralize import check_edge_length, open_edges
from solver.limits import COORD_MAX, EDGE_LENGTH_FAC_MAX, EDGE_LENGTH_FAC_MIN, ENVELOPE_MAX
from solver.mesh import mesh_from_arrays

from ..errors import error_from_dict
from ..formats import SURFACE_FORMATS, resolve_format
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
                           Form(description="absolute target edge length; overrides edge_length_fac, and must "
                                f"lie within [{EDGE_LENGTH_FAC_MIN:g}, {EDGE_LENGTH_FAC_MAX:g}] bounding-box "
                                "diagonals of the surface (422 out_of_range, field edge_length)")] = None,
    edge_length_fac: Annotated[float, Form(ge=EDGE_LENGTH_FAC_MIN, le=EDGE_LENGTH_FAC_MAX, allow_inf_nan=False,
                                           description="target edge length / bounding-box diagonal: smaller "
                                           "gives more tetrahedra (about its inverse cubed)")] = 0.05,
    epsilon: Annotated[float, Form(gt=0, le=ENVELOPE_MAX, allow_inf_nan=False,
                                   description="envelope / bounding-box diagonal")] = 1e-3,
    optimize: Annotated[bool, Form()] = True,
    allow_open: Annotated[bool, Form(description="accept border edges")] = False,
    name: Annotated[str | None, Form(max_length=200)] = None,
    wait: Annotated[bool, Form(description="wait up to the service's job_wait_s for the mesh (201); false: "
                               "answer 202 with the job at once")] = True,
) -> JSONResponse:
    """Fill the surface with tetrahedra in a worker process, orient them positively, store the mesh."""
    settings = request.app.state.settings
    jobs: JobRunner = request.app.state.jobs
    fname = safe_name(file.filename, "surface")
    fmt, ext = resolve_format(format, fname, allowed=SURFACE_FORMATS)
    data = await file.read()  # bounded by the BodyLimit middleware
    V, F = await reg.parse.call(owner, "service.state.reads.read_surface_upload", data, fmt, ext,
                                settings.tetra_max_triangles, settings.read_bounds(), what=repr(fname))
    opened = await reg.run(open_edges, F)
    if opened.size and not allow_open:
        raise InvalidMeshError(
            f"the surface is not closed: {len(opened)} edges are not shared by exactly two triangles "
            f"(first {opened[:3].tolist()}); close it, or pass allow_open", code="open_surface",
            open_edges=int(len(opened)))
    check_edge_length(V, edge_length, edge_length_fac, epsilon)  # 422 out_of_range naming the field; no job
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
        await asyncio.wait_for(asyncio.shield(job.task), settings.job_wait_s if wait else 0)
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
