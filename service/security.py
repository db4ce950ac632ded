"""API keys and request-rate limits.

With no keys configured the service has one tenant, ``"public"``. With keys,
every request must carry one (``X-API-Key`` header, ``Authorization: Bearer``,
or ``api_key`` query parameter for WebSockets), and each key sees only its
own meshes and sessions. Keys are never written to disk: resources record a
digest of the key as their owner.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import time
from collections.abc import Mapping

from .errors import ServiceError
from .settings import Settings

__all__ = ["Authenticator", "RateLimiter", "PUBLIC"]

PUBLIC = "public"


def _digest(key: str) -> str:
    return "k_" + hashlib.sha256(key.encode()).hexdigest()[:16]


class Authenticator:
    """Map a request's API key to the owner id of its resources."""

    def __init__(self, settings: Settings) -> None:
        self.enabled = bool(settings.api_keys)
        self._keys = {k: _digest(k) for k in settings.api_keys}

    def owner(self, headers: Mapping[str, str], query: Mapping[str, str]) -> str:
        """Owner id for the key in ``headers`` or ``query``.

        Raises
        ------
        ServiceError
            401 when keys are configured and none, or an unknown one, is given.
        """
        if not self.enabled:
            return PUBLIC
        key = headers.get("x-api-key")
        auth = headers.get("authorization", "")
        if not key and auth.lower().startswith("bearer "):
            key = auth[7:].strip()
        key = key or query.get("api_key")
        if not key:
            e = ServiceError(401, "an API key is required: send the X-API-Key header",
                             code="missing_api_key")
            e.headers["WWW-Authenticate"] = "ApiKey"
            raise e
        for k, owner in self._keys.items():
            if hmac.compare_digest(k.encode(), key.encode()):
                return owner
        e = ServiceError(401, "unknown API key", code="invalid_api_key")
        e.headers["WWW-Authenticate"] = "ApiKey"
        raise e


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
            e = ServiceError(429, f"rate limit exceeded: {self.rate:g} requests/s with bursts of "
                             f"{self.burst}; retry in {wait:.2f} s", code="rate_limited",
                             retry_after_s=round(wait, 3))
            e.headers["Retry-After"] = str(max(1, math.ceil(wait)))
            self._buckets[owner] = (tokens, now)
            raise e
        self._buckets[owner] = (tokens - 1.0, now)
