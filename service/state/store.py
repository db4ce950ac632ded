"""Persistence of meshes and sessions in a local data directory.

Layout (``data_dir``)::

    secret.key                       the installation secret of owner ids (mode 0600)
    meshes/<mesh_id>/meta.json       owner, name, format, main file, summary
    meshes/<mesh_id>/<files>         the uploaded file(s), byte for byte, or arrays.npz
    sessions/<session_id>.json       owner, mesh id, SPEC, last MOVE, timestamps
    sessions/expired/<id>.json       sessions removed for idleness (they answer 410 for a while)

JSON files are replaced atomically, so a crash never leaves a half-written
record; a restart reloads every session and rebuilds it on first use.
"""

from __future__ import annotations

import json
import os
import re
import secrets
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from solver.errors import InvalidMeshError
from solver.io import read_mesh
from solver.mesh import Mesh, mesh_from_arrays

__all__ = ["Store", "new_id", "valid_id"]

_ID = re.compile(r"^[A-Za-z0-9_-]{1,64}$")


def new_id(prefix: str) -> str:
    """Random resource id such as ``m_3f9c0a1b2d4e6f70``."""
    return f"{prefix}_{secrets.token_hex(8)}"


def valid_id(ident: str) -> bool:
    """True if ``ident`` can name a file in the data directory (no path tricks)."""
    return bool(_ID.match(ident))


def _write_json(path: Path, doc: dict[str, Any]) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".json")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(doc, f)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


class Store:
    """Meshes and session records on disk.

    Parameters
    ----------
    root : path
        The data directory; created if missing.
    """

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root)
        self.meshes_dir = self.root / "meshes"
        self.sessions_dir = self.root / "sessions"
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
        """Remove a mesh and its files."""
        if valid_id(mesh_id):
            shutil.rmtree(self.mesh_dir(mesh_id), ignore_errors=True)

    def save_arrays(self, mesh_id: str, mesh: Mesh) -> None:
        """Store a mesh given as arrays (vertices, tetrahedra, named sets)."""
        sets: dict[str, Any] = {f"set:{k}": v for k, v in mesh.sets.items()}
        np.savez(self.mesh_dir(mesh_id) / "arrays.npz", V=mesh.V, T=mesh.T, surface=mesh.surface,
                 **sets)

    def load_mesh(self, meta: dict[str, Any]) -> Mesh:
        """Read a stored mesh back (validated).

        Raises
        ------
        InvalidMeshError
            The stored file no longer reads (e.g. deleted by hand).
        """
        d = self.mesh_dir(meta["id"])
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
        return read_mesh(d / meta["file"], meta.get("format"))

    # --------------------------------------------------------------- sessions
    def save_session(self, record: dict[str, Any]) -> None:
        """Write (or replace) a session record."""
        _write_json(self.sessions_dir / f"{record['id']}.json", record)

    def list_sessions(self) -> list[dict[str, Any]]:
        """Every stored session record."""
        out = []
        for p in self.sessions_dir.glob("*.json"):
            try:
                out.append(json.loads(p.read_text()))
            except (OSError, ValueError):
                continue
        return out

    def delete_session(self, session_id: str) -> None:
        """Remove a session record."""
        if valid_id(session_id):
            (self.sessions_dir / f"{session_id}.json").unlink(missing_ok=True)

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
        upload and its summary) and temporary files of atomic writes.
        """
        gone = []
        for d in self.meshes_dir.iterdir():
            if d.is_dir() and not (d / "meta.json").is_file():
                shutil.rmtree(d, ignore_errors=True)
                gone.append(d.name)
        for folder in (self.meshes_dir, self.sessions_dir):
            for p in folder.rglob(".tmp-*"):
                p.unlink(missing_ok=True)
                gone.append(p.name)
        return gone

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
