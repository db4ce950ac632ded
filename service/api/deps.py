"""Route dependencies: the registry, the caller's identity, and resources loaded or 404.

Routes declare what they need as ``Annotated`` aliases::

    async def get_session(s: SessionDep, reg: RegistryDep) -> ...

``SessionDep`` and ``MeshDep`` authenticate the caller, charge the request to
its key's rate limit, and load the resource of the path or answer 404 (also
for resources of other keys). Every authenticated use of a session counts as
activity against its idle time.
"""

from __future__ import annotations

import time
from typing import Annotated, Any

from fastapi import Depends, Path, Request, Security
from fastapi.security import APIKeyHeader

from ..settings import Settings
from ..state.registry import Registry
from ..state.session import Session

__all__ = ["OwnerDep", "RegistryDep", "SessionDep", "MeshDep", "SettingsDep", "safe_name"]

_key_header = APIKeyHeader(name="X-API-Key", auto_error=False,
                           description="Required when the service is configured with API keys.")


def get_registry(request: Request) -> Registry:
    """The app's :class:`~service.state.registry.Registry`."""
    return request.app.state.registry


def get_settings(request: Request) -> Settings:
    """The app's :class:`~service.settings.Settings`."""
    return request.app.state.settings


def get_owner(request: Request, _key: str | None = Security(_key_header)) -> str:
    """Authenticate the request and charge it to its key's rate limit; return the owner id."""
    state = request.app.state
    who = state.auth.owner(request.headers)
    state.limiter.check(who)
    return who


RegistryDep = Annotated[Registry, Depends(get_registry)]
SettingsDep = Annotated[Settings, Depends(get_settings)]
OwnerDep = Annotated[str, Depends(get_owner)]


def get_session(session_id: Annotated[str, Path(max_length=64, description="id from POST /v1/sessions")],
                owner: OwnerDep, reg: RegistryDep) -> Session:
    """The caller's session of the path (its use counts as activity), or 404."""
    s = reg.session(owner, session_id)
    s.last_used = time.time()
    return s


def get_mesh(mesh_id: Annotated[str, Path(max_length=64, description="id from POST /v1/meshes")],
             owner: OwnerDep, reg: RegistryDep) -> dict[str, Any]:
    """The caller's mesh meta of the path, or 404."""
    return reg.mesh_meta(owner, mesh_id)


SessionDep = Annotated[Session, Depends(get_session)]
MeshDep = Annotated[dict[str, Any], Depends(get_mesh)]


def safe_name(name: str | None, default: str) -> str:
    """A file name without directories or odd characters.

    Examples
    --------
    >>> safe_name("../../etc/pass wd.inp", "x")
    'pass_wd.inp'
    >>> safe_name(None, "mesh")
    'mesh'
    """
    base = (name or "").replace("\\", "/").rsplit("/", 1)[-1]
    clean = "".join(c if c.isalnum() or c in "._-" else "_" for c in base).lstrip(".")
    return clean[:120] or default
