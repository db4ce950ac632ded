"""Long, GIL-holding work (fTetWild) in worker processes, with a time limit and cancellation.

Each job runs in its own spawned process, at most ``workers`` at once; the
event loop only waits on the process's pipe, so every other request is served
meanwhile. A job past its time limit, or cancelled, has its process killed.
"""

from __future__ import annotations

import asyncio
import multiprocessing as mp
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

from ..errors import NotFound, ServiceError
from .store import new_id

__all__ = ["Job", "JobRunner"]

_SPAWN = mp.get_context("spawn")


@dataclass(eq=False)
class Job:
    """One job: its status and, when done, its result."""

    id: str
    owner: str
    time_limit_s: float
    created: float = field(default_factory=time.time)
    started: float | None = None
    finished: float | None = None
    status: str = "queued"  # queued | running | done | failed | cancelled
    stage: str = "queued"
    error: dict[str, Any] | None = None
    result: dict[str, Any] | None = None
    task: asyncio.Task[None] | None = None
    process: Any = None

    def doc(self) -> dict[str, Any]:
        """The public description (GET /v1/jobs/{id})."""
        end = self.finished or time.time()
        frac = {"queued": 0.0, "reading": 0.05, "tetrahedralizing": 0.1, "storing": 0.9}.get(self.stage, 1.0)
        return {"id": self.id, "status": self.status, "stage": self.stage, "progress": frac,
                "elapsed_s": round(end - (self.started or end), 3), "time_limit_s": self.time_limit_s,
                "created": self.created, "error": self.error, "mesh": self.result}


class JobRunner:
    """Run jobs in worker processes.

    Parameters
    ----------
    workers : int
        Processes at once; further jobs queue.
    time_limit_s : float
        Wall time a job's process may run.
    keep_s : float
        How long finished jobs stay listed.
    """

    def __init__(self, workers: int, time_limit_s: float, keep_s: float = 3600.0) -> None:
        self.workers = workers
        self.time_limit_s = time_limit_s
        self.keep_s = keep_s
        self.jobs: dict[str, Job] = {}
        self._slots: asyncio.Semaphore | None = None
        self.closed = False

    @property
    def alive(self) -> bool:
        """True while the runner accepts jobs."""
        return not self.closed

    @property
    def queued(self) -> int:
        """Jobs queued or running."""
        return sum(1 for j in self.jobs.values() if j.status in ("queued", "running"))

    def submit(self, owner: str, target: Callable[..., None], args: tuple[Any, ...],
               finish: Callable[[Any], Awaitable[dict[str, Any]]]) -> Job:
        """Start a job: ``target(conn, *args)`` in a worker process, then ``await finish(message)``.

        ``target`` sends one message through ``conn``: ``("ok", ...)`` or
        ``("error", error_dict)``. ``finish`` turns an ``ok`` message into the
        job's result (stored mesh document).
        """
        self._expire()
        job = Job(id=new_id("j"), owner=owner, time_limit_s=self.time_limit_s)
        self.jobs[job.id] = job
        job.task = asyncio.ensure_future(self._run(job, target, args, finish))
        job.task.add_done_callback(lambda t: t.cancelled() or t.exception())
        return job

    def get(self, owner: str, job_id: str) -> Job:
        """A job of ``owner``; 404 otherwise."""
        job = self.jobs.get(job_id)
        if job is None or job.owner != owner:
            raise NotFound("job", job_id)
        return job

    def cancel(self, job: Job) -> None:
        """Stop a queued or running job (its process is killed).

        Raises
        ------
        ServiceError
            409 ``job_finished`` when it has already finished.
        """
        if job.status not in ("queued", "running"):
            raise ServiceError("job_finished", f"job {job.id} has already finished ({job.status})",
                               job_id=job.id, status=job.status)
        self._kill(job)
        job.status, job.stage, job.finished = "cancelled", "cancelled", time.time()
        job.error = {"type": "ServiceError", "code": "job_cancelled", "message": "cancelled", "details": {}}
        if job.task is not None:
            job.task.cancel()

    async def close(self) -> None:
        """Kill every running job."""
        self.closed = True
        for job in list(self.jobs.values()):
            if job.status in ("queued", "running"):
                self.cancel(job)

    def _kill(self, job: Job) -> None:
        p = job.process
        if p is not None and p.is_alive():
            p.kill()
            p.join(5)

    def _expire(self) -> None:
        now = time.time()
        for jid in [j.id for j in self.jobs.values() if j.finished and now - j.finished > self.keep_s]:
            self.jobs.pop(jid, None)

    async def _run(self, job: Job, target: Callable[..., None], args: tuple[Any, ...],
                   finish: Callable[[Any], Awaitable[dict[str, Any]]]) -> None:
        if self._slots is None:
            self._slots = asyncio.Semaphore(self.workers)
        async with self._slots:
            if job.status == "cancelled":
                return
            job.status, job.stage, job.started = "running", "tetrahedralizing", time.time()
            parent, child = _SPAWN.Pipe(duplex=False)
            proc = _SPAWN.Process(target=target, args=(child, *args), daemon=True)
            job.process = proc
            try:
                proc.start()
                child.close()
                msg = await asyncio.to_thread(self._wait, parent, proc, job.time_limit_s)
            finally:
                self._kill(job)
                parent.close()
            if msg is None:
                job.status, job.stage, job.finished = "failed", "failed", time.time()
                alive = time.time() - job.started < job.time_limit_s
                job.error = ({"type": "ServiceError", "code": "worker_failed", "details": {},
                              "message": f"the worker process ended with code {proc.exitcode}"} if alive else
                             {"type": "ServiceError", "code": "job_time_limit", "details":
                              {"time_limit_s": job.time_limit_s},
                              "message": f"stopped after the time limit of {job.time_limit_s:g} s"})
                return
            if msg[0] == "error":
                job.status, job.stage, job.finished, job.error = "failed", "failed", time.time(), msg[1]
                return
            job.stage = "storing"
            try:
                job.result = await finish(msg)
            except Exception as e:  # noqa: BLE001 - stored on the job, answered by GET /v1/jobs/{id}
                job.status, job.stage, job.finished = "failed", "failed", time.time()
                job.error = {"type": type(e).__name__, "code": getattr(e, "code", "worker_failed"),
                             "message": getattr(e, "message", str(e)), "details": getattr(e, "details", {})}
                return
            job.status, job.stage, job.finished = "done", "done", time.time()

    @staticmethod
    def _wait(conn: Any, proc: Any, limit: float) -> Any:
        """The child's message, or None when it died or ran past ``limit`` seconds."""
        deadline = time.monotonic() + limit
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            if conn.poll(min(left, 0.5)):
                try:
                    return conn.recv()
                except (EOFError, OSError):
                    return None
            if not proc.is_alive() and not conn.poll(0):
                return None
