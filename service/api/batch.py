"""``/v1/sessions/{id}/batch`` and ``/v1/sessions/{id}/bounds``: shape variables through the service.

A batch (``tetmorph doe`` of a session) answers 202 with a job; poll it at
``GET /v1/sessions/{id}/batch/{job_id}`` (rows done of rows total), cancel it
with ``DELETE``, and fetch the zip of decks and ``summary.csv`` at
``.../result`` when it is done. The plan, the shapes and every row's variant
are checked before the job starts: a bad plan answers 422 naming its row and
column, and nothing is stored. The paths carry the session id, so behind the
balancer they reach the replica that runs the job.

Bounds are synchronous: the search takes tens of stacked back-substitutions,
and stops at ``TETMORPH_BOUNDS_TIME_LIMIT_S`` with 422 ``bounds_time_limit``.
"""

from __future__ import annotations

import asyncio
import os
import time
from pathlib import Path
from typing import Annotated, Any

from fastapi import APIRouter, Request, Response
from fastapi import Path as PathParam
from fastapi.responses import FileResponse

from solver.workflows.bounds import shape_bounds
from solver.workflows.doe import DoeResult, Variant
from solver.workflows.shapes import parse_shapes

from ..errors import NotFound, ServiceError
from ..formats import check_export, resolve_format
from ..models.batch import BatchCreate, BoundsQuery
from ..models.error import error_responses
from ..models.service import JobDoc
from ..state.batch import DeckZip, check_plan, job_folder, plan_of, remove_tree, solve_block, summary_counts
from ..state.jobs import Job, JobRunner
from ..state.registry import Registry
from ..state.session import Session
from .deps import OwnerDep, RegistryDep, SessionDep, safe_name
from .responses import JSONResponse

router = APIRouter(tags=["sessions"])

_AUTH = (401, 429)
JobId = Annotated[str, PathParam(max_length=64, description="id from POST /v1/sessions/{id}/batch")]


def _deck_format(reg: Registry, s: Session, fmt: str | None) -> tuple[str, str, str]:
    """``(meshio format, extension, stem)`` of the decks: the asked format, else the mesh's own."""
    meta = reg.store.mesh_meta(s.mesh_id) or {}
    own = meta.get("format")
    name, ext = resolve_format(fmt if fmt is not None else (own if own not in (None, "arrays") else "vtu"),
                               None if fmt is not None else meta.get("file"))
    stem = safe_name(str(meta.get("name", "mesh")).rsplit(".", 1)[0], "mesh")
    return name, ext, stem


@router.post("/sessions/{session_id}/batch", status_code=202, response_model=JobDoc,
             summary="Morph every row of a PLAN (a job: a zip of decks and summary.csv)",
             responses={202: {"description": "the job; poll its Location"}, **error_responses(
                 *_AUTH, 404, 410, 413, 422,
                 s422="a bad plan (the row, its line and the column), shape (its name), format "
                      "(unknown_format, lossy_write), too_many_rows, or engine_unavailable")})
async def create_batch(s: SessionDep, body: BatchCreate, owner: OwnerDep, reg: RegistryDep,
                       request: Request) -> JSONResponse:
    """Check the plan and the shapes on the session's factorization, then solve the rows in a job."""
    settings = reg.settings
    plan = plan_of(body.plan, settings.batch_max_rows)
    if body.engine == "ray" and not settings.ray_address:
        raise ServiceError("engine_unavailable", "engine 'ray' needs a Ray cluster: start the service with "
                           "TETMORPH_RAY_ADDRESS (docs/guide/batches.md, 'Batches on Ray')", field="engine")
    fmt, ext, stem = _deck_format(reg, s, body.format)
    await reg.run(check_export, await reg.sessions.mesh(s), fmt)  # 422 lossy_write before anything is solved
    shapes_doc = body.shapes_doc()
    async with s.lock:
        d = await reg.sessions.deformer(s)
        shapes = await reg.run(check_plan, d, shapes_doc, plan)
    mesh = d.mesh
    jobs: JobRunner = request.app.state.jobs
    folder = job_folder(settings.data_dir, settings.replica_id, "")
    limit = settings.batch_max_result_bytes

    async def local(job: Job) -> None:
        z = DeckZip(folder / f"{job.id}.zip", mesh, stem, ext, fmt, limit)
        t0 = time.perf_counter()
        variants: list[Variant] = []
        try:
            nonlocal_shapes, built = shapes, d
            bases: dict[int, Any] = {}  # the first block's interior basis, per deformer (solve_block)
            for start in range(0, plan.rows, body.block):
                if job.stop.is_set():
                    break
                async with s.lock:  # interactive MOVEs get in between blocks
                    dd = await reg.sessions.deformer(s)
                    if dd is not built:  # rebuilt (evicted meanwhile): the shapes of the new deformer
                        nonlocal_shapes, built = await reg.run(parse_shapes, shapes_doc, dd), dd
                    variants += await reg.builder.solve(solve_block, dd, nonlocal_shapes, plan, start, body.block,
                                                        body.inversion, z.writer(), job, bases)
                job.done = len(variants)
            if job.stop.is_set():
                z.discard()
                return
            ms = 1e3 * (time.perf_counter() - t0)
            result = DoeResult(shapes.names, variants, plan.rows, False, body.block,
                               {"total_ms": ms, "per_variant_ms": ms / max(len(variants), 1)})
            await reg.run(z.finish, result)
        except BaseException:
            # a cancel arrives while a block may still be writing in its thread: discard after it
            await asyncio.shield(asyncio.to_thread(z.discard))  # not behind queued builds; works at shutdown
            raise
        job.result_path, job.summary = z.path, {"engine": "local", **summary_counts(result)}

    async def on_ray(job: Job) -> None:
        from solver.workflows.ray_engine import run_doe_ray

        spec = await reg.sessions.spec(s)
        decks = folder / f"{job.id}-decks"
        z = DeckZip(folder / f"{job.id}.zip", mesh, stem, ext, fmt, limit)
        try:
            def progress(done: int, total: int) -> None:
                job.done = done

            r = await asyncio.to_thread(
                run_doe_ray, mesh, spec, shapes_doc, plan, output=str(decks / f"{stem}_{{i}}{ext}"),
                file_format=fmt, block=body.block, inversion=body.inversion, actors=settings.ray_actors,
                address=settings.ray_address, progress=progress, cancelled=job.stop.is_set)
            if job.stop.is_set() or r.cancelled:
                z.discard()
                return

            def pack() -> DoeResult:
                named = []
                for v in r.variants:
                    if v.file is not None:
                        z.add_file(Path(v.file), z.name(v.row))
                        v = Variant(**{**v.__dict__, "file": z.name(v.row)})
                    named.append(v)
                out = DoeResult(r.shapes, named, r.rows, False, r.block, r.timings)
                z.finish(out)
                return out

            result = await reg.run(pack)
        except BaseException:
            await asyncio.shield(asyncio.to_thread(z.discard))  # after a pack in flight, off the event loop
            raise
        finally:
            remove_tree(decks)
        job.result_path, job.summary = z.path, {"engine": "ray", **summary_counts(result)}

    run = on_ray if body.engine == "ray" else local

    async def work(job: Job) -> None:
        s.batches += 1
        try:
            await run(job)
        finally:
            s.batches -= 1

    job = jobs.submit_task(owner, "batch", work, plan.rows, s.id, settings.batch_time_limit_s)
    return JSONResponse(job.doc(), status_code=202, headers={"Location": f"/v1/sessions/{s.id}/batch/{job.id}"})


