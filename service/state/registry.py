"""The service's meshes and sessions: what the routes call.

:class:`Registry` composes the persistent :class:`~service.state.store.Store`,
the :class:`~service.state.mesh_cache.MeshCache`, the
:class:`~service.state.factor_cache.FactorCache` and the
:class:`~service.state.builder.Builder`. A session owns a
:class:`~solver.deform.deformer.Deformer` while it is in the factorization
cache; an evicted session is rebuilt transparently on its next update.
Updates to one session are serialized by its lock. A MOVE becomes the
session's state (memory and disk) only after it solved and every number of its
result is finite.

With a shared store (PostgreSQL, several replicas) a session's record is the
truth and this process holds a cache of it: every request on a session
records its use and reads the stored version; a newer version (a MOVE
committed by another replica) is loaded before the request is served. A MOVE
commits only if the version it was solved from is still the stored one;
otherwise the session is reloaded and the MOVE answers 409
``version_conflict``, which the client retries.

A session's presets (named MOVEs a client keeps with it) are not part of its
morph state: they are stored apart from the versioned record, so saving them
neither bumps the version nor makes a concurrent MOVE conflict, and a MOVE's
commit never writes them. With a shared store the answers that show them
read them from the store first (another replica may have replaced them).
"""

from __future__ import annotations

import asyncio
import copy
import ctypes
import ctypes.util
import gc
import logging
import math
import os
import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import numpy as np

from solver.constraints.spec import parse_spec
from solver.deform.deformer import Deformer, DeformResult
from solver.errors import InvalidMeshError
from solver.mesh import Mesh

from ..errors import NotFound, ServiceError, error_from_dict
from ..models.move import check_move_extent, reduced_move
from ..models.spec import check_spec_ids, stored_surfaces
from ..settings import Settings
from .builder import Builder, small_report
from .factor_cache import FactorCache
from .mesh_cache import MeshCache
from .session import Session, SessionStatus
from .store import Store, new_id, valid_id
from .stores import open_store

__all__ = ["Registry", "all_finite"]

log = logging.getLogger("tetmorph.service")


def all_finite(doc: Any) -> bool:
    """True if every number in a JSON-like document is finite.

    Examples
    --------
    >>> all_finite({"a": [1, 2.5, {"b": None}]}), all_finite({"a": [float("inf")]})
    (True, False)
    """
    if isinstance(doc, float):
        return math.isfinite(doc)
    if isinstance(doc, dict):
        return all(all_finite(v) for v in doc.values())
    if isinstance(doc, (list, tuple)):
        return all(all_finite(v) for v in doc)
    return True


def _release_memory() -> None:
    """Collect garbage, empty MKL's buffer pool, and hand freed heap pages back to the system (glibc)."""
    gc.collect()
    mkl = os.environ.get("PYPARDISO_MKL_RT")  # set by the solver when it located MKL
    if mkl:
        try:
            ctypes.CDLL(mkl).mkl_free_buffers()
        except (OSError, AttributeError):
            pass
    name = ctypes.util.find_library("c")
    if name:
        try:
            ctypes.CDLL(name).malloc_trim(0)
        except (OSError, AttributeError):  # not glibc
            pass


