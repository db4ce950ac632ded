"""The workspaces of a data directory's meshes and sessions (:class:`~service.state.store.FileStore`'s).

A session's workspace is ``sessions/workspace/<id>.json``, deleted with the session; a mesh's is
``meshes/<mesh_id>.workspace.json``, beside the mesh's folder (whose files are the upload's
only), deleted with the mesh. Each is replaced atomically, like every record.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Literal

from .files import valid_id, write_json

__all__ = ["EMPTY_WORKSPACE", "WorkspaceOf", "FileWorkspaces"]

#: The workspace of a mesh or session none was saved for (service/models/workspace.py).
EMPTY_WORKSPACE: dict[str, Any] = {"regions": None, "labels": [], "doe_plan": "", "shape_values": {},
                                   "session": None}

#: Whose workspace: a mesh's or a session's.
WorkspaceOf = Literal["mesh", "session"]


class FileWorkspaces:
    """The workspace files of :class:`~service.state.store.FileStore` (its folders and records)."""

    meshes_dir: Path
    workspace_dir: Path

    def _has_record(self, session_id: str) -> bool:
        raise NotImplementedError

    def mesh_dir(self, mesh_id: str) -> Path:
        """Directory of one mesh (the store's)."""
        raise NotImplementedError

    def _workspace_path(self, of: WorkspaceOf, ident: str) -> Path | None:
        """Where a workspace is kept, when its mesh or session exists."""
        if of == "session":
            return self.workspace_dir / f"{ident}.json" if self._has_record(ident) else None
        if valid_id(ident) and (self.mesh_dir(ident) / "meta.json").is_file():
            return self.meshes_dir / f"{ident}.workspace.json"
        return None

    def save_workspace(self, of: WorkspaceOf, ident: str, doc: dict[str, Any]) -> bool:
        """Replace a workspace file (atomically); False when its mesh or session has no record."""
        p = self._workspace_path(of, ident)
        if p is None:
            return False
        p.parent.mkdir(exist_ok=True)
        write_json(p, doc)
        return True

    def load_workspace(self, of: WorkspaceOf, ident: str) -> dict[str, Any] | None:
        """A workspace (the empty one when none was saved), or None when its mesh or session has no record."""
        p = self._workspace_path(of, ident)
        if p is None:
            return None
        try:
            doc = json.loads(p.read_text())
        except (OSError, ValueError):  # none saved
            return dict(EMPTY_WORKSPACE)
        return {**EMPTY_WORKSPACE, **doc} if isinstance(doc, dict) else dict(EMPTY_WORKSPACE)

