"""Mesh and session records in PostgreSQL, shared by every replica (``TETMORPH_DATABASE_URL``).

Tables (created at start-up, under an advisory lock so that replicas starting
together do not race)::

    tm_meshes    id, owner, created, meta, workspace          the mesh metas (and the mesh's workspace)
    tm_sessions  id, owner, mesh_id, created, last_used, version, record, presets, history, workspace
    tm_expired   id, owner, expired_at              sessions removed for idleness (410 for a while)
    tm_rate      owner, tokens, at, granted         one token bucket per owner

Mesh *files* stay in the data directory (``meshes/<id>/``), which every
replica mounts (a shared volume): a mesh is written once, parsed once per
replica and then held in memory, and a path is what the mesh readers take.
The database holds what is small and changes: metas, session records with
their versions, expiry, rate buckets. A session's presets, its undo
history and its workspace are columns of their own: a MOVE's commit (the versioned ``record``)
never writes them and their writes never touch the record or its version, so
neither undoes the other and they never make a MOVE conflict.

Every statement runs on the event loop's thread (one connection, autocommit);
on a local network each is well under a millisecond. A lost connection is
opened again once per call (:class:`~service.state.pg_connection.PgConnection`).
"""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from solver.io.bounds import ReadBounds
from solver.mesh import Mesh

from ..errors import ServiceError
from ..security import Limiter, SharedRateLimiter
from .pg_connection import PgConnection, jsonb
from .store import EMPTY_HISTORY, EMPTY_WORKSPACE, FileStore, WorkspaceOf, read_mesh_files, record_only, valid_id

__all__ = ["PgStore", "SCHEMA", "ORPHAN_AGE_S"]

#: A mesh folder without a record is removed only when older than this (another replica may be writing it).
ORPHAN_AGE_S = 3600.0
#: Advisory lock key serializing the schema creation.
_SCHEMA_LOCK = 74_190_301

SCHEMA = """
CREATE TABLE IF NOT EXISTS tm_meshes (
    id text PRIMARY KEY, owner text NOT NULL, created double precision NOT NULL, meta jsonb NOT NULL,
    workspace jsonb);
CREATE TABLE IF NOT EXISTS tm_sessions (
    id text PRIMARY KEY, owner text NOT NULL, mesh_id text NOT NULL, created double precision NOT NULL,
    last_used double precision NOT NULL, version bigint NOT NULL DEFAULT 0, record jsonb NOT NULL,
    presets jsonb NOT NULL DEFAULT '[]'::jsonb, history jsonb, workspace jsonb);
DO $$ BEGIN  -- tables made before presets (the history, workspaces) existed: their sessions have none
    IF NOT EXISTS (SELECT 1 FROM information_schema.columns WHERE table_schema = current_schema()
                   AND table_name = 'tm_sessions' AND column_name = 'presets') THEN
        ALTER TABLE tm_sessions ADD COLUMN presets jsonb NOT NULL DEFAULT '[]'::jsonb;
    END IF;
    IF NOT EXISTS (SELECT 1 FROM information_schema.columns WHERE table_schema = current_schema()
                   AND table_name = 'tm_sessions' AND column_name = 'history') THEN
        ALTER TABLE tm_sessions ADD COLUMN history jsonb;
    END IF;
    IF NOT EXISTS (SELECT 1 FROM information_schema.columns WHERE table_schema = current_schema()
                   AND table_name = 'tm_sessions' AND column_name = 'workspace') THEN
        ALTER TABLE tm_sessions ADD COLUMN workspace jsonb;
    END IF;
    IF NOT EXISTS (SELECT 1 FROM information_schema.columns WHERE table_schema = current_schema()
                   AND table_name = 'tm_meshes' AND column_name = 'workspace') THEN
        ALTER TABLE tm_meshes ADD COLUMN workspace jsonb;
    END IF;
END $$;
CREATE INDEX IF NOT EXISTS tm_sessions_owner ON tm_sessions (owner);
CREATE INDEX IF NOT EXISTS tm_sessions_mesh ON tm_sessions (mesh_id);
CREATE INDEX IF NOT EXISTS tm_sessions_last_used ON tm_sessions (last_used);
CREATE TABLE IF NOT EXISTS tm_expired (
    id text PRIMARY KEY, owner text NOT NULL, expired_at double precision NOT NULL);
CREATE TABLE IF NOT EXISTS tm_rate (
    owner text PRIMARY KEY, tokens double precision NOT NULL, at double precision NOT NULL,
    granted boolean NOT NULL);
"""

