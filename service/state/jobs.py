"""Jobs: long work answered 202, with progress, a time limit and cancellation.

Tetrahedralizations (fTetWild holds the GIL) run in a spawned process each, at
most ``workers`` at once; the event loop only waits on the process's pipe, so
every other request is served meanwhile. A job past its time limit, or
cancelled, has its process killed.

Batches (:mod:`service.state.batch`) run in this process as tasks
(:meth:`JobRunner.submit_task`), at most ``task_workers`` at once; they count
rows done of rows total, and a cancelled one stops before its next block.
"""

from __future__ import annotations

import asyncio
import multiprocessing as mp
import shutil
import tempfile
import threading
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

from ..errors import NotFound, ServiceError, error_record
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
    #: ``tetrahedralize`` or ``batch``.
    kind: str = "tetrahedralize"
    session_id: str | None = None
    #: Rows done and rows in all (batches).
    done: int = 0
    total: int = 0
    #: Set by :meth:`JobRunner.cancel`; a batch stops before its next block.
    stop: threading.Event = field(default_factory=threading.Event)
    #: Held while the status changes: a DELETE (a route's thread) and the runner (the event loop) race.
    lock: threading.Lock = field(default_factory=threading.Lock)
    #: The event loop that runs the job's task (cancelled from other threads through it).
    loop: asyncio.AbstractEventLoop | None = None
    #: The finished batch's zip, and its summary counts.
    result_path: Any = None
    summary: dict[str, Any] | None = None
    #: Each stage a tetrahedralization entered, with the seconds since it started: ``[(stage, at_s)]``.
    stages: list[tuple[str, float]] = field(default_factory=list)

    def enter(self, stage: str) -> None:
        """Enter ``stage`` (a tetrahedralization's), unless the job has ended; noted in :attr:`stages`."""
        with self.lock:
            if self.status in ("queued", "running"):
                self.stage = stage
                self.stages.append((stage, round(time.time() - (self.started or time.time()), 3)))

    def doc(self) -> dict[str, Any]:
        """The public description (GET /v1/jobs/{id})."""
        end = self.finished or time.time()
        frac: float | None
        if self.kind == "tetrahedralize":  # fTetWild tells nothing of how far it is: its stage and time say it
            frac = 1.0 if self.status == "done" else None
        else:
            frac = round(1.0 if self.status == "done" else self.done / max(self.total, 1), 4)
        doc: dict[str, Any] = {
            "id": self.id, "kind": self.kind, "status": self.status, "stage": self.stage, "progress": frac,
            "elapsed_s": round(end - (self.started or end), 3), "time_limit_s": self.time_limit_s,
            "created": self.created, "error": self.error, "mesh": self.result}
        if self.kind == "tetrahedralize":
            doc["stages"] = [{"stage": name, "at_s": at} for name, at in self.stages]
        else:
            base = f"/v1/sessions/{self.session_id}/{'study' if self.kind == 'study' else 'batch'}/{self.id}"
            doc.update({"session_id": self.session_id, "rows_done": self.done, "rows_total": self.total,
                        "summary": self.summary, "result": base + "/result" if self.status == "done" else None})
        return doc


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

    def __init__(self, workers: int, time_limit_s: float, keep_s: float = 3600.0, task_workers: int = 1) -> None:
        self.workers = workers
        self.time_limit_s = time_limit_s
        self.keep_s = keep_s
        self.task_workers = task_workers
        self.jobs: dict[str, Job] = {}
        self._slots: asyncio.Semaphore | None = None
        self._task_slots: asyncio.Semaphore | None = None
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
               finish: Callable[[Any], Awaitable[dict[str, Any]]],
               undo: Callable[[dict[str, Any]], Awaitable[None]] | None = None) -> Job:
        """Start a job: ``target(conn, work, *args)`` in a worker process, then ``await finish(message)``.

        ``work`` is a scratch folder of the job's own, removed when the process has
        ended, also when it was killed (cancelled, or past the time limit).
        ``target`` sends one message through ``conn``: ``("ok", ...)`` or
        ``("error", error_dict)``. ``finish`` turns an ``ok`` message into the
        job's result (stored mesh document). A job cancelled while ``finish``
        stores is not interrupted; ``undo(result)`` then removes what it stored.
        """
        self._expire()
        job = Job(id=new_id("j"), owner=owner, time_limit_s=self.time_limit_s, loop=asyncio.get_running_loop())
        self.jobs[job.id] = job
        job.task = asyncio.ensure_future(self._run(job, target, args, finish, undo))
        job.task.add_done_callback(lambda t: t.cancelled() or t.exception())
        return job

    def submit_task(self, owner: str, kind: str, work: Callable[[Job], Awaitable[None]], total: int,
                    session_id: str | None = None, time_limit_s: float | None = None) -> Job:
        """Start a job that runs ``await work(job)`` in this process (a batch).

        ``work`` updates ``job.done`` as it goes and sets ``job.result_path``
        and ``job.summary``; an exception it raises becomes the job's error.
        """
        self._expire()
        job = Job(id=new_id("j"), owner=owner, time_limit_s=time_limit_s or self.time_limit_s, kind=kind,
                  session_id=session_id, total=total)
        self.jobs[job.id] = job
        job.task = asyncio.ensure_future(self._run_task(job, work))
        job.task.add_done_callback(lambda t: t.cancelled() or t.exception())
        return job

    async def _run_task(self, job: Job, work: Callable[[Job], Awaitable[None]]) -> None:
        if self._task_slots is None:
            self._task_slots = asyncio.Semaphore(self.task_workers)
        async with self._task_slots:
            if job.status == "cancelled":
                return
            job.status, job.stage, job.started = "running", "solving", time.time()
            try:
                await asyncio.wait_for(work(job), job.time_limit_s)
            except TimeoutError:
                job.stop.set()
                job.status, job.stage, job.finished = "failed", "failed", time.time()
                job.error = {"type": "ServiceError", "code": "job_time_limit", "details":
                             {"time_limit_s": job.time_limit_s},
                             "message": f"stopped after the time limit of {job.time_limit_s:g} s"}
                return
            except asyncio.CancelledError:
                job.stop.set()
                raise
            except Exception as e:  # noqa: BLE001 - stored on the job, answered by GET of the job
                if job.status != "cancelled":
                    job.status, job.stage, job.finished = "failed", "failed", time.time()
                    job.error = error_record(e)  # a full data directory: storage_full
                return
            if job.status != "cancelled":  # a cancel whose work returned before the task's cancellation came
                job.status, job.stage, job.finished = "done", "done", time.time()

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
        with job.lock:
            if job.status not in ("queued", "running"):
                raise ServiceError("job_finished", f"job {job.id} has already finished ({job.status})",
                                   job_id=job.id, status=job.status)
            storing = job.stage == "storing"
            job.stop.set()
            job.status, job.stage, job.finished = "cancelled", "cancelled", time.time()
            job.error = {"type": "ServiceError", "code": "job_cancelled", "message": "cancelled", "details": {}}
        if storing:  # the runner finishes storing, sees the cancel and undoes it: nothing is left half stored
            return
        self._kill(job)
        if job.task is not None:
            if job.loop is not None and job.loop.is_running():
                job.loop.call_soon_threadsafe(job.task.cancel)  # a route's thread may call this
            else:
                job.task.cancel()

    def end_session(self, session_id: str) -> int:
        """Stop and forget every job of a session being deleted: a job is owned by its session.

        A queued or running batch is cancelled (``session_deleted``; it stops before its next block
        and discards its partial zip); a finished one's zip is removed. Returns how many jobs it had.
        """
        mine = [j for j in self.jobs.values() if j.session_id == session_id]
        for job in mine:
            if job.status in ("queued", "running"):
                self.cancel(job)
                assert job.error is not None
                job.error = {**job.error, "code": "session_deleted", "message": f"session {session_id} was deleted"}
            elif job.result_path is not None:
                job.result_path.unlink(missing_ok=True)
            self.jobs.pop(job.id, None)
        return len(mine)

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
            job = self.jobs.pop(jid)
            if job.result_path is not None:
                job.result_path.unlink(missing_ok=True)

    async def _run(self, job: Job, target: Callable[..., None], args: tuple[Any, ...],
                   finish: Callable[[Any], Awaitable[dict[str, Any]]],
                   undo: Callable[[dict[str, Any]], Awaitable[None]] | None) -> None:
        if self._slots is None:
            self._slots = asyncio.Semaphore(self.workers)
        async with self._slots:
            if job.status == "cancelled":
                return
            job.status, job.stage, job.started = "running", "starting", time.time()
            job.stages.append(("starting", 0.0))
            parent, child = _SPAWN.Pipe(duplex=False)
            work = tempfile.mkdtemp(prefix=f"tetmorph-job-{job.id}-")
            proc = _SPAWN.Process(target=target, args=(child, work, *args), daemon=True)
            job.process = proc
            try:
                proc.start()
                child.close()
                msg = await asyncio.to_thread(self._wait, parent, proc, job)
            finally:
                self._kill(job)
                parent.close()
                shutil.rmtree(work, ignore_errors=True)
            if job.status == "cancelled":  # killed by cancel() while the pipe's wait was ending
                return
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
            with job.lock:  # storing starts unless cancelled first: cancel() then leaves the undoing to this task
                if job.status == "cancelled":
                    return
                job.stage = "storing"
                job.stages.append(("storing", round(time.time() - job.started, 3)))
            try:
                result = await finish(msg)
            except Exception as e:  # noqa: BLE001 - stored on the job, answered by GET /v1/jobs/{id}
                with job.lock:
                    if job.status != "cancelled":
                        job.status, job.stage, job.finished = "failed", "failed", time.time()
                        job.error = error_record(e)  # a full data directory: storage_full
                return
            with job.lock:
                if job.status != "cancelled":
                    job.result = result
                    job.status, job.stage, job.finished = "done", "done", time.time()
                    return
            if undo is not None:  # cancelled while storing: what was stored goes
                await undo(result)

    @staticmethod
    def _wait(conn: Any, proc: Any, job: Job) -> Any:
        """The child's last message, or None when it died or ran past the job's time limit.

        ``("stage", name)`` messages before it move the job to that stage.
        """
        deadline = time.monotonic() + job.time_limit_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            if conn.poll(min(left, 0.5)):
                try:
                    msg = conn.recv()
                except (EOFError, OSError):
                    return None
                if isinstance(msg, tuple) and len(msg) == 2 and msg[0] == "stage":
                    job.enter(str(msg[1]))
                    continue
                return msg
            if not proc.is_alive() and not conn.poll(0):
                return None
