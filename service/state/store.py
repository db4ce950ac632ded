"""Persistence of meshes and sessions: the :class:`Store` protocol and its filesystem implementation.

:class:`FileStore` keeps everything in a local data directory (the embedded
default); :class:`~service.state.pg_store.PgStore` keeps the records in
PostgreSQL for several replicas (``TETMORPH_DATABASE_URL``). Both keep mesh
files in the data directory (on a volume every replica mounts, for replicas).

Layout (``data_dir``)::

    secret.key                       the installation secret of owner ids (mode 0600)
    meshes/<mesh_id>/meta.json       owner, name, format, main file, summary
    meshes/<mesh_id>/<files>         the uploaded file(s), byte for byte, or arrays.npz
    sessions/<session_id>.json       owner, mesh id, SPEC, last MOVE, timestamps
    sessions/presets/<id>.json       the session's named MOVEs (none when missing)
    sessions/history/<id>.json       the session's undo history (empty when missing)
    sessions/workspace/<id>.json     the session's workspace (regions, labels, DOE plan; empty when missing)
    meshes/<mesh_id>.workspace.json  the mesh's workspace (beside its folder; empty when missing)
    sessions/expired/<id>.json       sessions removed for idleness (they answer 410 for a while)

JSON files are replaced atomically (written to a temporary file of the same
folder, flushed to the disk, then renamed over the record), so a crash or a
full disk never leaves a half-written record: a write that fails leaves the
record it would have replaced as it was, and no temporary file. A restart
reloads every session and rebuilds it on first use.

A session's presets, undo history and workspace are kept apart from its
record: a MOVE's commit writes the record (its version checked) and never
them, and writing them never touches the record or its version.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from solver.errors import InvalidMeshError
from solver.io import read_mesh
from solver.io.bounds import ReadBounds
from solver.mesh import Mesh, mesh_from_arrays

from ..security import Limiter, RateLimiter
from .files import valid_id
from .files import write_json as _write_json
from .workspaces import EMPTY_WORKSPACE, FileWorkspaces, WorkspaceOf

__all__ = ["Store", "FileStore", "EMPTY_HISTORY", "EMPTY_WORKSPACE", "WorkspaceOf", "new_id", "valid_id",
           "read_mesh_files", "record_only", "free_bytes"]

#: The undo history of a session none was saved for: nothing applied, nothing undone.
EMPTY_HISTORY: dict[str, Any] = {"applied": [], "undone": []}

def new_id(prefix: str) -> str:
    """Random resource id such as ``m_3f9c0a1b2d4e6f70``."""
    return f"{prefix}_{secrets.token_hex(8)}"


def free_bytes(path: str | os.PathLike[str]) -> int:
    """Bytes of the file system of ``path`` that this process may still write (``shutil.disk_usage``)."""
    return shutil.disk_usage(path).free


def record_only(record: dict[str, Any]) -> dict[str, Any]:
    """A session record without the ``presets`` a loaded record carries (they are stored apart)."""
    return {k: v for k, v in record.items() if k != "presets"} if "presets" in record else record


class Store(Protocol):
    """What the registry keeps across restarts (and, with PostgreSQL, shares between replicas).

    Session records carry a ``version``: :meth:`commit_session` writes a record
    only if the stored version is the one it was solved from. A session's
    presets are stored apart (:meth:`save_presets`, no version): the records
    :meth:`load_session` and :meth:`list_sessions` answer carry them under
    ``presets`` (``[]`` when none were saved); the writes of records ignore that key.
    """

    #: True when other processes write the same records (replicas): the registry re-reads them.
    shared: bool
    root: Path
    #: What a stored file may declare or expand to when it is read back.
    bounds: ReadBounds

    def mesh_dir(self, mesh_id: str) -> Path:
        """Directory of one mesh's files."""

    def new_mesh_dir(self, mesh_id: str) -> Path:
        """Create and return the directory for a new mesh."""

    def save_mesh_meta(self, meta: dict[str, Any]) -> None:
        """Write (or replace) a mesh's meta."""

    def mesh_meta(self, mesh_id: str) -> dict[str, Any] | None:
        """The stored meta of a mesh, or None."""

    def list_meshes(self) -> list[dict[str, Any]]:
        """Every stored mesh's meta, oldest first."""

    def delete_mesh(self, mesh_id: str) -> None:
        """Remove a mesh's meta and files."""

    def save_arrays(self, mesh_id: str, mesh: Mesh) -> None:
        """Store a mesh given as arrays."""

    def load_mesh(self, meta: dict[str, Any]) -> Mesh:
        """Read a stored mesh back (validated)."""

    def create_session(self, record: dict[str, Any], limit: int) -> None:
        """Insert a new session record; 429 ``session_limit`` when its owner has ``limit`` already."""

    def update_session(self, record: dict[str, Any], version: int) -> bool:
        """Write ``record`` over the stored one if it exists at ``version`` (never an insert, the version kept).

        A deleted session stays deleted, whichever replica wrote last: there is
        no write of a session record that could bring it back.
        """

    def commit_session(self, record: dict[str, Any], version: int) -> int | None:
        """Write ``record`` if the stored version is ``version``; the new version, or None when it is not."""

    def load_session(self, session_id: str) -> dict[str, Any] | None:
        """One session record (with its presets), or None."""

    def touch_session(self, session_id: str, now: float) -> int | None:
        """Record a use of the session; its stored version, or None when it no longer exists."""

    def save_presets(self, session_id: str, presets: list[dict[str, Any]]) -> bool:
        """Replace a session's presets (its record and version untouched); False when the session is gone."""

    def load_presets(self, session_id: str) -> list[dict[str, Any]] | None:
        """A session's presets (``[]`` when none were saved), or None when the session is gone."""

    def save_history(self, session_id: str, history: dict[str, Any]) -> bool:
        """Replace a session's undo history (record and version untouched); False when the session is gone."""

    def load_history(self, session_id: str) -> dict[str, Any] | None:
        """A session's undo history (:data:`EMPTY_HISTORY` when none was saved), or None when it is gone."""

    def save_workspace(self, of: WorkspaceOf, ident: str, doc: dict[str, Any]) -> bool:
        """Replace a mesh's or session's workspace (nothing else touched); False when it is gone."""

    def load_workspace(self, of: WorkspaceOf, ident: str) -> dict[str, Any] | None:
        """A mesh's or session's workspace (empty when none was saved), or None when it is gone."""

    def list_sessions(self) -> list[dict[str, Any]]:
        """Every stored session record (with its presets)."""

    def count_sessions(self, owner: str) -> int:
        """Sessions of one owner."""

    def delete_session(self, session_id: str) -> None:
        """Remove a session record."""

    def sessions_of_mesh(self, mesh_id: str) -> list[str]:
        """Ids of the sessions on a mesh or with it as a target surface."""

    def existing(self, ids: list[str]) -> set[str]:
        """Which of ``ids`` still have records."""

    def expire_idle(self, before: float) -> list[tuple[str, str]]:
        """Remove the sessions last used before ``before`` and remember them as expired: their ``(id, owner)``."""

    def save_expired(self, session_id: str, owner: str, at: float) -> None:
        """Remember that a session was removed for idleness."""

    def expired(self, session_id: str) -> tuple[str, float] | None:
        """``(owner, expired_at)`` of an expired session, or None."""

    def list_expired(self) -> list[dict[str, Any]]:
        """Every remembered expired session."""

    def delete_expired(self, session_id: str) -> None:
        """Forget an expired session."""

    def forget_expired(self, before: float) -> int:
        """Forget the sessions that expired before ``before``."""

    def remove_orphans(self) -> list[str]:
        """Remove what interrupted uploads and writes left behind."""

    def rename_owner(self, old: str, new: str) -> int:
        """Give every record of owner ``old`` to ``new``."""

    def writable(self) -> bool:
        """True when records can be written now (readiness)."""

    def rate_limiter(self, rate: float, burst: int) -> Limiter:
        """The request rate limiter of this store's processes: ``rate`` per second per key, bursts of ``burst``."""

    def close(self) -> None:
        """Release connections."""


