"""The interactive API page ``/docs`` (Swagger UI), served with its assets from the service itself.

The Swagger UI files come from the ``swagger-ui-bundle-v2`` package (the ``swagger-ui-dist`` build,
installed with the service), so the page needs no network beyond the service: it works offline and
behind a firewall. The page sends its own Content-Security-Policy, which lets it load its script,
style sheet and icon from the service, run its one inline script (by hash), fetch ``/openapi.json``
and send "Try it out" requests to the service, and nothing else.
"""

from __future__ import annotations

import base64
import hashlib
import re
from pathlib import Path

from fastapi import FastAPI
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import FileResponse, HTMLResponse
from swagger_ui_bundle import swagger_ui_path

from .errors import ServiceError

__all__ = ["ASSETS", "DOCS_PATH", "docs_csp", "install_docs"]

DOCS_PATH = "/docs"
ASSETS_PATH = "/docs/assets"
#: The files the page loads, by name, with their media types; no other file of the bundle is served.
ASSETS = {"swagger-ui-bundle.js": "text/javascript; charset=utf-8",
          "swagger-ui.css": "text/css; charset=utf-8",
          "favicon-32x32.png": "image/png"}


def docs_csp(html: str) -> str:
    """The page's Content-Security-Policy: the service's own files, and each inline script by its hash.

    ``img-src data:`` is for the icons Swagger UI's style sheet holds as ``data:`` URIs; inline
    ``style`` attributes (which cannot run code) are allowed for its layout.
    """
    hashes = []
    for attrs, body in re.findall(r"<script([^>]*)>(.*?)</script>", html, re.S):
        if "src=" not in attrs:
            digest = base64.b64encode(hashlib.sha256(body.encode()).digest()).decode()
            hashes.append(f"'sha256-{digest}'")
    return ("default-src 'none'; script-src 'self' " + " ".join(hashes) + "; style-src 'self' 'unsafe-inline'; "
            "img-src 'self' data:; connect-src 'self'; base-uri 'none'; form-action 'none'; "
            "frame-ancestors 'none'")


def install_docs(app: FastAPI) -> None:
    """Serve Swagger UI at ``/docs`` and its files under ``/docs/assets/`` (create the app with ``docs_url=None``)."""
    root = Path(str(swagger_ui_path))
    page = get_swagger_ui_html(
        openapi_url=app.openapi_url or "/openapi.json", title=f"{app.title} - API",
        swagger_js_url=f"{ASSETS_PATH}/swagger-ui-bundle.js", swagger_css_url=f"{ASSETS_PATH}/swagger-ui.css",
        swagger_favicon_url=f"{ASSETS_PATH}/favicon-32x32.png",
        # no request to the public validator (its badge would load an image from another host)
        swagger_ui_parameters={"validatorUrl": None})
    html = bytes(page.body).decode()
    csp = docs_csp(html)

    @app.get(DOCS_PATH, include_in_schema=False)
    def docs() -> HTMLResponse:
        return HTMLResponse(html, headers={"Content-Security-Policy": csp})

    @app.get(ASSETS_PATH + "/{name}", include_in_schema=False)
    def docs_asset(name: str) -> FileResponse:
        if name not in ASSETS:
            raise ServiceError("not_found", f"no file {name!r} under {ASSETS_PATH}/")
        return FileResponse(root / name, media_type=ASSETS[name],
                            headers={"Cache-Control": "public, max-age=86400"})
