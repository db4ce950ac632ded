"""Shared route dependencies: the registry and the caller's identity."""

from __future__ import annotations

from fastapi import Depends, Request, Security
from fastapi.security import APIKeyHeader

from ..registry import Registry

__all__ = ["owner", "registry", "safe_name"]

_key_header = APIKeyHeader(name="X-API-Key", auto_error=False,
                           description="Required when the service is configured with API keys.")


def registry(request: Request) -> Registry:
    """The app's :class:`~service.registry.Registry`."""
    return request.app.state.registry


def owner(request: Request, _key: str | None = Security(_key_header)) -> str:
    """Authenticate the request and charge it to its key's rate limit; return the owner id."""
    state = request.app.state
    who = state.auth.owner(request.headers, request.query_params)
    state.limiter.check(who)
    return who


Owner = Depends(owner)
Reg = Depends(registry)


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