def _job(request: Request, owner: str, s: Session, job_id: str) -> Job:
    job = request.app.state.jobs.get(owner, job_id)
    if job.session_id != s.id:
        raise NotFound("job", job_id)
    return job


@router.get("/sessions/{session_id}/batch/{job_id}", response_model=JobDoc, summary="Progress of a batch",
            responses=error_responses(*_AUTH, 404, 410))
def get_batch(s: SessionDep, job_id: JobId, owner: OwnerDep, request: Request) -> dict[str, Any]:
    """Status, rows done of rows total; the summary counts and the result's URL when done."""
    return _job(request, owner, s, job_id).doc()


@router.delete("/sessions/{session_id}/batch/{job_id}", response_model=JobDoc, summary="Cancel a batch",
               responses=error_responses(*_AUTH, 404, 409, 410, s409="the batch has finished (job_finished)"))
def cancel_batch(s: SessionDep, job_id: JobId, owner: OwnerDep, request: Request) -> dict[str, Any]:
    """Stop the batch before its next block; nothing of it is kept."""
    job = _job(request, owner, s, job_id)
    request.app.state.jobs.cancel(job)
    return job.doc()


@router.get("/sessions/{session_id}/batch/{job_id}/result", summary="The zip of a finished batch",
            responses={200: {"content": {"application/zip": {}}, "description": "{stem}_{row}.{ext} per "
                             "variant written, and summary.csv"},
                       **error_responses(*_AUTH, 404, 409, 410, s409="not finished yet (job_not_finished)")})
def batch_result(s: SessionDep, job_id: JobId, owner: OwnerDep, request: Request) -> Response:
    """The decks and the summary, once the job is done."""
    return job_zip(_job(request, owner, s, job_id), "batch")


def job_zip(job: Job, what: str) -> Response:
    """The zip of a finished job (a batch or a study); 409 ``job_not_finished`` before."""
    if job.status != "done" or job.result_path is None or not os.path.exists(job.result_path):
        raise ServiceError("job_not_finished", f"{what} {job.id} is {job.status}; its result is there when it is "
                           "done", job_id=job.id, status=job.status)
    return FileResponse(job.result_path, media_type="application/zip", filename=f"{job.id}.zip")


@router.post("/sessions/{session_id}/bounds", summary="Safe bounds of each shape (synchronous)",
             responses=error_responses(*_AUTH, 404, 410, 413, 422, s422="a bad shape (its name), range, or "
                                       "bounds_time_limit"))
async def bounds(s: SessionDep, body: BoundsQuery, reg: RegistryDep) -> dict[str, Any]:
    """Per shape, the largest positive and negative value with no inverted element (bisection)."""
    lo, hi = (body.range[0], body.range[1]) if body.range is not None else (None, None)
    limit = reg.settings.bounds_time_limit_s
    shapes_doc = body.shapes_doc()
    async with s.lock:
        d = await reg.sessions.deformer(s)

        def search() -> Any:
            shapes = parse_shapes(shapes_doc, d)
            deadline = time.monotonic() + limit
            return shape_bounds(d, shapes, lo=lo, hi=hi, tol=body.tol, cancelled=lambda: time.monotonic() > deadline)

        r = await reg.builder.solve(search)
    if r.cancelled:
        raise ServiceError("bounds_time_limit", f"the bounds search stopped after {limit:g} s "
                           f"(TETMORPH_BOUNDS_TIME_LIMIT_S) with {len(r.shapes)} of {len(shapes_doc['shapes'])} "
                           "shapes done; ask for fewer shapes or a wider tol", time_limit_s=limit,
                           finished=[b.shape for b in r.shapes])
    return dict(r.to_dict())


__all__ = ["router"]
