"""Request ids, access logs (API keys redacted), JSON logs and Prometheus metrics.

Every response carries ``X-Request-ID`` (the client's, if it sent a sane one,
else a new one) and ``X-Tetmorph-Replica`` (which replica answered); every log
line written while the request runs carries the request id too.
"""

from __future__ import annotations

import contextvars
import json
import logging
import re
import secrets
import time
from typing import Any
from urllib.parse import unquote_plus

from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram
from starlette.routing import Mount
from starlette.types import ASGIApp, Message, Receive, Scope, Send

__all__ = ["RequestContext", "Metrics", "JSONFormatter", "RequestIdFilter", "configure_logging",
           "redact", "request_id"]

request_id: contextvars.ContextVar[str] = contextvars.ContextVar("request_id", default="-")
access_log = logging.getLogger("tetmorph.access")
_SANE_ID = re.compile(r"^[A-Za-z0-9._-]{1,64}$")
#: Sent with every HTTP response, the editor's and the API's: no MIME sniffing, no framing by other
#: pages (clickjacking), no referrer with ids in it sent elsewhere.
SECURITY_HEADERS = ((b"x-content-type-options", b"nosniff"), (b"x-frame-options", b"DENY"),
                    (b"referrer-policy", b"no-referrer"))
#: The Content-Security-Policy of every answer that sets none of its own (JSON, files): nothing may load
#: or run from it, and no page may frame it. The editor's page sets its own (:func:`editor_csp`), and so
#: does the Swagger UI page (:func:`service.docs_assets.docs_csp`).
API_CSP = b"default-src 'none'; frame-ancestors 'none'; base-uri 'none'"


def editor_csp(index_html: str) -> str:
    """The editor page's Content-Security-Policy: its own files, plus each inline script by its hash.

    The page's one inline script is its import map; a hash (not ``'unsafe-inline'``) lets it and nothing
    else run, so a script injected into the page is refused. Inline ``style`` attributes are allowed:
    they cannot run code.
    """
    import base64
    import hashlib

    hashes = []
    for attrs, body in re.findall(r"<script([^>]*)>(.*?)</script>", index_html, re.S):
        if "src=" not in attrs:
            digest = base64.b64encode(hashlib.sha256(body.encode()).digest()).decode()
            hashes.append(f"'sha256-{digest}'")
    return ("default-src 'self'; script-src 'self' " + " ".join(hashes) + "; style-src 'self' 'unsafe-inline'; "
            "img-src 'self' data: blob:; connect-src 'self'; worker-src 'self' blob:; object-src 'none'; "
            "base-uri 'none'; form-action 'self'; frame-ancestors 'none'")
#: ``name=value`` pairs of a query string, alone or inside a logged line (after ``?``, ``&``, ``;`` or a space).
_PAIR = re.compile(r"(^|[?&;\s])([^=&;?\s]+)=([^&;\s]*)")
SECRET_NAMES = frozenset({"api_key"})


def _secret(name: str) -> bool:
    """Whether a query name is a secret's once decoded, as the server decodes it (``api%5Fkey``, ``%61pi_key``)."""
    decoded = name
    for _ in range(3):  # names encoded twice or three times decode to the same name
        step = unquote_plus(decoded)
        if step == decoded:
            break
        decoded = step
    return decoded.strip().lower() in SECRET_NAMES


def redact(query: str) -> str:
    """A query string (or a log line holding one) with the value of every ``api_key`` replaced.

    Names are compared decoded, so a percent-encoded spelling of the name is redacted too.

    Examples
    --------
    >>> redact("kind=positions&api_key=s3cret&dtype=float32")
    'kind=positions&api_key=[redacted]&dtype=float32'
    >>> redact("GET /v1/stream?api%5Fkey=s3cret&%61pi_key=s3cret")
    'GET /v1/stream?api%5Fkey=[redacted]&%61pi_key=[redacted]'
    """
    if "=" not in query:
        return query
    return _PAIR.sub(lambda m: f"{m[1]}{m[2]}=[redacted]" if _secret(m[2]) else m[0], query)


class RequestIdFilter(logging.Filter):
    """Put the current request id on every record (``%(request_id)s``)."""

    def filter(self, record: logging.LogRecord) -> bool:
        """Add ``request_id``; also redact API keys given as query parameters in the message."""
        record.request_id = request_id.get()
        if isinstance(record.msg, str):
            record.msg = redact(record.msg)
        if record.args and isinstance(record.args, tuple):
            record.args = tuple(redact(a) if isinstance(a, str) else a for a in record.args)
        return True


class JSONFormatter(logging.Formatter):
    """One JSON object per line: time, level, logger, request id, message (and the exception)."""

    def format(self, record: logging.LogRecord) -> str:
        """Format one record."""
        doc: dict[str, Any] = {"time": round(record.created, 3), "level": record.levelname,
                               "logger": record.name, "request_id": getattr(record, "request_id", "-"),
                               "message": record.getMessage()}
        if record.exc_info:
            doc["exception"] = self.formatException(record.exc_info)
        return json.dumps(doc)