class Registry:
    """Meshes and sessions of one service instance.

    Parameters
    ----------
    settings : Settings
    store : Store, optional
        Default: :func:`~service.state.stores.open_store` of the settings.
    """

    def __init__(self, settings: Settings, store: Store | None = None) -> None:
        self.settings = settings
        self.store: Store = store if store is not None else open_store(
            settings.data_dir, settings.database_url, settings.max_file_points, settings.max_file_cells)
        self.meshes = MeshCache()
        self.factors = FactorCache(settings.cache_budget_bytes)
        self.builder = Builder(settings.build_workers, settings.solve_pool_size, settings.solve_options())
        self.sessions: dict[str, Session] = {}
        self._boxes: dict[int, tuple[Mesh, list[float], list[float]]] = {}
        #: Called with the seconds of every solved MOVE (the metrics set it).
        self.observe_solve: Callable[[float], None] = lambda seconds: None
        #: Sessions removed for idleness: id -> (owner, when) (with a shared store: asked from it).
        self.expired: dict[str, tuple[str, float]] = {}
        if not self.store.shared:  # a shared store's sessions are loaded when first asked for
            for rec in self.store.list_sessions():
                s = Session.from_record(rec)
                self.sessions[s.id] = s
            self.expired = {r["id"]: (r["owner"], r["expired_at"]) for r in self.store.list_expired()}

    def start(self) -> None:
        """Start the worker threads (again, after :meth:`close`)."""
        if self.builder.closed:
            self.builder.start()

    def close(self) -> None:
        """Stop the worker threads."""
        self.builder.close()

    def close_store(self) -> None:
        """Release the store's connections."""
        self.store.close()

    async def run(self, fn: Callable[..., Any], *args: Any) -> Any:
        """Run a blocking call (file export, packing) in a worker thread."""
        return await self.builder.run(fn, *args)

    @property
    def evictions(self) -> int:
        """Sessions evicted from the factorization cache so far."""
        return self.factors.evictions

    @property
    def cached_sessions(self) -> int:
        """Sessions whose factorizations are in the cache."""
        return len(self.factors)

    @property
    def cache_bytes(self) -> int:
        """Bytes held by cached factorizations."""
        return self.factors.total

    # ----------------------------------------------------------------- meshes
    def mesh_meta(self, owner: str, mesh_id: str) -> dict[str, Any]:
        """Meta of a mesh owned by ``owner``; 404 otherwise."""
        meta = self.store.mesh_meta(mesh_id)
        if meta is None or meta.get("owner") != owner:
            raise NotFound("mesh", mesh_id)
        return meta

    def list_meshes(self, owner: str) -> list[dict[str, Any]]:
        """Metas of the meshes of ``owner``, oldest first."""
        return [m for m in self.store.list_meshes() if m.get("owner") == owner]

    async def mesh(self, meta: dict[str, Any]) -> Mesh:
        """The parsed mesh of a stored meta (read in a worker thread on a miss)."""
        m = self.meshes.get(meta["id"])
        if m is None:
            m = await self.builder.solve(self.store.load_mesh, meta)
            self.meshes.put(meta["id"], m)
        return m

    def _check_size(self, mesh: Mesh) -> None:
        m = mesh.elements
        if m > self.settings.max_elements:
            raise ServiceError("too_many_elements", f"the mesh has {m} volume elements; this service "
                               f"accepts at most {self.settings.max_elements}",
                               elements=m, limit=self.settings.max_elements)

    async def add_mesh(self, owner: str, name: str, fmt: str, files: dict[str, bytes],
                       main: str, mesh_id: str | None = None) -> dict[str, Any]:
        """Store uploaded file(s) and parse them.

        Parameters
        ----------
        owner, name : str
        fmt : str
            meshio format name.
        files : dict of str to bytes
            File name (sanitized) to content; ``main`` is the one to read
            (TetGen's ``.node`` next to its ``.ele``).
        main : str
        mesh_id : str, optional
            A fixed id (the demo); random by default.

        Returns
        -------
        dict
            The mesh meta (id, counts, element types, sets, quality under ``info``).
        """
        mid = mesh_id or new_id("m")
        meta = {"id": mid, "owner": owner, "name": name, "format": fmt, "file": main,
                "files": sorted(files), "created": time.time()}

        async def write_and_read(d: Path) -> Mesh:
            for fname, data in files.items():
                (d / fname).write_bytes(data)
            return await self.builder.run(self.store.load_mesh, meta)

        return await self._store_mesh(meta, write_and_read)

    async def add_mesh_arrays(self, owner: str, name: str, mesh: Mesh,
                              extra: dict[str, Any] | None = None) -> dict[str, Any]:
        """Store a mesh built from arrays (JSON upload, tetrahedralization)."""
        self._check_size(mesh)  # before anything is written
        meta = {"id": new_id("m"), "owner": owner, "name": name, "format": "arrays",
                "file": "arrays.npz", "files": ["arrays.npz"], "created": time.time(),
                **(extra or {})}

        async def write(d: Path) -> Mesh:
            self.store.save_arrays(meta["id"], mesh)
            return mesh

        return await self._store_mesh(meta, write)

    async def _store_mesh(self, meta: dict[str, Any],
                          produce: Callable[[Path], Awaitable[Mesh]]) -> dict[str, Any]:
        """Create the mesh's directory and let ``produce`` fill it and return the parsed mesh.

        Then check its size and save ``meta`` with its summary; remove everything on failure.
        """
        mid = meta["id"]
        d = self.store.new_mesh_dir(mid)
        try:
            mesh = await produce(d)
            self._check_size(mesh)
            meta["info"] = await self.builder.solve(mesh.info)
            self.store.save_mesh_meta(meta)
        except BaseException:
            self.store.delete_mesh(mid)
            raise
        self.meshes.put(mid, mesh)
        return meta

    def delete_mesh(self, owner: str, mesh_id: str) -> None:
        """Delete a mesh; 409 while sessions use it."""
        self.mesh_meta(owner, mesh_id)
        users = (self.store.sessions_of_mesh(mesh_id) if self.store.shared else
                 sorted(s.id for s in self.sessions.values()
                        if s.mesh_id == mesh_id or any(m == mesh_id for _, m in stored_surfaces(s.spec))))
        if users:
            raise ServiceError("mesh_in_use", f"mesh {mesh_id} is used by sessions {users}; delete "
                               "them first", sessions=users)
        self.meshes.drop(mesh_id)
        self.store.delete_mesh(mesh_id)

    def mesh_file(self, meta: dict[str, Any]) -> Path:
        """Path of the stored main file."""
        return self.store.mesh_dir(meta["id"]) / meta["file"]

    # --------------------------------------------------------------- sessions
    def session(self, owner: str, session_id: str) -> Session:
        """A session of ``owner``; 404 otherwise (also for other keys' sessions), 410 when expired.

        With a shared store this records the use and loads the record when it
        is newer than this process's copy (or not here at all).
        """
        s = self.sessions.get(session_id) if valid_id(session_id) else None
        if self.store.shared and valid_id(session_id):
            s = self._sync(session_id, s)
        if s is None or s.owner != owner:
            gone = self.expired.get(session_id) if not self.store.shared else self.store.expired(session_id)
            if gone is not None and gone[0] == owner:
                raise ServiceError("session_expired", f"session {session_id} was removed after "
                                   f"{self.settings.session_ttl_s:g} s without use", session_id=session_id,
                                   expired_at=gone[1], ttl_s=self.settings.session_ttl_s)
            raise NotFound("session", session_id)
        return s

    def _sync(self, session_id: str, s: Session | None) -> Session | None:
        """The local copy of a shared session, current with its record (None when it is gone)."""
        now = time.time()
        version = self.store.touch_session(session_id, now)
        if version is None:
            if s is not None and not s.busy:
                self._drop_local(s)
            return None
        if s is None:
            rec = self.store.load_session(session_id)
            if rec is None:
                return None
            s = Session.from_record(rec)
            self.sessions[s.id] = s
        elif version != s.version and not s.lock.locked():
            self._reload(s)
        s.last_used = max(s.last_used, now)
        return s

    def _reload(self, s: Session) -> bool:
        """Load a session's record into this process's copy; False when the record is gone."""
        rec = self.store.load_session(s.id)
        if rec is None:
            return False
        if rec.get("version", 0) != s.version or rec.get("last_move") != s.last_move:
            s.positions, s.report = None, None  # recomputed from the record's MOVE when asked for
        s.version, s.last_move = int(rec.get("version", 0)), rec.get("last_move")
        s.last_used = max(s.last_used, float(rec.get("last_used", s.last_used)))
        s.presets = list(rec.get("presets") or [])
        return True

    def _drop_local(self, s: Session) -> None:
        """Forget this process's copy of a session (its record is gone or moved on)."""
        self.sessions.pop(s.id, None)
        self.factors.drop(s.id)
        s.deformer, s.positions = None, None
        if s.build_task is not None and not s.build_task.done():
            s.build_task.cancel()
        s.build_task = None

    def list_sessions(self, owner: str) -> list[Session]:
        """Sessions of ``owner``, oldest first."""
        if self.store.shared:
            out = []
            for rec in self.store.list_sessions():
                if rec.get("owner") != owner:
                    continue
                s = self.sessions.get(rec["id"])
                if s is None:
                    s = self.sessions[rec["id"]] = Session.from_record(rec)
                elif rec.get("version", 0) != s.version and not s.lock.locked():
                    self._reload(s)
                s.presets = list(rec.get("presets") or [])
                out.append(s)
            return sorted(out, key=lambda s: s.created)
        return sorted((s for s in self.sessions.values() if s.owner == owner),
                      key=lambda s: s.created)

    def set_presets(self, s: Session, presets: list[dict[str, Any]]) -> None:
        """Replace a session's presets (validated by the route): the store first, then memory.

        The session's lock is not taken (a MOVE being solved goes on) and its
        version does not change.

        Raises
        ------
        NotFound
            The session's record is gone (another replica deleted it); nothing is stored.
        """
        if not self.store.save_presets(s.id, presets):
            if self.store.shared:
                self._drop_local(s)
            raise NotFound("session", s.id)
        s.presets = presets

    def refresh_presets(self, s: Session) -> None:
        """With a shared store: read the session's presets (another replica may have replaced them)."""
        if self.store.shared:
            presets = self.store.load_presets(s.id)
            if presets is not None:
                s.presets = presets

    async def resolve_spec(self, owner: str, spec: dict[str, Any]) -> dict[str, Any]:
        """The SPEC with each stored target surface (``{"mesh_id": ID}``) as its vertices and triangles.

        Raises
        ------
        ServiceError
            422 ``surface_not_found`` (no such mesh of the owner) or
            ``not_a_surface`` (a volume mesh), naming the SPEC field.
        """
        refs = stored_surfaces(spec)
        if not refs:
            return spec
        out = copy.copy(spec)
        out["targets"] = list(spec["targets"])
        for k, mid in refs:
            where = f"SPEC.targets[{k}].surface.mesh_id"
            meta = self.store.mesh_meta(mid)
            if meta is None or meta.get("owner") != owner:
                raise ServiceError("surface_not_found", f"{where}: no stored mesh {mid!r} (upload the surface "
                                   "with POST /v1/meshes)", field=where, mesh_id=mid)
            m = await self.mesh(meta)
            if not m.is_surface:
                raise ServiceError("not_a_surface", f"{where}: mesh {mid} is a volume mesh ({m.elements} "
                                   "elements); a target is a triangle surface (STL, OBJ, PLY, OFF)",
                                   field=where, mesh_id=mid)
            surface = await self.run(lambda m=m: {"vertices": m.V.tolist(), "triangles": m.surface.tolist()})
            out["targets"][k] = {**spec["targets"][k], "surface": surface}
        return out

    async def session_spec(self, s: Session) -> dict[str, Any]:
        """The SPEC a session builds from (stored target surfaces resolved, once per process)."""
        if s.resolved is None:
            s.resolved = await self.resolve_spec(s.owner, s.spec)
        return s.resolved

    async def create_session(self, owner: str, mesh_id: str, spec: dict[str, Any],
                             session_id: str | None = None) -> Session:
        """Create a session and start its build.

        Waits until every SPEC error has surfaced (selections resolved and
        checked), then up to ``build_wait_s`` for the factorization. The
        returned session's ``status`` is ``ready`` or ``building``.

        Raises
        ------
        SpecError, ConstraintError, InvalidMeshError
            The SPEC does not fit the mesh; nothing is stored.
        ServiceError
            404 unknown mesh, 429 too many sessions, 422 an unknown target surface.
        """
        self.sweep()
        meta = self.mesh_meta(owner, mesh_id)
        check_spec_ids(spec, int(meta.get("info", {}).get("vertices", 0)))
        resolved = await self.resolve_spec(owner, spec)
        parse_spec(resolved)  # malformed SPEC: 422 before anything is stored
        limit = self.settings.max_sessions
        mine = (self.store.count_sessions(owner) if self.store.shared else
                sum(1 for s in self.sessions.values() if s.owner == owner))
        if mine >= limit:
            raise ServiceError("session_limit", f"this key already has {mine} sessions (limit "
                               f"{limit}); delete one first", sessions=mine, limit=limit)
        sid = session_id or new_id("s")
        if sid in self.sessions:
            raise ServiceError("session_exists", f"session {sid} exists", session_id=sid)
        s = Session(id=sid, owner=owner, mesh_id=meta["id"], spec=spec, created=time.time())
        s.resolved = resolved
        self.sessions[sid] = s
        task = self._start_build(s)
        checked = asyncio.ensure_future(s.checked.wait())
        stored = False
        try:
            await asyncio.wait({task, checked}, return_when=asyncio.FIRST_COMPLETED)
            if task.done() and task.exception() is not None:
                raise task.exception()  # type: ignore[misc]
            self.store.create_session(s.record(), limit)  # atomic count and insert when shared
            stored = True
            try:
                await asyncio.wait_for(asyncio.shield(task), self.settings.build_wait_s)
            except TimeoutError:
                pass  # answered 202; the build goes on
        except BaseException:
            checked.cancel()
            self.sessions.pop(sid, None)
            if stored:
                self.store.delete_session(sid)
            if not task.done():
                task.cancel()
            raise
        return s

    def _start_build(self, s: Session) -> asyncio.Task[Deformer]:
        return self.builder.start_build(s, self.session_mesh, self._built, self._failed, self.session_spec)

    def _built(self, s: Session, d: Deformer) -> None:
        self.factors.add(s.id, d.nbytes)
        def pinned(sid: str) -> bool:
            o = self.sessions.get(sid)
            return o is not None and o.busy

        for sid in self.factors.evict(keep=s.id, pinned=pinned):
            o = self.sessions.get(sid)
            if o is not None:
                o.deformer, o.status, o.build_task = None, SessionStatus.evicted, None
                log.info("evicted session %s from the factorization cache", sid)

    def _failed(self, s: Session) -> None:
        # only a session the store already holds records its failure: a build that fails while its
        # POST is still being answered (a SPEC that does not fit the mesh) is refused, and stores nothing
        if s.id in self.sessions and self.store.mesh_meta(s.mesh_id) is not None and \
                self.store.load_session(s.id) is not None:
            self.store.save_session(s.record())

    async def session_mesh(self, s: Session) -> Mesh:
        """The parsed rest mesh of a session (from its deformer or the cache when there).

        Raises
        ------
        InvalidMeshError
            The mesh was removed from the data directory behind the service's back.
        """
        if s.deformer is not None:
            return s.deformer.mesh
        m = self.meshes.get(s.mesh_id)
        if m is not None:
            return m
        meta = self.store.mesh_meta(s.mesh_id)
        if meta is None:
            raise InvalidMeshError(f"the session's mesh {s.mesh_id} no longer exists",
                                   code="mesh_missing")
        return await self.mesh(meta)

    async def deformer(self, s: Session) -> Deformer:
        """The session's deformer, rebuilding it if evicted or never built here."""
        d = s.deformer
        if d is not None:
            self.factors.touch(s.id)
            return d
        if s.status is SessionStatus.failed and s.build_task is None:
            raise error_from_dict(s.error or {"code": "build_failed"}, prefix=f"session {s.id} failed to build: ")
        return await self._start_build(s)

    async def deform(self, s: Session, move: dict[str, Any], inversion: str | None = None,
                     quality: str = "basic", repair: bool | None = None) -> DeformResult:
        """Solve one MOVE (serialized per session) and make it the session's state.

        The MOVE is committed (memory and disk) only after it solved and every
        number of its positions and REPORT is finite; otherwise the session is
        left exactly as it was.

        Raises
        ------
        SpecError
            Malformed MOVE.
        InversionError
            ``reject`` policy and an inverting move; the session is unchanged.
        ServiceError
            ``non_finite_result``: the solve produced non-finite numbers.
        """
        async with s.lock:
            d = await self.deformer(s)
            move = reduced_move(move)
            check_move_extent(move, *self._bbox(d.mesh))
            mv = d.parse_move(move)
            t0 = time.perf_counter()
            r = await self.builder.solve(d.solve, mv, inversion, quality, repair)
            self.observe_solve(time.perf_counter() - t0)
            return self._commit(s, r, move)

    async def boundary_stage(self, s: Session, move: dict[str, Any]) -> tuple[Deformer, Any, dict[str, Any]]:
        """The boundary positions of a MOVE first (nothing is committed): ``(deformer, stage, move)``.

        Pass them to :meth:`complete_stage` for the interior, the check and the commit.
        """
        async with s.lock:
            d = await self.deformer(s)
            move = reduced_move(move)
            check_move_extent(move, *self._bbox(d.mesh))
            mv = d.parse_move(move)
            stage = await self.builder.solve(d.solve_boundary, mv)
            return d, stage, move

    async def complete_stage(self, s: Session, d: Deformer, stage: Any, move: dict[str, Any],
                             inversion: str | None = None, repair: bool | None = None) -> DeformResult:
        """Finish a :meth:`boundary_stage` solve and commit it like :meth:`deform`."""
        async with s.lock:
            if s.deformer is not d:  # rebuilt or evicted in between: solve afresh
                d = await self.deformer(s)
                stage = d.parse_move(move)
            t0 = time.perf_counter()
            r = await self.builder.solve(d.solve, stage, inversion, "basic", repair)
            self.observe_solve(time.perf_counter() - t0)
            return self._commit(s, r, move)

    def _commit(self, s: Session, r: DeformResult, move: dict[str, Any]) -> DeformResult:
        """Make a solved MOVE the session's state, memory and disk, if every number is finite."""
        finite = bool(np.isfinite(r.V).all()) and all_finite(r.report)
        r.report["finite"] = finite
        if not finite:
            raise ServiceError("non_finite_result", "the solve produced non-finite numbers; the "
                               "session is unchanged", session_id=s.id)
        # a clamped MOVE is stored as applied, so a rebuild reproduces these positions
        applied = r.move.to_dict() if r.report.get("clamped") and r.move is not None else move
        rec = {**s.record(), "last_move": applied, "last_used": time.time()}
        self._store_commit(s, rec)  # the store first: a failed write leaves memory unchanged
        s.positions, s.report, s.last_move = r.V, small_report(r.report), applied
        s.updates += 1
        s.last_used = rec["last_used"]
        return r

    def _store_commit(self, s: Session, rec: dict[str, Any]) -> None:
        """Write a session's new record if its version is still ``s.version``; else reload and answer 409."""
        solved_from = s.version
        version = self.store.commit_session(rec, solved_from)
        if version is None:
            if not self._reload(s):
                self._drop_local(s)
                raise NotFound("session", s.id)
            raise ServiceError("version_conflict", f"session {s.id} changed while this request was solved "
                               f"(version {solved_from}, now {s.version}); nothing was committed: retry",
                               session_id=s.id, version=solved_from, current=s.version)
        s.version = version

    def _bbox(self, mesh: Mesh) -> tuple[list[float], list[float]]:
        key = id(mesh)
        box = self._boxes.get(key)
        if box is None or box[0] is not mesh:
            V = mesh.V[mesh.referenced] if mesh.referenced.any() else mesh.V
            box = (mesh, V.min(0).tolist(), V.max(0).tolist())
            self._boxes = {key: box, **dict(list(self._boxes.items())[:15])}
        return box[1], box[2]

    async def positions(self, s: Session) -> np.ndarray:
        """Current deformed positions (rest positions before the first MOVE)."""
        async with s.lock:
            if s.positions is None and s.last_move is not None:
                d = await self.deformer(s)  # a build restores positions from the last MOVE
                if s.positions is None:  # built before the record moved on (another replica's MOVE)
                    r = await self.builder.solve(d.solve, s.last_move, "warn")
                    s.positions, s.report = r.V, small_report(r.report)
            if s.positions is None:
                return (await self.session_mesh(s)).V
            return s.positions

    async def reset(self, s: Session) -> None:
        """Back to the rest shape; the last MOVE is forgotten."""
        async with s.lock:
            self._store_commit(s, {**s.record(), "last_move": None, "last_used": time.time()})
            s.positions, s.report, s.last_move = None, None, None

    async def delete_session(self, s: Session) -> None:
        """Remove a session from memory and disk (waits for a running update)."""
        async with s.lock:
            self._forget(s)
        _release_memory()

    def _forget(self, s: Session) -> None:
        self._drop_local(s)
        self.store.delete_session(s.id)

    def sweep(self, now: float | None = None) -> list[str]:
        """Remove sessions idle longer than the TTL; return their ids.

        With a shared store the records are swept in the database (one
        statement, so replicas sweeping at once remove each session once), and
        this process forgets its copies of sessions whose records are gone.
        """
        now = time.time() if now is None else now
        ttl = self.settings.session_ttl_s
        if self.store.shared:
            for s in self.sessions.values():
                if s.busy:
                    self.store.touch_session(s.id, now)
            ids = [sid for sid, _ in self.store.expire_idle(now - ttl)]
            alive = self.store.existing(list(self.sessions))
            for s in [s for s in self.sessions.values() if s.id not in alive and not s.busy]:
                self._drop_local(s)
            self.store.forget_expired(now - self.settings.expired_memory_s)
            if ids:
                log.info("removed %d idle sessions", len(ids))
                _release_memory()
            return ids
        gone = [s for s in self.sessions.values() if now - s.last_used > ttl and not s.busy]
        for s in gone:
            self._forget(s)
            self.expired[s.id] = (s.owner, now)
            self.store.save_expired(s.id, s.owner, now)
            log.info("removed idle session %s", s.id)
        for sid in [k for k, (_, at) in self.expired.items() if now - at > self.settings.expired_memory_s]:
            self.expired.pop(sid, None)
            self.store.delete_expired(sid)
        if gone:
            _release_memory()
        return [s.id for s in gone]