def _surfaces(spec: dict[str, Any]) -> list[tuple[int, str]]:
    from ..models.spec import stored_surfaces

    return stored_surfaces(spec)


def read_mesh_files(root: Path, meta: dict[str, Any], bounds: ReadBounds | None = None) -> Mesh:
    """Read a stored mesh of ``root/meshes`` back (validated), refusing files that declare more than the bounds.

    Raises
    ------
    InvalidMeshError
        The stored file no longer reads (e.g. deleted by hand).
    """
    d = root / "meshes" / meta["id"]
    if meta.get("format") == "arrays":
        try:
            with np.load(d / "arrays.npz") as z:
                sets = {k[4:]: z[k] for k in z.files if k.startswith("set:")}
                T = z["T"] if z["T"].size else None
                surface = z["surface"] if T is None else None
                return mesh_from_arrays(z["V"], T, surface, sets=sets)
        except OSError as e:
            raise InvalidMeshError(f"stored mesh {meta['id']} is unreadable: {e}",
                                   code="unreadable_file") from e
    return read_mesh(d / meta["file"], meta.get("format"), bounds=bounds)


class FileStore(FileWorkspaces):
    """Meshes and session records on disk (one process writes them).

    Parameters
    ----------
    root : path
        The data directory; created if missing.
    bounds : ReadBounds, optional
        What an uploaded file may declare or expand to.
    min_free_bytes : int
        The free space the data directory keeps in reserve: below it :meth:`writable` is False.
    """

    shared = False

    def __init__(self, root: str | os.PathLike[str], bounds: ReadBounds | None = None,
                 min_free_bytes: int = 0) -> None:
        self.root = Path(root)
        #: What an uploaded file may declare or expand to (checked before it is read).
        self.bounds = bounds or ReadBounds()
        #: Free space in reserve: with less, the store says it is not writable (``TETMORPH_MIN_FREE_MB``).
        self.min_free_bytes = min_free_bytes
        self.meshes_dir = self.root / "meshes"
        self.sessions_dir = self.root / "sessions"
        self.presets_dir = self.sessions_dir / "presets"
        self.history_dir = self.sessions_dir / "history"
        self.workspace_dir = self.sessions_dir / "workspace"
        self.meshes_dir.mkdir(parents=True, exist_ok=True)
        self.sessions_dir.mkdir(parents=True, exist_ok=True)

    # ----------------------------------------------------------------- meshes
    def mesh_dir(self, mesh_id: str) -> Path:
        """Directory of one mesh (not necessarily existing)."""
        return self.meshes_dir / mesh_id

    def new_mesh_dir(self, mesh_id: str) -> Path:
        """Create and return the directory for a new mesh."""
        d = self.mesh_dir(mesh_id)
        d.mkdir(parents=True, exist_ok=False)
        return d

    def save_mesh_meta(self, meta: dict[str, Any]) -> None:
        """Write (or replace) a mesh's ``meta.json``."""
        _write_json(self.mesh_dir(meta["id"]) / "meta.json", meta)

    def mesh_meta(self, mesh_id: str) -> dict[str, Any] | None:
        """The stored meta of a mesh, or None."""
        if not valid_id(mesh_id):
            return None
        p = self.mesh_dir(mesh_id) / "meta.json"
        try:
            return json.loads(p.read_text())
        except (OSError, ValueError):
            return None

    def list_meshes(self) -> list[dict[str, Any]]:
        """Every stored mesh's meta, oldest first."""
        out = [m for d in self.meshes_dir.iterdir() if d.is_dir()
               if (m := self.mesh_meta(d.name)) is not None]
        return sorted(out, key=lambda m: m.get("created", 0))

    def delete_mesh(self, mesh_id: str) -> None:
        """Remove a mesh, its files and its workspace."""
        if valid_id(mesh_id):
            shutil.rmtree(self.mesh_dir(mesh_id), ignore_errors=True)
            (self.meshes_dir / f"{mesh_id}.workspace.json").unlink(missing_ok=True)

    def save_arrays(self, mesh_id: str, mesh: Mesh) -> None:
        """Store a mesh given as arrays (vertices, tetrahedra, named sets)."""
        sets: dict[str, Any] = {f"set:{k}": v for k, v in mesh.sets.items()}
        np.savez(self.mesh_dir(mesh_id) / "arrays.npz", V=mesh.V, T=mesh.T, surface=mesh.surface,
                 **sets)

    def load_mesh(self, meta: dict[str, Any]) -> Mesh:
        """Read a stored mesh back (validated); see :func:`read_mesh_files`."""
        return read_mesh_files(self.root, meta, self.bounds)

    # --------------------------------------------------------------- sessions
    def save_session(self, record: dict[str, Any]) -> None:
        """Write (or replace) a session record (its presets are not written: see :meth:`save_presets`)."""
        _write_json(self.sessions_dir / f"{record['id']}.json", record_only(record))

    def create_session(self, record: dict[str, Any], limit: int) -> None:
        """Write a new session record (the registry has checked the limit: one process)."""
        self.save_session(record)

    def update_session(self, record: dict[str, Any], version: int) -> bool:
        """Write ``record`` if its session has a record at ``version`` (this process is the only writer)."""
        rec = self.load_session(str(record.get("id", "")))
        if rec is None or int(rec.get("version", 0)) != version:
            return False
        self.save_session({**record, "version": version})
        return True

    def commit_session(self, record: dict[str, Any], version: int) -> int | None:
        """Write ``record`` with ``version + 1`` (this process is the only writer); None when it was deleted.

        A session deleted while a MOVE of it was solved (over a stream, say) stays deleted:
        its record is never written back.
        """
        if not self._has_record(str(record.get("id", ""))):
            return None
        new = version + 1
        self.save_session({**record, "version": new})
        return new

    def load_session(self, session_id: str) -> dict[str, Any] | None:
        """One session record with its presets, or None."""
        if not valid_id(session_id):
            return None
        try:
            rec = json.loads((self.sessions_dir / f"{session_id}.json").read_text())
        except (OSError, ValueError):
            return None
        return {**rec, "presets": self._presets(session_id)}

    def _has_record(self, session_id: str) -> bool:
        return valid_id(session_id) and (self.sessions_dir / f"{session_id}.json").is_file()

    def _presets(self, session_id: str) -> list[dict[str, Any]]:
        try:
            doc = json.loads((self.presets_dir / f"{session_id}.json").read_text())
        except (OSError, ValueError):  # none saved (records written before presets existed included)
            return []
        return doc if isinstance(doc, list) else []

    def save_presets(self, session_id: str, presets: list[dict[str, Any]]) -> bool:
        """Replace a session's presets file (atomically); False when the session has no record."""
        if not self._has_record(session_id):
            return False
        self.presets_dir.mkdir(exist_ok=True)
        _write_json(self.presets_dir / f"{session_id}.json", presets)
        return True

    def load_presets(self, session_id: str) -> list[dict[str, Any]] | None:
        """A session's presets, or None when it has no record."""
        if not self._has_record(session_id):
            return None
        return self._presets(session_id)

    def save_history(self, session_id: str, history: dict[str, Any]) -> bool:
        """Replace a session's history file (atomically); False when the session has no record."""
        if not self._has_record(session_id):
            return False
        self.history_dir.mkdir(exist_ok=True)
        _write_json(self.history_dir / f"{session_id}.json", history)
        return True

    def load_history(self, session_id: str) -> dict[str, Any] | None:
        """A session's history, or None when it has no record."""
        if not self._has_record(session_id):
            return None
        try:
            doc = json.loads((self.history_dir / f"{session_id}.json").read_text())
        except (OSError, ValueError):  # none saved
            return dict(EMPTY_HISTORY)
        return doc if isinstance(doc, dict) else dict(EMPTY_HISTORY)

    def touch_session(self, session_id: str, now: float) -> int | None:
        """Nothing to record (uses are kept in memory); the stored version."""
        rec = self.load_session(session_id)
        return None if rec is None else int(rec.get("version", 0))

    def count_sessions(self, owner: str) -> int:
        """Sessions of one owner."""
        return sum(1 for r in self.list_sessions() if r.get("owner") == owner)

    def expire_idle(self, before: float) -> list[tuple[str, str]]:
        """Remove the records last used before ``before`` (the registry sweeps its memory itself)."""
        out = []
        for rec in self.list_sessions():
            if rec.get("last_used", time.time()) < before:
                self.delete_session(rec["id"])
                self.save_expired(rec["id"], rec["owner"], time.time())
                out.append((rec["id"], rec["owner"]))
        return out

    def expired(self, session_id: str) -> tuple[str, float] | None:
        """``(owner, expired_at)`` of an expired session, or None."""
        if not valid_id(session_id):
            return None
        try:
            doc = json.loads((self.sessions_dir / "expired" / f"{session_id}.json").read_text())
        except (OSError, ValueError):
            return None
        return doc["owner"], float(doc["expired_at"])

    def writable(self) -> bool:
        """True when a byte can be written in the sessions folder and the disk has its reserve free.

        The reserve (``min_free_bytes``) makes readiness fail before writes do, so that a load
        balancer sends the writes elsewhere while the records still fit.
        """
        try:
            if self.min_free_bytes and free_bytes(self.root) < self.min_free_bytes:
                return False
            fd, path = tempfile.mkstemp(dir=self.sessions_dir, prefix=".tmp-ready-")
            try:
                os.write(fd, b"\0")  # a file system that is full still creates empty files
            finally:
                os.close(fd)
                os.unlink(path)
            return True
        except OSError:
            return False

    def rate_limiter(self, rate: float, burst: int) -> Limiter:
        """Token buckets in this process's memory (one process serves the data directory)."""
        return RateLimiter(rate, burst)

    def close(self) -> None:
        """Nothing to release."""

    def sessions_of_mesh(self, mesh_id: str) -> list[str]:
        """Ids of the sessions on a mesh or with it as a target surface."""
        return sorted(r["id"] for r in self.list_sessions() if r.get("mesh_id") == mesh_id
                      or any(m == mesh_id for _, m in _surfaces(r.get("spec") or {})))

    def existing(self, ids: list[str]) -> set[str]:
        """Which of ``ids`` still have records."""
        return {i for i in ids if valid_id(i) and (self.sessions_dir / f"{i}.json").is_file()}

    def forget_expired(self, before: float) -> int:
        """Forget the sessions that expired before ``before``."""
        old = [r["id"] for r in self.list_expired() if r.get("expired_at", 0.0) < before]
        for sid in old:
            self.delete_expired(sid)
        return len(old)

    def list_sessions(self) -> list[dict[str, Any]]:
        """Every stored session record, with its presets."""
        out = []
        for p in self.sessions_dir.glob("*.json"):
            try:
                rec = json.loads(p.read_text())
            except (OSError, ValueError):
                continue
            out.append({**rec, "presets": self._presets(p.stem)})
        return out

    def delete_session(self, session_id: str) -> None:
        """Remove a session record, then its presets, history and workspace."""
        if valid_id(session_id):
            (self.sessions_dir / f"{session_id}.json").unlink(missing_ok=True)
            for d in (self.presets_dir, self.history_dir, self.workspace_dir):
                (d / f"{session_id}.json").unlink(missing_ok=True)

    # ------------------------------------------------------------- tombstones
    def save_expired(self, session_id: str, owner: str, at: float) -> None:
        """Remember that a session was removed for idleness (it answers 410 for a while)."""
        d = self.sessions_dir / "expired"
        d.mkdir(exist_ok=True)
        _write_json(d / f"{session_id}.json", {"id": session_id, "owner": owner, "expired_at": at})

    def list_expired(self) -> list[dict[str, Any]]:
        """Every remembered expired session."""
        d = self.sessions_dir / "expired"
        out = []
        for p in d.glob("*.json") if d.is_dir() else []:
            try:
                out.append(json.loads(p.read_text()))
            except (OSError, ValueError):
                continue
        return out

    def delete_expired(self, session_id: str) -> None:
        """Forget an expired session."""
        if valid_id(session_id):
            (self.sessions_dir / "expired" / f"{session_id}.json").unlink(missing_ok=True)

    # ------------------------------------------------------------ maintenance
    def remove_orphans(self) -> list[str]:
        """Remove what an interrupted upload or write left behind; return the names removed.

        A mesh directory without ``meta.json`` (the process died between the
        upload and its summary), presets of sessions without a record (the
        process died while deleting one) and temporary files of atomic writes.
        """
        return _remove_orphans(self.meshes_dir, self.sessions_dir, self.presets_dir, self.workspace_dir)

    def rename_owner(self, old: str, new: str) -> int:
        """Give every mesh and session of owner ``old`` to ``new``; return how many records changed."""
        n = 0
        for meta in self.list_meshes():
            if meta.get("owner") == old:
                self.save_mesh_meta({**meta, "owner": new})
                n += 1
        for rec in self.list_sessions():
            if rec.get("owner") == old:
                self.save_session({**rec, "owner": new})
                n += 1
        return n


def _remove_orphans(meshes_dir: Path, sessions_dir: Path, presets_dir: Path, workspace_dir: Path) -> list[str]:
    """:meth:`FileStore.remove_orphans` of a data directory's folders."""
    gone = []
    for d in meshes_dir.iterdir():
        if d.is_dir() and not (d / "meta.json").is_file():
            shutil.rmtree(d, ignore_errors=True)
            gone.append(d.name)
    for p in meshes_dir.glob("*.workspace.json"):
        if not (meshes_dir / p.name.removesuffix(".workspace.json") / "meta.json").is_file():
            p.unlink(missing_ok=True)
            gone.append(p.name)
    for folder in (presets_dir, workspace_dir):
        for p in folder.glob("*.json") if folder.is_dir() else []:
            if not (sessions_dir / p.name).is_file():
                p.unlink(missing_ok=True)
                gone.append(f"{folder.name}/{p.name}")
    for folder in (meshes_dir, sessions_dir):
        for p in folder.rglob(".tmp-*"):
            p.unlink(missing_ok=True)
            gone.append(p.name)
    return gone
