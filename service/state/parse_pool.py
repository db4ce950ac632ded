"""Untrusted files are parsed in worker processes, never in the server's.

A reader that loops forever on a damaged file, or a compressed upload that
expands to gigabytes, must cost one worker process, not the service. Every
read of an uploaded file (meshes, target surfaces, the files of a stored mesh
read back) runs here:

- a pool of spawned processes (no web code imported in them), started with the
  service and kept warm;
- each call under a wall-clock limit and a CPU-time limit (``RLIMIT_CPU``),
  in a process whose address space is limited (``RLIMIT_AS``) to what it
  used once started plus a budget derived from the expanded-size bound of
  the uploads;
- a limit reached answers a typed error naming the limit (``parse_time_limit``,
  ``parse_cpu_limit``: 422; ``parse_memory_limit``: 413), and the worker is
  killed and replaced;
- a fair queue: calls wait per key, a key's queue is bounded
  (``parse_queue_full``, 429), keys are served in turn, and one key never holds
  every worker (at most ``workers - 1`` at once when there are several).

:meth:`ParsePool.health` tells ``/ready`` whether the pool is stuck (a call past
its limits, a worker that cannot be replaced) or saturated.
"""

from __future__ import annotations

import asyncio
import atexit
import collections
import concurrent.futures
import contextlib
import importlib
import logging
import multiprocessing as mp
import os
import signal
import threading
import time
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import Any

from ..errors import ServiceError, error_from_dict

__all__ = ["ParsePool", "ParseLimits", "shared_pool", "reader_pids"]

log = logging.getLogger("tetmorph.service")

_SPAWN = mp.get_context("spawn")


@dataclass(frozen=True)
class ParseLimits:
    """Limits of one call in a parse worker.

    Attributes
    ----------
    time_s : float
        Wall-clock seconds a call may take.
    cpu_s : float
        CPU seconds a call may use (``RLIMIT_CPU`` of the worker, reset per call).
    memory_bytes : int
        Address space a worker may add to what it used once started (``RLIMIT_AS``); 0: no limit.
    """

    time_s: float = 120.0
    cpu_s: float = 120.0
    memory_bytes: int = 0

    def names(self) -> dict[str, str]:
        """The settings that set each limit (for messages)."""
        return {"time": "TETMORPH_PARSE_TIME_LIMIT_S", "cpu": "TETMORPH_PARSE_CPU_LIMIT_S",
                "memory": "TETMORPH_PARSE_MEMORY_MB"}


def _vm_bytes() -> int:
    """The process's address space in bytes (``VmSize``), or 0 where /proc is not there."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


#: Growth of a worker's resident memory over a call after which it is replaced rather than kept: what a
#: large read leaves in the allocator would make the next call's memory limit depend on the last file.
RETIRE_GROWTH = 256 * 2**20


def _rss_bytes() -> int:
    """The process's resident memory in bytes (0 where /proc is not there)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def _serve(conn: Connection, memory_bytes: int, warm: tuple[str, ...]) -> None:
    """The worker's loop (spawned: nothing of the service is imported here but what calls name)."""
    import resource

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the server's Ctrl-C ends the server, which ends us
    for name in warm:  # imports before the limit: they are the same for every call
        importlib.import_module(name)
    if memory_bytes > 0:
        limit = _vm_bytes() + memory_bytes
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    conn.send(("ready", os.getpid()))
    start_rss = _rss_bytes()
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        target, args, cpu_s = msg
        used = resource.getrusage(resource.RUSAGE_SELF)
        spent = int(used.ru_utime + used.ru_stime) + 1
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(resource.RLIMIT_CPU, (spent + max(1, int(cpu_s)), resource.RLIM_INFINITY))
        try:
            module, _, fn = target.rpartition(".")
            result = getattr(importlib.import_module(module), fn)(*args)
            reply: tuple[Any, ...] = ("ok", result)
        except MemoryError:
            reply = ("memory",)
        except Exception as e:  # noqa: BLE001 - every failure goes back to the server as data
            to_dict = getattr(e, "to_dict", None)
            if callable(to_dict):  # a solver error: its type, code and details
                reply = ("error", to_dict())
            elif isinstance(getattr(e, "code", None), str) and hasattr(e, "details"):  # a service error
                err: Any = e
                reply = ("error", {"type": type(e).__name__, "code": err.code, "message": str(e),
                                   "details": dict(err.details)})
            else:
                reply = ("error", {"type": "UnreadableFileError", "code": "unreadable_file",
                                   "message": f"the reader failed ({type(e).__name__}: {str(e)[:300]})",
                                   "details": {}})
        # a worker that grew by more than RETIRE_GROWTH keeps that memory: it is replaced after this call
        retire = reply[0] == "memory" or _rss_bytes() - start_rss > RETIRE_GROWTH
        try:
            conn.send((*reply, retire))
        except MemoryError:
            conn.send(("memory", True))


