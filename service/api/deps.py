"""Route dependencies: the registry, the caller's identity, and resources loaded or 404.

Routes declare what they need as ``Annotated`` aliases::

    async def get_session(s: SessionDep, reg: RegistryDep) -> ...

``SessionDep`` and ``MeshDep`` authenticate the caller, charge the request to
its key's rate limit, and load the resource of the path or answer 404 (also
for resources of other keys). Every authenticated use of a session counts as
activity against its idle time.
"""

from __future__ import annotations

import asyncio
import time
from typing import Annotated, Any
from urllib.parse import unquote_plus

from fastapi import Depends, Path, Request, Security
from fastapi.security import APIKeyHeader

from ..errors import ServiceError
from ..settings import Settings
from ..state.registry import Registry
from ..state.session import Session
from ..strict_json import duplicate_key, duplicate_key_error

__all__ = ["OwnerDep", "RegistryDep", "SessionDep", "MeshDep", "SettingsDep", "safe_name", "refuse_nul",
           "refuse_duplicate_keys"]

#: JSON bodies larger than this are checked for repeated keys off the event loop.
_THREAD_BYTES = 1 << 20

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
    s = reg.sessions.lookup(owner, session_id)
    s.last_used = time.time()
    return s


def get_mesh(mesh_id: Annotated[str, Path(max_length=64, description="id from POST /v1/meshes")],
             owner: OwnerDep, reg: RegistryDep) -> dict[str, Any]:
    """The caller's mesh meta of the path, or 404."""
    return reg.catalogue.meta(owner, mesh_id)


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


async def refuse_nul(request: Request) -> None:
    """Refuse a NUL character anywhere a request carries text: query, JSON body, form fields, file names.

    Text a request brings may be stored (names, SPECs, MOVEs), and PostgreSQL cannot store a NUL in
    text: refused here, before any route runs, a single server and a cluster answer the same 422.
    """
    def bad(where: str) -> ServiceError:
        return ServiceError("invalid_request", f"{where} contains a NUL character (\\u0000), which no "
                            "tetmorph text may hold", field=where)

    if "\x00" in unquote_plus(request.url.query):
        raise bad("the query string")
    kind = request.headers.get("content-type", "")
    if kind.startswith("application/json"):
        if b"\\u0000" in await request.body():  # JSON writes a NUL only as this escape
            raise bad("the JSON body")
    elif kind.startswith(("multipart/form-data", "application/x-www-form-urlencoded")):
        try:
            form = await request.form()
        except Exception:  # noqa: BLE001 - a broken form is the route's 400, not this check's
            return
        for key, value in form.multi_items():
            text = value if isinstance(value, str) else (getattr(value, "filename", None) or "")
            if "\x00" in key or "\x00" in text:
                raise bad(f"form field {key.replace(chr(0), '?')!r}")


def _is_json(content_type: str) -> bool:
    """Whether a body of this content type is parsed as JSON (``application/json``, ``application/*+json``)."""
    kind = content_type.split(";", 1)[0].strip().lower()
    return kind == "application/json" or (kind.startswith("application/") and kind.endswith("+json"))


async def refuse_duplicate_keys(request: Request) -> None:
    """Refuse a JSON body with an object that names a key twice: 422 ``duplicate_key`` with the key and its path.

    Every JSON body is checked here, before any route reads it (:mod:`service.strict_json`), whatever its model.
    """
    if not _is_json(request.headers.get("content-type", "")):
        return
    body = await request.body()
    if not body:
        return
    found = await asyncio.to_thread(duplicate_key, body) if len(body) > _THREAD_BYTES else duplicate_key(body)
    if found is not None:
        raise duplicate_key_error(*found)
