"""``/v1/sessions/{id}/study``: every plan row morphed, solved by an FE solver and tabled (``tetmorph study``).

A study answers 202 with a job. Its rows are morphed on the session's
factorization (under the session's lock, like a batch), then each deck is
handed to the solver command the operator configured under the name the
request gives (``TETMORPH_STUDY_SOLVERS``: a client names a solver, it never
sends a command), one run at a time with a time limit. Poll
``GET /v1/sessions/{id}/study/{job_id}`` (rows done of rows total), cancel
with ``DELETE``, and fetch ``.../result`` when done: a zip with one folder per
row (the deck, the solver's output files and its log) and ``study.csv``
(row, parameters, status, mesh figures, solver time, responses). A row
whose morph inverts, whose solver fails or times out, or whose output has no
responses is recorded in the table; the study goes on.
"""

from __future__ import annotations

import asyncio
import shutil
import zipfile
from functools import partial
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Request, Response

from solver.workflows.study import ccx_responses, morph_rows, solve_row, write_table

from ..errors import NotFound, ServiceError
from ..formats import check_export
from ..models.batch import StudyCreate
from ..models.error import error_responses
from ..models.service import JobDoc
from ..state.batch import check_plan, job_folder, plan_of, remove_tree
from ..state.jobs import Job, JobRunner
from ..state.session import Session
from .batch import JobId, _deck_format, job_zip
from .deps import OwnerDep, RegistryDep, SessionDep
from .responses import JSONResponse

router = APIRouter(tags=["sessions"])

_AUTH = (401, 429)
_READERS = {"ccx": ccx_responses}


def _job(request: Request, owner: str, s: Session, job_id: str) -> Job:
    job = request.app.state.jobs.get(owner, job_id)
    if job.session_id != s.id or job.kind != "study":
        raise NotFound("job", job_id)
    return job


def _zip_rows(root: Path, path: Path, limit: int) -> None:
    """Every file under ``root`` into the zip at ``path``, named relative to ``root``."""
    total = 0
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for f in sorted(p for p in root.rglob("*") if p.is_file()):
            total += f.stat().st_size
            if total > limit:
                raise ServiceError("result_too_large", f"the study's files pass {limit / 2**20:.0f} MB "
                                   "(TETMORPH_BATCH_MAX_RESULT_MB)", limit_bytes=limit)
            z.write(f, arcname=f.relative_to(root).as_posix())


@router.post("/sessions/{session_id}/study", status_code=202, response_model=JobDoc,
             summary="Morph every row of a PLAN and run the FE solver on each deck (a job: a zip and study.csv)",
             responses={202: {"description": "the job; poll its Location"}, **error_responses(
                 *_AUTH, 404, 410, 413, 422,
                 s422="a bad plan (the row, its line and the column), shape (its name), format "
                      "(unknown_format, lossy_write), too_many_rows, or solver_unavailable (a solver name "
                      "the service has not configured)")})
