"""API keys, owner ids and request-rate limits.

With no keys configured the service has one tenant, ``"public"``. With keys,
every request must carry one (``X-API-Key`` header or ``Authorization:
Bearer``; the WebSocket upgrade may also use the ``api_key`` query parameter,
which browsers need), and each key sees only its own meshes and sessions.

Keys are never written to disk. Resources record an owner id,
``HMAC-SHA256(secret, tenant)``, where the secret is created once per
installation in the data directory (``secret.key``, mode 0600). A key may be
given a tenant name (``TETMORPH_API_KEYS="acme=K1"``); several keys of one
tenant share its data, which is how a key is rotated: add ``acme=K2``, move the
clients to K2, then remove ``acme=K1``. A bare key is the tenant of its own
name, so bare ``K1`` rotates as ``K1,K1=K2``, then ``K1=K2``.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import os
import secrets
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Protocol

from .errors import ServiceError
from .settings import Settings

__all__ = ["Authenticator", "Limiter", "RateLimiter", "SharedRateLimiter", "ConnectionSlots",
           "PUBLIC", "load_secret", "legacy_owner", "parse_keys", "one_key"]

PUBLIC = "public"
SECRET_FILE = "secret.key"


def load_secret(data_dir: Path) -> bytes:
    """The installation's secret, created on first start (32 random bytes, file mode 0600)."""
    path = Path(data_dir) / SECRET_FILE
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        data = path.read_bytes()
        if len(data) < 32:
            raise RuntimeError(f"{path} holds {len(data)} bytes; expected 64 hex digits") from None
        return bytes.fromhex(data.decode().strip())
    with os.fdopen(fd, "w") as f:
        f.write(secrets.token_hex(32))
    return bytes.fromhex(path.read_text().strip())


def parse_keys(entries: list[str]) -> dict[str, str]:
    """Key to tenant name: ``"name=key"`` entries, or bare keys (their own tenant).

    Examples
    --------
    >>> parse_keys(["acme=K1", "acme=K2", "K3"]) == {"K1": "acme", "K2": "acme", "K3": "K3"}
    True
    """
    out = {}
    for e in entries:
        name, sep, key = e.partition("=")
        if sep and name.strip() and key.strip():
            out[key.strip()] = name.strip()
        else:
            out[e.strip()] = e.strip()
    return out


def legacy_owner(key: str) -> str:
    """The owner id earlier versions recorded for a key (unsalted), to migrate data from."""
    return "k_" + hashlib.sha256(key.encode()).hexdigest()[:16]


def _values(items: Mapping[str, str] | None, name: str) -> list[str]:
    """Every value of ``name`` (starlette's headers and query parameters keep repeated names)."""
    if items is None:
        return []
    getlist = getattr(items, "getlist", None)
    if getlist is not None:
        return [str(v) for v in getlist(name)]
    value = items.get(name)
    return [] if value is None else [value]


def one_key(headers: Mapping[str, str], query: Mapping[str, str] | None = None) -> str | None:
    """The one API key a request names: ``X-API-Key``, ``Authorization: Bearer`` or the ``api_key`` query.

    Each may come more than once, and several may come together, as long as they name one key.

    Raises
    ------
    ServiceError
        400 ``conflicting_credentials`` when they name different keys; the error names where
        they came from, never the keys.

    Examples
    --------
    >>> one_key({"x-api-key": "K1"}, {"api_key": "K1"}), one_key({"authorization": "Basic eDp5"})
    ('K1', None)
    """
    found: list[tuple[str, str]] = [("X-API-Key", v) for v in _values(headers, "x-api-key") if v]
    for auth in _values(headers, "authorization"):
        if auth.lower().startswith("bearer ") and auth[7:].strip():
            found.append(("Authorization", auth[7:].strip()))
    found += [("api_key", v) for v in _values(query, "api_key") if v]
    keys = {key for _, key in found}
    if len(keys) > 1:
        where = sorted({name for name, _ in found})
        raise ServiceError("conflicting_credentials", f"the request names {len(keys)} different API keys, in "
                           f"{' and '.join(where)}; send one key (repeated, it must be the same)", headers=where)
    return found[0][1] if found else None