def configure_logging(level: str = "info", json_lines: bool = False) -> None:
    """Log to stderr with request ids, as text or JSON lines; quiet uvicorn's own access log."""
    handler = logging.StreamHandler()
    handler.addFilter(RequestIdFilter())
    handler.setFormatter(JSONFormatter() if json_lines else logging.Formatter(
        "%(asctime)s %(levelname)s %(name)s [%(request_id)s] %(message)s"))
    for name in ("tetmorph", "uvicorn", "uvicorn.error"):
        lg = logging.getLogger(name)
        lg.handlers = [handler]
        lg.setLevel(level.upper())
        lg.propagate = False
    logging.getLogger("uvicorn.access").disabled = True  # ours redacts keys and carries the id


class Metrics:
    """The Prometheus metrics of one app (its own registry, so several apps can coexist)."""

    def __init__(self) -> None:
        self.registry = CollectorRegistry()
        r = self.registry
        self.requests = Counter("tetmorph_requests_total", "HTTP requests by route and status",
                                ["method", "route", "status"], registry=r)
        self.request_seconds = Histogram("tetmorph_request_seconds", "HTTP request duration",
                                         ["method", "route"], registry=r)
        self.build_seconds = Histogram("tetmorph_build_seconds", "session build (assembly and factorization)",
                                       registry=r, buckets=(0.1, 0.3, 1, 3, 10, 30, 100, 300))
        self.solve_seconds = Histogram("tetmorph_solve_seconds", "one MOVE solved (back-substitution, check)",
                                       registry=r, buckets=(0.005, 0.01, 0.03, 0.1, 0.3, 1, 3, 10))
        self.solves_in_flight = Gauge("tetmorph_solves_in_flight", "solves running now in this process (they "
                                      "share the free cores, solver.linalg.threads)", registry=r)
        self.solve_threads = Gauge("tetmorph_solve_threads", "threads one solve would get now", registry=r)
        self.queue = Gauge("tetmorph_queue_depth", "work waiting or running per pool", ["pool"], registry=r)
        self.cache_bytes = Gauge("tetmorph_cache_bytes", "bytes of cached factorizations", registry=r)
        self.sessions = Gauge("tetmorph_sessions", "sessions by status", ["status"], registry=r)


#: The request methods counted under their own name in the metrics; any other is ``other``.
METRIC_METHODS = frozenset({"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"})


class RequestContext:
    """ASGI middleware: request id, access log line, request metrics."""

    def __init__(self, app: ASGIApp, metrics: Metrics, replica: str = "") -> None:
        self.app = app
        self.metrics = metrics
        self.replica = replica.encode("latin-1", "replace")

    @staticmethod
    def _template(scope: Scope) -> str:
        """The matched route's path template (``/v1/sessions/{session_id}``), so nothing a client types is a label.

        A mount (the editor's static files) is one label, ``/editor/{path}``; a path no route matched is
        ``unmatched``. The labels are the app's routes, a bounded set.
        """
        if scope.get("endpoint") is None:
            return "unmatched"
        route = scope.get("route")
        if isinstance(route, Mount):  # static files: what follows the mount is the client's text
            return f"{route.path}/{{path}}"
        if route is None and "app_root_path" in scope:  # a mount that left no route: its prefix is in root_path
            return f"{str(scope.get('root_path', ''))[len(str(scope['app_root_path'])):]}/{{path}}"
        # the path with each parameter's segment put back as its name: only the route's own literal segments remain
        names = {str(v): k for k, v in (scope.get("path_params") or {}).items()}
        return "/".join(f"{{{names[seg]}}}" if seg in names else seg for seg in str(scope.get("path", "")).split("/"))

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Handle one ASGI connection."""
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        given = dict(scope.get("headers") or []).get(b"x-request-id", b"").decode("latin-1")
        rid = given if _SANE_ID.match(given) else secrets.token_hex(8)
        token = request_id.set(rid)
        status = 0
        t0 = time.perf_counter()

        async def tagged_send(msg: Message) -> None:
            nonlocal status
            if msg["type"] == "http.response.start":
                status = msg["status"]
                headers = [*msg.get("headers", []), (b"x-request-id", rid.encode()),
                           (b"x-tetmorph-replica", self.replica), *SECURITY_HEADERS]
                if not any(k.lower() == b"content-security-policy" for k, _ in headers):
                    headers.append((b"content-security-policy", API_CSP))
                msg["headers"] = headers
            elif msg["type"] == "websocket.accept":
                msg["headers"] = [*msg.get("headers", []), (b"x-tetmorph-replica", self.replica)]
            await send(msg)

        try:
            await self.app(scope, receive, tagged_send)
        finally:
            dt = time.perf_counter() - t0
            path = self._template(scope)
            method = scope.get("method", "WS")
            if scope["type"] == "http":  # a method is any token a client sends: the label set stays bounded
                label = method if method in METRIC_METHODS else "other"
                self.metrics.requests.labels(label, path, str(status)).inc()
                self.metrics.request_seconds.labels(label, path).observe(dt)
            q = scope.get("query_string", b"").decode("latin-1")
            client = scope.get("client") or ("-", 0)
            access_log.info("%s %s %s%s %s %.1f ms", client[0], method, scope.get("path", ""),
                            "?" + redact(q) if q else "", status or "-", 1e3 * dt)
            request_id.reset(token)