async def create_study(s: SessionDep, body: StudyCreate, owner: OwnerDep, reg: RegistryDep,
                       request: Request) -> JSONResponse:
    """Check the solver name, the plan and the shapes, then morph, solve and table the rows in a job."""
    settings = reg.settings
    template = settings.study_solvers.get(body.solver)
    if template is None:
        names = sorted(settings.study_solvers)
        raise ServiceError("solver_unavailable", f"solver {body.solver!r} is not configured on this service "
                           f"(configured: {names or 'none'}; the operator sets TETMORPH_STUDY_SOLVERS)",
                           field="solver", configured=names)
    program = template.split()[0] if template.split() else ""
    if not shutil.which(program):
        raise ServiceError("solver_unavailable", f"solver {body.solver!r} runs {program!r}, which is not "
                           "installed on this replica", field="solver", program=program)
    timeout = min(body.timeout_s or settings.study_timeout_s, settings.study_timeout_s)
    plan = plan_of(body.plan, settings.batch_max_rows)
    fmt, ext, stem = _deck_format(reg, s, body.format)
    await reg.run(check_export, await reg.sessions.mesh(s), fmt)  # 422 lossy_write before anything is solved
    shapes_doc = body.shapes_doc()
    async with s.lock:
        d = await reg.sessions.deformer(s)
        await reg.run(check_plan, d, shapes_doc, plan)
    mesh = d.mesh
    jobs: JobRunner = request.app.state.jobs
    folder = job_folder(settings.data_dir, settings.replica_id, "")
    limit = int(settings.batch_max_result_mb * 2**20)
    reader = _READERS[body.response]

    async def work(job: Job) -> None:
        root = folder / f"{job.id}-rows"
        s.batches += 1
        try:
            async with s.lock:  # the morphs on the factorization; the solver runs without the lock
                dd = await reg.sessions.deformer(s)
                shapes = await reg.run(check_plan, dd, shapes_doc, plan)
                rows = await reg.builder.solve(partial(
                    morph_rows, mesh, dd, shapes, plan, output=str(root / "{i}" / f"{stem}{ext}"),
                    file_format=fmt, block=body.block, inversion=body.inversion, cancelled=job.stop.is_set))
            for r in rows:
                if job.stop.is_set():
                    return
                run = asyncio.ensure_future(asyncio.to_thread(solve_row, r, template, reader, timeout,
                                                              job.stop.is_set))
                try:
                    await asyncio.shield(run)
                except asyncio.CancelledError:  # a DELETE, the session's deletion, the time limit
                    job.stop.set()
                    await run  # its solver killed, before the rows folder is removed
                    raise
                job.done += 1
            for r in rows:  # names inside the zip, not this replica's paths
                if r.deck is not None:
                    r.deck = Path(r.deck).relative_to(root).as_posix()
            await reg.run(write_table, rows, shapes.names, root / "study.csv")
            zpath = folder / f"{job.id}.zip"
            try:
                await reg.run(_zip_rows, root, zpath, limit)
            except BaseException:
                zpath.unlink(missing_ok=True)
                raise
            counts: dict[str, Any] = {}
            for r in rows:
                counts[r.status] = counts.get(r.status, 0) + 1
            job.result_path, job.summary = zpath, {"rows": counts}
        finally:
            s.batches -= 1
            await asyncio.shield(asyncio.to_thread(remove_tree, root))

    job = jobs.submit_task(owner, "study", work, plan.rows, s.id, settings.batch_time_limit_s)
    return JSONResponse(job.doc(), status_code=202, headers={"Location": f"/v1/sessions/{s.id}/study/{job.id}"})


@router.get("/sessions/{session_id}/study/{job_id}", response_model=JobDoc, summary="Progress of a study",
            responses=error_responses(*_AUTH, 404, 410))
def get_study(s: SessionDep, job_id: JobId, owner: OwnerDep, request: Request) -> dict[str, Any]:
    """Status, rows solved of rows total; the counts per row status and the result's URL when done."""
    return _job(request, owner, s, job_id).doc()


@router.delete("/sessions/{session_id}/study/{job_id}", response_model=JobDoc, summary="Cancel a study",
               responses=error_responses(*_AUTH, 404, 409, 410, s409="the study has finished (job_finished)"))
def cancel_study(s: SessionDep, job_id: JobId, owner: OwnerDep, request: Request) -> dict[str, Any]:
    """Stop the study, killing its running solver; nothing of it is kept."""
    job = _job(request, owner, s, job_id)
    request.app.state.jobs.cancel(job)
    return job.doc()


@router.get("/sessions/{session_id}/study/{job_id}/result", summary="The zip of a finished study",
            responses={200: {"content": {"application/zip": {}}, "description": "a folder per row (deck, "
                             "solver output, log) and study.csv"},
                       **error_responses(*_AUTH, 404, 409, 410, s409="not finished yet (job_not_finished)")})
def study_result(s: SessionDep, job_id: JobId, owner: OwnerDep, request: Request) -> Response:
    """The rows' files and the table, once the job is done."""
    return job_zip(_job(request, owner, s, job_id), "study")