class Authenticator:
    """Map a request's API key to the owner id of its resources.

    Parameters
    ----------
    settings : Settings
    secret : bytes
        The installation secret (:func:`load_secret`).
    """

    def __init__(self, settings: Settings, secret: bytes) -> None:
        self.enabled = bool(settings.api_keys)
        self._tenants = parse_keys(settings.api_keys)
        self._secret = secret

    def owner_of_tenant(self, tenant: str) -> str:
        """The owner id of a tenant name."""
        return "o_" + hmac.new(self._secret, tenant.encode(), hashlib.sha256).hexdigest()[:32]

    def migrations(self) -> dict[str, str]:
        """Earlier owner ids of the configured bare keys -> their owner ids now."""
        return {legacy_owner(k): self.owner_of_tenant(t) for k, t in self._tenants.items()}

    def owner(self, headers: Mapping[str, str], query: Mapping[str, str] | None = None) -> str:
        """Owner id for the key in ``headers`` (or ``query``, for the WebSocket upgrade only).

        Raises
        ------
        ServiceError
            401 when keys are configured and none, or an unknown one, is given; 400
            ``conflicting_credentials`` when the request names two different keys (:func:`one_key`).
        """
        if not self.enabled:
            return PUBLIC
        key = one_key(headers, query)
        if not key:
            e = ServiceError("missing_api_key", "an API key is required: send the X-API-Key header")
            e.headers["WWW-Authenticate"] = "ApiKey"
            raise e
        tenant = None
        for k, t in self._tenants.items():
            if hmac.compare_digest(k.encode(), key.encode()):
                tenant = t
        if tenant is None:
            e = ServiceError("invalid_api_key", "unknown API key")
            e.headers["WWW-Authenticate"] = "ApiKey"
            raise e
        return self.owner_of_tenant(tenant)


class Limiter(Protocol):
    """What the routes ask of a rate limiter (:class:`RateLimiter`, :class:`SharedRateLimiter`)."""

    def check(self, owner: str, now: float | None = None) -> None:
        """Take one token of ``owner``'s bucket, or raise 429 with ``Retry-After``."""


class RateLimiter:
    """Token bucket per owner: ``rate`` requests per second, bursts of ``burst``."""

    def __init__(self, rate: float, burst: int) -> None:
        self.rate = rate
        self.burst = burst
        self._buckets: dict[str, tuple[float, float]] = {}

    def check(self, owner: str, now: float | None = None) -> None:
        """Take one token, or raise 429 with ``Retry-After``.

        Examples
        --------
        >>> lim = RateLimiter(rate=1.0, burst=2)
        >>> lim.check("a", now=0.0); lim.check("a", now=0.0)
        >>> try:
        ...     lim.check("a", now=0.1)
        ... except ServiceError as e:
        ...     print(e.status, e.headers["Retry-After"])
        429 1
        """
        if self.rate <= 0:
            return
        now = time.monotonic() if now is None else now
        tokens, last = self._buckets.get(owner, (float(self.burst), now))
        tokens = min(float(self.burst), tokens + (now - last) * self.rate)
        if tokens < 1.0:
            wait = (1.0 - tokens) / self.rate
            e = ServiceError("rate_limited", f"rate limit exceeded: {self.rate:g} requests/s with bursts "
                             f"of {self.burst}; retry in {wait:.2f} s", retry_after_s=round(wait, 3))
            e.headers["Retry-After"] = str(max(1, math.ceil(wait)))
            self._buckets[owner] = (tokens, now)
            raise e
        self._buckets[owner] = (tokens - 1.0, now)


class SharedRateLimiter:
    """The token buckets of :class:`RateLimiter`, kept in the shared store so that every replica charges one.

    Parameters
    ----------
    take : callable
        ``take(owner, rate, burst) -> (granted, tokens_left)``, one atomic
        update of the owner's bucket (:meth:`~service.state.pg_store.PgStore.take_token`).
    rate : float
    burst : int
    """

    def __init__(self, take: Callable[[str, float, int], tuple[bool, float]], rate: float, burst: int) -> None:
        self.take = take
        self.rate = rate
        self.burst = burst

    def check(self, owner: str, now: float | None = None) -> None:
        """Take one token, or raise 429 with ``Retry-After``."""
        if self.rate <= 0:
            return
        granted, tokens = self.take(owner, self.rate, self.burst)
        if not granted:
            wait = (1.0 - tokens) / self.rate
            e = ServiceError("rate_limited", f"rate limit exceeded: {self.rate:g} requests/s with bursts "
                             f"of {self.burst}; retry in {wait:.2f} s", retry_after_s=round(wait, 3))
            e.headers["Retry-After"] = str(max(1, math.ceil(wait)))
            raise e


class Slot:
    """One held connection of :class:`ConnectionSlots`; :meth:`release` gives it back."""

    def __init__(self, slots: ConnectionSlots, owner: str) -> None:
        self._slots, self._owner, self._held = slots, owner, True

    def release(self) -> None:
        """Give the slot back (idempotent)."""
        if self._held:
            self._held = False
            self._slots.open[self._owner] -= 1


class ConnectionSlots:
    """Open WebSocket streams per owner, at most ``limit`` at once."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.open: dict[str, int] = {}

    def acquire(self, owner: str) -> Slot:
        """Hold one slot of ``owner``.

        Raises
        ------
        ServiceError
            429 ``connection_limit`` when the owner holds ``limit`` already.
        """
        n = self.open.get(owner, 0)
        if n >= self.limit:
            raise ServiceError("connection_limit", f"this key has {n} open streams (limit {self.limit})",
                               connections=n, limit=self.limit)
        self.open[owner] = n + 1
        return Slot(self, owner)