@dataclass(eq=False)
class _Worker:
    process: Any
    conn: Connection
    busy_since: float | None = None


@dataclass(eq=False)
class _Call:
    owner: str
    target: str
    args: tuple[Any, ...]
    what: str
    future: concurrent.futures.Future[Any] = field(default_factory=concurrent.futures.Future)


class ParsePool:
    """Worker processes that read untrusted files (see the module's docstring).

    The pool is driven by threads, not by an event loop: one pool serves every
    app of a process (:func:`shared_pool`), and :meth:`call` awaits from any loop.

    Parameters
    ----------
    workers : int
        Processes.
    limits : ParseLimits
    queue_depth : int
        Calls one key may have waiting.
    warm : tuple of str
        Modules each worker imports before its memory limit is set.
    """

    def __init__(self, workers: int, limits: ParseLimits, queue_depth: int = 8,
                 warm: tuple[str, ...] = ("solver.io",)) -> None:
        self.n = max(1, int(workers))
        self.limits = limits
        self.queue_depth = queue_depth
        self.warm = warm
        self._idle: list[_Worker] = []
        self._busy: set[_Worker] = set()
        self._pending: dict[str, collections.deque[_Call]] = {}
        self._turn: collections.deque[str] = collections.deque()
        self._running: collections.Counter[str] = collections.Counter()
        self._starting = 0
        self._spawning: set[Any] = set()  # processes started that have not said they are ready
        self._lock = threading.RLock()
        self._closed = False
        self.failed_starts = 0
        self.replaced = 0

    # ------------------------------------------------------------------ workers

    def _spawn(self) -> _Worker:
        parent, child = _SPAWN.Pipe()
        p = _SPAWN.Process(target=_serve, args=(child, self.limits.memory_bytes, self.warm), daemon=True,
                           name="tetmorph-parse")
        p.start()
        with self._lock:
            self._spawning.add(p)
        try:
            child.close()
            hello = parent.recv() if parent.poll(120) else None
            if not hello or hello[0] != "ready":
                p.kill()
                raise RuntimeError("a parse worker did not start")
            return _Worker(p, parent)
        finally:
            with self._lock:
                self._spawning.discard(p)

    def _add(self) -> None:
        """Start one worker (in the calling thread: a spawn takes a second or two)."""
        try:
            w = self._spawn()
        except Exception:  # noqa: BLE001 - counted: /ready reports a pool that cannot start workers
            with self._lock:
                self.failed_starts += 1
                self._starting -= 1
            log.exception("a parse worker did not start")
            return
        with self._lock:
            self._starting -= 1
            if self._closed:
                self._stop(w)
                return
            self._idle.append(w)
        self._dispatch()

    def _drop_dead(self) -> None:
        """Replace idle workers that were killed while they waited (by hand, by the system)."""
        dead = [w for w in self._idle if not w.process.is_alive()]
        for w in dead:
            self._idle.remove(w)
            self.replaced += 1
            threading.Thread(target=self._replace, args=(w,), name="tm-parse-start", daemon=True).start()

    def _replace(self, w: _Worker) -> None:
        """Stop a dead worker and start another."""
        self._stop(w)
        self._grow()

    def _grow(self) -> None:
        """Start workers in the background until there are ``n`` (alive or starting)."""
        with self._lock:
            need = self.n - len(self._idle) - len(self._busy) - self._starting
            self._starting += max(0, need)
        for _ in range(max(0, need)):
            threading.Thread(target=self._add, name="tm-parse-start", daemon=True).start()

    def start(self) -> None:
        """Start the workers in the background (a call starts them too when none runs)."""
        with self._lock:
            self._closed = False
        self._grow()

    @staticmethod
    def _stop(w: _Worker) -> None:
        with contextlib.suppress(Exception):
            w.process.kill()
        with contextlib.suppress(Exception):
            w.conn.close()
        with contextlib.suppress(Exception):
            w.process.join(5)

    def close(self) -> None:
        """Stop every worker; calls still waiting fail with ``unavailable``."""
        with self._lock:
            self._closed = True
            calls = [c for q in self._pending.values() for c in q]
            self._pending.clear()
            self._turn.clear()
            workers = [*self._idle, *self._busy]
            self._idle.clear()
        for c in calls:
            if not c.future.done():
                c.future.set_exception(ServiceError("unavailable", "the service is stopping"))
        for w in workers:
            with contextlib.suppress(Exception):
                w.conn.send(None)
            self._stop(w)

    # ------------------------------------------------------------------ calls

    def submit(self, owner: str, target: str, *args: Any, what: str = "the file") -> concurrent.futures.Future[Any]:
        """Queue ``target(*args)`` (``"module.function"``) for the key ``owner``; its future.

        Raises
        ------
        ServiceError
            ``parse_queue_full`` (the key's queue is full), ``unavailable`` (closed).
        """
        with self._lock:
            if self._closed:
                raise ServiceError("unavailable", "the service is stopping")
            q = self._pending.setdefault(owner, collections.deque())
            if len(q) >= self.queue_depth:
                raise ServiceError("parse_queue_full", f"{len(q)} files of this key are already waiting to be "
                                   f"read (at most {self.queue_depth}); retry when they are answered",
                                   queued=len(q), limit=self.queue_depth)
            call = _Call(owner, target, args, what)
            q.append(call)
            if owner not in self._turn:
                self._turn.append(owner)
        self._grow()
        self._dispatch()
        return call.future

    async def call(self, owner: str, target: str, *args: Any, what: str = "the file") -> Any:
        """Run ``target(*args)`` in a worker for the key ``owner`` and await what it returns.

        Returns
        -------
        object
            What the function returned (pickled through the pipe).

        Raises
        ------
        SolverError
            What the function raised, with its own type and code.
        ServiceError
            ``parse_time_limit``, ``parse_cpu_limit``, ``parse_memory_limit``,
            ``parse_queue_full``, ``worker_failed``, ``unavailable``.
        """
        fut = self.submit(owner, target, *args, what=what)
        try:
            return await asyncio.wrap_future(fut)
        except asyncio.CancelledError:
            fut.cancel()  # a call still waiting is dropped; a running one ends by its limits
            raise

    def _cap(self) -> int:
        return self.n - 1 if self.n > 1 else 1

    def _dispatch(self) -> None:
        while True:
            with self._lock:
                self._drop_dead()
                if not self._idle or not self._turn:
                    return
                owner = next((o for o in self._turn if self._pending.get(o) and self._running[o] < self._cap()),
                             None)
                if owner is None:
                    return
                self._turn.remove(owner)
                q = self._pending[owner]
                call = q.popleft()
                if q:
                    self._turn.append(owner)  # its next call waits for the other keys' turns
                else:
                    del self._pending[owner]
                if not call.future.set_running_or_notify_cancel():
                    continue  # the request went away while it waited
                w = self._idle.pop()
                self._busy.add(w)
                self._running[owner] += 1
                w.busy_since = time.monotonic()
            threading.Thread(target=self._run, args=(w, call), name="tm-parse", daemon=True).start()

    def _run(self, w: _Worker, call: _Call) -> None:
        healthy = False
        try:
            w.conn.send((call.target, call.args, self.limits.cpu_s))
            if not w.conn.poll(self.limits.time_s):
                self._stop(w)
                call.future.set_exception(self._limit("time", call))
                return
            reply = w.conn.recv()
            healthy = reply[0] in ("ok", "error") and not reply[-1]
            if reply[0] == "ok":
                call.future.set_result(reply[1])
            elif reply[0] == "error":
                call.future.set_exception(error_from_dict(reply[1]))
            else:
                call.future.set_exception(self._limit("memory", call))
        except (EOFError, OSError):  # the worker died: a CPU or memory limit, or a crash
            call.future.set_exception(self._limit(self._death(w), call))
        except BaseException as e:  # noqa: BLE001 - never leave a request waiting
            log.exception("parse call failed")
            if not call.future.done():
                call.future.set_exception(ServiceError("worker_failed", f"the worker reading {call.what} "
                                                       f"failed ({type(e).__name__})"))
        finally:
            with self._lock:
                self._busy.discard(w)
                self._running[call.owner] -= 1
                if self._running[call.owner] <= 0:
                    del self._running[call.owner]
                w.busy_since = None
                keep = healthy and not self._closed
                if keep:
                    self._idle.append(w)
                else:
                    self.replaced += 1
            if not keep:
                self._stop(w)
                if not self._closed:
                    self._grow()
            self._dispatch()

    @staticmethod
    def _death(w: _Worker) -> str:
        w.process.join(5)
        code = w.process.exitcode
        if code == -signal.SIGXCPU:
            return "cpu"
        # an allocation refused under RLIMIT_AS ends C code in an abort or a fault; the system's OOM killer kills
        return "memory" if code in (-signal.SIGSEGV, -signal.SIGABRT, -signal.SIGBUS, -signal.SIGKILL, 1) else "crash"
    def _limit(self, kind: str, call: _Call) -> ServiceError:
        lim = self.limits
        setting = lim.names()
        if kind == "time":
            return ServiceError("parse_time_limit", f"reading {call.what} took longer than the {lim.time_s:g} s "
                                f"limit ({setting['time']}); the worker reading it was stopped. The file may be "
                                "damaged (a truncated or corrupted file some readers never finish)",
                                limit_s=lim.time_s, setting=setting["time"])
        if kind == "cpu":
            return ServiceError("parse_cpu_limit", f"reading {call.what} used more than the {lim.cpu_s:g} CPU "
                                f"seconds allowed ({setting['cpu']}); the worker reading it was stopped",
                                limit_s=lim.cpu_s, setting=setting["cpu"])
        if kind == "memory":
            mb = lim.memory_bytes / 2**20
            return ServiceError("parse_memory_limit", f"reading {call.what} needed more memory than the "
                                f"{mb:,.0f} MB a reader may use ({setting['memory']}, derived from "
                                "TETMORPH_MAX_FILE_EXPANDED_MB); the worker reading it was stopped",
                                limit_mb=round(mb), setting=setting["memory"])
        return ServiceError("worker_failed", f"the worker reading {call.what} ended unexpectedly; it was "
                            "replaced")

    # ------------------------------------------------------------------ state

    def pids(self) -> list[int]:
        """The workers' process ids (those still starting too)."""
        with self._lock:
            return [w.process.pid for w in [*self._idle, *self._busy]] + [p.pid for p in self._spawning]

    def health(self) -> dict[str, Any]:
        """Workers idle, busy and starting, calls waiting, the oldest call's age, and whether it is stuck.

        ``stuck``: a call has run past its wall-clock limit (plus a grace) without being
        stopped, or no worker is alive and none can be started.
        """
        now = time.monotonic()
        oldest = max((now - w.busy_since for w in self._busy if w.busy_since is not None), default=0.0)
        waiting = sum(len(q) for q in self._pending.values())
        alive = len(self._idle) + len(self._busy) + self._starting
        stuck = oldest > self.limits.time_s + 10 or (alive == 0 and self.failed_starts > 0)
        return {"workers": self.n, "idle": len(self._idle), "busy": len(self._busy), "starting": self._starting,
                "waiting": waiting, "oldest_call_s": round(oldest, 3), "replaced": self.replaced,
                "stuck": bool(stuck), "saturated": bool(not self._idle and waiting > 2 * self.n)}


#: Pools by (workers, limits, queue depth): every app of a process with the same settings shares one.
_SHARED: dict[tuple[int, ParseLimits, int], ParsePool] = {}
_SHARED_LOCK = threading.Lock()


def shared_pool(workers: int, limits: ParseLimits, queue_depth: int) -> ParsePool:
    """The process's pool for these settings (started once, stopped when the process exits)."""
    key = (workers, limits, queue_depth)
    with _SHARED_LOCK:
        pool = _SHARED.get(key)
        if pool is None or pool._closed:
            pool = _SHARED[key] = ParsePool(workers, limits, queue_depth)
            pool.start()
        return pool


def reader_pids() -> set[int]:
    """The process ids of every shared pool's workers in this process (to tell them from other children)."""
    with _SHARED_LOCK:
        pools = list(_SHARED.values())
    return {pid for pool in pools for pid in pool.pids()}


@atexit.register
def _close_shared() -> None:
    for pool in list(_SHARED.values()):
        pool.close()