_TAKE = """
INSERT INTO tm_rate AS r (owner, tokens, at, granted)
VALUES (%(owner)s, %(burst)s - 1, extract(epoch FROM clock_timestamp()), true)
ON CONFLICT (owner) DO UPDATE SET
    tokens = CASE WHEN LEAST(%(burst)s, r.tokens + GREATEST(EXCLUDED.at - r.at, 0) * %(rate)s) >= 1
                  THEN LEAST(%(burst)s, r.tokens + GREATEST(EXCLUDED.at - r.at, 0) * %(rate)s) - 1
                  ELSE LEAST(%(burst)s, r.tokens + GREATEST(EXCLUDED.at - r.at, 0) * %(rate)s) END,
    granted = LEAST(%(burst)s, r.tokens + GREATEST(EXCLUDED.at - r.at, 0) * %(rate)s) >= 1,
    at = EXCLUDED.at
RETURNING tokens, granted
"""


class PgStore:
    """The :class:`~service.state.store.Store` of replicas: records in PostgreSQL, mesh files in ``root``.

    Parameters
    ----------
    url : str
        ``postgresql://user@host:port/db``.
    root : path
        The shared data directory (mesh files).
    bounds : ReadBounds, optional
        What an uploaded file may declare or expand to.
    min_free_bytes : int
        The free space the data directory keeps in reserve (see :meth:`writable`).
    """

    shared = True

    def __init__(self, url: str, root: str | os.PathLike[str], bounds: ReadBounds | None = None,
                 min_free_bytes: int = 0) -> None:
        self.url = url
        self.root = Path(root)
        self.files = FileStore(root, bounds, min_free_bytes)  # mesh folders (and the data directory's layout)
        self.bounds = self.files.bounds
        self.sessions_dir = self.files.sessions_dir
        self._db = PgConnection(url)

        def create(c: Any) -> None:
            c.execute("SELECT pg_advisory_lock(%s)", (_SCHEMA_LOCK,))
            try:
                c.execute(SCHEMA)
            finally:
                c.execute("SELECT pg_advisory_unlock(%s)", (_SCHEMA_LOCK,))

        self._db.run(create)

    def close(self) -> None:
        """Close the connection."""
        self._db.close()

    def writable(self) -> bool:
        """True when the database answers and the data directory takes files (its reserve free)."""
        return self._db.answers() and self.files.writable()

    # ----------------------------------------------------------------- meshes
    def mesh_dir(self, mesh_id: str) -> Path:
        """Directory of one mesh's files (on the shared volume)."""
        return self.files.mesh_dir(mesh_id)

    def new_mesh_dir(self, mesh_id: str) -> Path:
        """Create and return the directory for a new mesh."""
        return self.files.new_mesh_dir(mesh_id)

    def save_mesh_meta(self, meta: dict[str, Any]) -> None:
        """Insert or replace a mesh's meta (after its files are written)."""
        self._db.exec("INSERT INTO tm_meshes (id, owner, created, meta) VALUES (%s, %s, %s, %s) "
                      "ON CONFLICT (id) DO UPDATE SET owner = EXCLUDED.owner, meta = EXCLUDED.meta",
                      (meta["id"], meta["owner"], float(meta.get("created", time.time())), jsonb(meta)))

    def mesh_meta(self, mesh_id: str) -> dict[str, Any] | None:
        """The meta of a mesh, or None."""
        if not valid_id(mesh_id):
            return None
        rows = self._db.rows("SELECT meta FROM tm_meshes WHERE id = %s", (mesh_id,))
        return rows[0][0] if rows else None

    def list_meshes(self) -> list[dict[str, Any]]:
        """Every mesh's meta, oldest first."""
        return [r[0] for r in self._db.rows("SELECT meta FROM tm_meshes ORDER BY created, id")]

    def delete_mesh(self, mesh_id: str) -> None:
        """Remove a mesh's record, then its files."""
        self._db.exec("DELETE FROM tm_meshes WHERE id = %s", (mesh_id,))
        self.files.delete_mesh(mesh_id)

    def save_arrays(self, mesh_id: str, mesh: Mesh) -> None:
        """Store a mesh given as arrays (in its folder)."""
        self.files.save_arrays(mesh_id, mesh)

    def load_mesh(self, meta: dict[str, Any]) -> Mesh:
        """Read a stored mesh back from its folder."""
        return read_mesh_files(self.root, meta, self.files.bounds)

    # --------------------------------------------------------------- sessions
    def _row(self, record: dict[str, Any]) -> tuple[Any, ...]:
        return (record["id"], record["owner"], record["mesh_id"], float(record["created"]),
                float(record.get("last_used", time.time())), int(record.get("version", 0)),
                jsonb(record_only(record)))

    def create_session(self, record: dict[str, Any], limit: int) -> None:
        """Insert a new record, counting the owner's sessions under a lock of that owner.

        Raises
        ------
        ServiceError
            429 ``session_limit``; 409 ``session_exists``.
        """
        owner = record["owner"]

        def insert(c: Any) -> None:
            with c.transaction():
                c.execute("SELECT pg_advisory_xact_lock(hashtext(%s))", (owner,))
                n = c.execute("SELECT count(*) FROM tm_sessions WHERE owner = %s", (owner,)).fetchone()[0]
                if n >= limit:
                    raise ServiceError("session_limit", f"this key already has {n} sessions (limit {limit}); "
                                       "delete one first", sessions=int(n), limit=limit)
                done = c.execute("INSERT INTO tm_sessions (id, owner, mesh_id, created, last_used, version, record) "
                                 "VALUES (%s, %s, %s, %s, %s, %s, %s) ON CONFLICT (id) DO NOTHING RETURNING id",
                                 self._row(record)).fetchall()
                if not done:
                    raise ServiceError("session_exists", f"session {record['id']} exists", session_id=record["id"])

        self._db.run(insert)

    def update_session(self, record: dict[str, Any], version: int) -> bool:
        """Write ``record`` over the stored one, in one statement, if it exists at ``version``; never insert."""
        return self._db.exec("UPDATE tm_sessions SET record = %s, last_used = GREATEST(last_used, %s) "
                             "WHERE id = %s AND version = %s",
                             (jsonb(record_only(record)), float(record.get("last_used", time.time())),
                              record["id"], int(version))) > 0

    def commit_session(self, record: dict[str, Any], version: int) -> int | None:
        """Write ``record`` only if the stored version is still ``version``; the new version, else None."""
        rows = self._db.rows("UPDATE tm_sessions SET record = %s, version = version + 1, "
                             "last_used = GREATEST(last_used, %s) WHERE id = %s AND version = %s RETURNING version",
                             (jsonb(record_only(record)), float(record.get("last_used", time.time())), record["id"],
                              int(version)))
        return int(rows[0][0]) if rows else None

    def load_session(self, session_id: str) -> dict[str, Any] | None:
        """One record (with its current version, last use and presets), or None."""
        if not valid_id(session_id):
            return None
        rows = self._db.rows("SELECT record, version, last_used, presets FROM tm_sessions WHERE id = %s",
                             (session_id,))
        if not rows:
            return None
        rec, version, last_used, presets = rows[0]
        return {**rec, "version": int(version), "last_used": float(last_used), "presets": presets}

    def save_presets(self, session_id: str, presets: list[dict[str, Any]]) -> bool:
        """Replace a session's presets (record, version and last use untouched); False when it is gone."""
        if not valid_id(session_id):
            return False
        return self._db.exec("UPDATE tm_sessions SET presets = %s WHERE id = %s", (jsonb(presets), session_id)) > 0

    def save_history(self, session_id: str, history: dict[str, Any]) -> bool:
        """Replace a session's undo history (record, version and last use untouched); False when it is gone."""
        if not valid_id(session_id):
            return False
        return self._db.exec("UPDATE tm_sessions SET history = %s WHERE id = %s", (jsonb(history), session_id)) > 0

    def load_history(self, session_id: str) -> dict[str, Any] | None:
        """A session's undo history, or None when it is gone."""
        if not valid_id(session_id):
            return None
        rows = self._db.rows("SELECT history FROM tm_sessions WHERE id = %s", (session_id,))
        if not rows:
            return None
        return rows[0][0] if isinstance(rows[0][0], dict) else dict(EMPTY_HISTORY)

    def save_workspace(self, of: WorkspaceOf, ident: str, doc: dict[str, Any]) -> bool:
        """Replace a mesh's or session's workspace column (nothing else touched); False when it is gone."""
        if not valid_id(ident):
            return False
        table = "tm_sessions" if of == "session" else "tm_meshes"
        return self._db.exec(f"UPDATE {table} SET workspace = %s WHERE id = %s", (jsonb(doc), ident)) > 0

    def load_workspace(self, of: WorkspaceOf, ident: str) -> dict[str, Any] | None:
        """A mesh's or session's workspace (empty when none was saved), or None when it is gone."""
        if not valid_id(ident):
            return None
        table = "tm_sessions" if of == "session" else "tm_meshes"
        rows = self._db.rows(f"SELECT workspace FROM {table} WHERE id = %s", (ident,))
        if not rows:
            return None
        doc = rows[0][0]
        return {**EMPTY_WORKSPACE, **doc} if isinstance(doc, dict) else dict(EMPTY_WORKSPACE)

    def load_presets(self, session_id: str) -> list[dict[str, Any]] | None:
        """A session's presets, or None when it is gone."""
        if not valid_id(session_id):
            return None
        rows = self._db.rows("SELECT presets FROM tm_sessions WHERE id = %s", (session_id,))
        return list(rows[0][0]) if rows else None

    def touch_session(self, session_id: str, now: float) -> int | None:
        """Record a use (``last_used``); the stored version, or None when the session is gone."""
        if not valid_id(session_id):
            return None
        rows = self._db.rows("UPDATE tm_sessions SET last_used = GREATEST(last_used, %s) WHERE id = %s "
                             "RETURNING version", (float(now), session_id))
        return int(rows[0][0]) if rows else None

    def list_sessions(self) -> list[dict[str, Any]]:
        """Every record, with its version and presets."""
        return [{**rec, "version": int(v), "last_used": float(lu), "presets": p} for rec, v, lu, p in
                self._db.rows("SELECT record, version, last_used, presets FROM tm_sessions ORDER BY created, id")]

    def count_sessions(self, owner: str) -> int:
        """Sessions of one owner."""
        return int(self._db.rows("SELECT count(*) FROM tm_sessions WHERE owner = %s", (owner,))[0][0])

    def sessions_of_mesh(self, mesh_id: str) -> list[str]:
        """Ids of the sessions on a mesh or with it as a target surface."""
        target = jsonb([{"surface": {"mesh_id": mesh_id}}])
        return [r[0] for r in self._db.rows("SELECT id FROM tm_sessions WHERE mesh_id = %s OR "
                                            "record -> 'spec' -> 'targets' @> %s ORDER BY id", (mesh_id, target))]

    def existing(self, ids: list[str]) -> set[str]:
        """Which of ``ids`` still have records."""
        if not ids:
            return set()
        return {r[0] for r in self._db.rows("SELECT id FROM tm_sessions WHERE id = ANY(%s)", (ids,))}

    def delete_session(self, session_id: str) -> None:
        """Remove a record."""
        self._db.exec("DELETE FROM tm_sessions WHERE id = %s", (session_id,))

    def expire_idle(self, before: float) -> list[tuple[str, str]]:
        """Move sessions last used before ``before`` to ``tm_expired`` in one statement (replicas sweep at once)."""
        rows = self._db.rows("WITH gone AS (DELETE FROM tm_sessions WHERE last_used < %s RETURNING id, owner) "
                             "INSERT INTO tm_expired (id, owner, expired_at) SELECT id, owner, %s FROM gone "
                             "ON CONFLICT (id) DO UPDATE SET expired_at = EXCLUDED.expired_at RETURNING id, owner",
                             (float(before), time.time()))
        return [(r[0], r[1]) for r in rows]

    # ------------------------------------------------------------- tombstones
    def save_expired(self, session_id: str, owner: str, at: float) -> None:
        """Remember an expired session."""
        self._db.exec("INSERT INTO tm_expired (id, owner, expired_at) VALUES (%s, %s, %s) ON CONFLICT (id) "
                      "DO UPDATE SET expired_at = EXCLUDED.expired_at", (session_id, owner, float(at)))

    def expired(self, session_id: str) -> tuple[str, float] | None:
        """``(owner, expired_at)``, or None."""
        if not valid_id(session_id):
            return None
        rows = self._db.rows("SELECT owner, expired_at FROM tm_expired WHERE id = %s", (session_id,))
        return (rows[0][0], float(rows[0][1])) if rows else None

    def list_expired(self) -> list[dict[str, Any]]:
        """Every remembered expired session."""
        return [{"id": i, "owner": o, "expired_at": float(a)} for i, o, a in
                self._db.rows("SELECT id, owner, expired_at FROM tm_expired")]

    def delete_expired(self, session_id: str) -> None:
        """Forget an expired session."""
        self._db.exec("DELETE FROM tm_expired WHERE id = %s", (session_id,))

    def forget_expired(self, before: float) -> int:
        """Forget the sessions that expired before ``before``."""
        return self._db.exec("DELETE FROM tm_expired WHERE expired_at < %s", (float(before),))

    # ------------------------------------------------------------ rate limits
    def rate_limiter(self, rate: float, burst: int) -> Limiter:
        """Token buckets in the database, so that every replica charges the same bucket of a key."""
        return SharedRateLimiter(self.take_token, rate, burst)

    def take_token(self, owner: str, rate: float, burst: int) -> tuple[bool, float]:
        """Take one token of ``owner``'s bucket (database clock): ``(granted, tokens left)``."""
        rows = self._db.rows(_TAKE, {"owner": owner, "rate": float(rate), "burst": float(burst)})
        tokens, granted = rows[0]
        return bool(granted), float(tokens)

    # ------------------------------------------------------------ maintenance
    def _mesh_ids(self) -> set[str]:
        return {r[0] for r in self._db.rows("SELECT id FROM tm_meshes")}

    def remove_orphans(self) -> list[str]:
        """Remove mesh folders without a record that are older than :data:`ORPHAN_AGE_S`, and temporary files."""
        known = self._mesh_ids()
        gone = []
        now = time.time()
        for d in self._folders():
            if d.name not in known and now - d.stat().st_mtime > ORPHAN_AGE_S:
                shutil.rmtree(d, ignore_errors=True)
                gone.append(d.name)
        return gone

    def _folders(self) -> Iterator[Path]:
        for d in self.files.meshes_dir.iterdir():
            if d.is_dir():
                yield d

    def rename_owner(self, old: str, new: str) -> int:
        """Give every record of owner ``old`` to ``new``."""
        n = self._db.exec("UPDATE tm_meshes SET owner = %s, meta = jsonb_set(meta, '{owner}', to_jsonb(%s::text)) "
                          "WHERE owner = %s", (new, new, old))
        n += self._db.exec("UPDATE tm_sessions SET owner = %s, record = jsonb_set(record, '{owner}', "
                           "to_jsonb(%s::text)) WHERE owner = %s", (new, new, old))
        return n
