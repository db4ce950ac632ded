"""Worker threads, and the build of a session's deformer (assembly and factorization).

Assembly, factorization and back-substitution release the GIL in their
numeric kernels, so they run in threads beside the event loop: ``build``
threads assemble and factor, ``solve`` threads back-substitute. Nothing
CPU-heavy runs on the event loop.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Awaitable, Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

from solver.deform.deformer import Deformer
from solver.errors import SolverError
from solver.mesh import Mesh
from solver.options import SolveOptions

from .session import Session, SessionStatus

__all__ = ["Builder", "small_report"]

log = logging.getLogger("tetmorph.service")

T = TypeVar("T")


def small_report(report: dict[str, Any]) -> dict[str, Any]:
    """The REPORT without its set-up timings (kept once per session)."""
    out = dict(report)
    t = out.get("timings")
    if isinstance(t, dict):
        out["timings"] = {"update": t.get("update")}
    return out


class Builder:
    """Thread pools and session builds.

    Parameters
    ----------
    build_workers, solve_workers : int
        Threads that assemble and factor; threads that back-substitute.
    options : SolveOptions, optional
        What every session's precompute is built with (default: those in effect).
    """

    def __init__(self, build_workers: int, solve_workers: int, options: SolveOptions | None = None) -> None:
        self.build_workers = build_workers
        self.solve_workers = solve_workers
        self.options = options
        self.closed = True
        self._queued = {"build": 0, "solve": 0}
        #: Called with the seconds of every finished build (the metrics set it).
        self.observe_build: Callable[[float], None] = lambda seconds: None
        self.start()

    def start(self) -> None:
        """Start the worker threads (again, after :meth:`close`)."""
        self.build_pool = ThreadPoolExecutor(self.build_workers, thread_name_prefix="tm-build")
        self.solve_pool = ThreadPoolExecutor(self.solve_workers, thread_name_prefix="tm-solve")
        self.closed = False

    def close(self) -> None:
        """Stop the worker threads."""
        self.closed = True
        self.build_pool.shutdown(wait=False, cancel_futures=True)
        self.solve_pool.shutdown(wait=False, cancel_futures=True)

    def queued(self, pool: str) -> int:
        """Calls waiting or running in the ``"build"`` or ``"solve"`` pool."""
        return self._queued[pool]

    async def _in(self, pool: str, fn: Callable[..., T], *args: Any) -> T:
        executor = self.build_pool if pool == "build" else self.solve_pool
        self._queued[pool] += 1
        try:
            return await asyncio.get_running_loop().run_in_executor(executor, fn, *args)
        finally:
            self._queued[pool] -= 1

    async def run(self, fn: Callable[..., T], *args: Any) -> T:
        """Run a blocking call (file export, parsing, packing) in a build thread."""
        return await self._in("build", fn, *args)

    async def solve(self, fn: Callable[..., T], *args: Any) -> T:
        """Run a short blocking call (a back-substitution) in a solve thread."""
        return await self._in("solve", fn, *args)

    def start_build(self, s: Session, mesh: Callable[[Session], Awaitable[Mesh]],
                    built: Callable[[Session, Deformer], None],
                    failed: Callable[[Session], None],
                    spec: Callable[[Session], Awaitable[dict[str, Any]]] | None = None) -> asyncio.Task[Deformer]:
        """Start (or join) the build of a session's deformer.

        Parameters
        ----------
        s : Session
        mesh : coroutine function
            The session's rest mesh.
        built : callable
            Called with the session and its new deformer when the build succeeds.
        failed : callable
            Called with the session after a typed build failure (to persist it).
        spec : coroutine function, optional
            The SPEC to build (stored target surfaces resolved); default ``s.spec``.

        Returns
        -------
        asyncio.Task
            Resolves to the deformer; the session's status follows it.
        """
        if s.build_task is None or s.build_task.done():
            s.build_task = asyncio.ensure_future(self._build(s, mesh, built, failed, spec))
            # a failed background build is recorded on the session; never "never retrieved"
            s.build_task.add_done_callback(lambda t: t.cancelled() or t.exception())
        return s.build_task

    async def _build(self, s: Session, mesh_of: Callable[[Session], Awaitable[Mesh]],
                     built: Callable[[Session, Deformer], None],
                     failed: Callable[[Session], None],
                     spec_of: Callable[[Session], Awaitable[dict[str, Any]]] | None = None) -> Deformer:
        loop = asyncio.get_running_loop()
        s.status, s.stage, s.progress, s.error = SessionStatus.building, "mesh", 0.0, None

        def progress(stage: str, fraction: float) -> None:
            s.stage, s.progress = stage, fraction
            if stage == "constraints":
                loop.call_soon_threadsafe(s.checked.set)

        try:
            mesh = await mesh_of(s)
            spec = await spec_of(s) if spec_of is not None else s.spec
            t0 = time.perf_counter()
            d = await self.run(Deformer, mesh, spec, progress, self.options)
            self.observe_build(time.perf_counter() - t0)
            if s.last_move is not None and s.positions is None:
                r = await self.solve(d.solve, s.last_move, "warn")
                s.positions, s.report = r.V, small_report(r.report)
        except SolverError as e:
            s.status, s.error = SessionStatus.failed, e.to_dict()
            s.checked.set()
            failed(s)
            raise
        except BaseException as e:
            s.status = SessionStatus.failed
            s.error = {"type": type(e).__name__, "code": "build_failed", "message": str(e),
                       "details": {}}
            s.checked.set()
            raise
        s.deformer, s.status, s.stage, s.progress = d, SessionStatus.ready, "done", 1.0
        s.builds += 1
        built(s, d)
        return d
