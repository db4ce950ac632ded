"""What a client keeps apart from the morph state: a session's presets and undo history, and workspaces.

Both are stored apart from the session's versioned record, so saving them
neither bumps the version nor makes a concurrent MOVE conflict, and a MOVE's
commit never writes them. The session's lock is not taken: a MOVE being
solved meanwhile commits as usual. With a shared store the answers that show
presets read them from the store first (another replica may have replaced
them); the history and the workspaces (a session's or a mesh's) are always read from the store.
"""

from __future__ import annotations

from typing import Any

from ..errors import NotFound
from .session import Session
from .sessions import Sessions
from .store import WorkspaceOf

__all__ = ["set_presets", "refresh_presets", "save_history", "load_history", "save_workspace", "load_workspace"]


def _gone(sessions: Sessions, s: Session) -> NotFound:
    """The session's record is gone (another replica deleted it): forget the local copy."""
    if sessions.store.shared:
        sessions.drop_local(s)
    return NotFound("session", s.id)


def set_presets(sessions: Sessions, s: Session, presets: list[dict[str, Any]]) -> None:
    """Replace a session's presets (validated by the route): the store first, then memory.

    Raises
    ------
    NotFound
        The session's record is gone; nothing is stored.
    """
    if not sessions.store.save_presets(s.id, presets):
        raise _gone(sessions, s)
    s.presets = presets


def refresh_presets(sessions: Sessions, s: Session) -> None:
    """With a shared store: read the session's presets (another replica may have replaced them)."""
    if sessions.store.shared:
        presets = sessions.store.load_presets(s.id)
        if presets is not None:
            s.presets = presets


def save_history(sessions: Sessions, s: Session, history: dict[str, Any]) -> None:
    """Replace a session's undo history (validated by the route).

    Raises
    ------
    NotFound
        The session's record is gone; nothing is stored.
    """
    if not sessions.store.save_history(s.id, history):
        raise _gone(sessions, s)


def load_history(sessions: Sessions, s: Session) -> dict[str, Any]:
    """A session's undo history (no MOVEs, at 0, when none was saved).

    Raises
    ------
    NotFound
        The session's record is gone.
    """
    history = sessions.store.load_history(s.id)
    if history is None:
        raise _gone(sessions, s)
    return history


def save_workspace(sessions: Sessions, of: WorkspaceOf, ident: str, doc: dict[str, Any],
                   s: Session | None = None) -> None:
    """Replace a mesh's or session's workspace (validated by the route).

    Raises
    ------
    NotFound
        The mesh or session is gone; nothing is stored.
    """
    if not sessions.store.save_workspace(of, ident, doc):
        raise _gone(sessions, s) if s is not None else NotFound(of, ident)


def load_workspace(sessions: Sessions, of: WorkspaceOf, ident: str, s: Session | None = None) -> dict[str, Any]:
    """A mesh's or session's workspace (the empty one when none was saved).

    Raises
    ------
    NotFound
        The mesh or session is gone.
    """
    doc = sessions.store.load_workspace(of, ident)
    if doc is None:
        raise _gone(sessions, s) if s is not None else NotFound(of, ident)
    return doc
