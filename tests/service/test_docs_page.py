"""The Swagger UI page ``/docs`` loads everything from the service itself, under a policy that allows only that."""

from __future__ import annotations

import base64
import hashlib
import re
from html.parser import HTMLParser

import pytest
from fastapi.testclient import TestClient

from service.app import create_app


class _Refs(HTMLParser):
    """Every URL the page loads (``src`` and ``href`` attributes), and its inline scripts."""

    def __init__(self) -> None:
        super().__init__()
        self.urls: list[tuple[str, str]] = []
        self.inline: list[str] = []
        self._in_inline = False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        for key in ("src", "href"):
            if a.get(key):
                self.urls.append((tag, a[key]))
        self._in_inline = tag == "script" and not a.get("src")

    def handle_data(self, data):
        if self._in_inline:
            self.inline.append(data)

    def handle_endtag(self, tag):
        self._in_inline = False


@pytest.fixture(scope="module")
def tc(tmp_path_factory):
    with TestClient(create_app(data_dir=tmp_path_factory.mktemp("docs"), rate_limit_per_s=0)) as c:
        yield c


def _page(tc) -> tuple[str, _Refs]:
    r = tc.get("/docs")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    refs = _Refs()
    refs.feed(r.text)
    return r.text, refs


def test_the_docs_page_names_no_asset_of_another_host(tc):
    html, refs = _page(tc)
    assert {tag for tag, _ in refs.urls} >= {"script", "link"}, refs.urls  # the bundle, its style sheet, its icon
    for tag, url in refs.urls:
        assert url.startswith("/") and not url.startswith("//"), (tag, url)
    assert not re.search(r"https?://", html), re.findall(r"https?://[^\s'\"]+", html)


def test_every_asset_of_the_docs_page_is_served_with_its_type(tc):
    _, refs = _page(tc)
    want = {".js": "text/javascript", ".css": "text/css", ".png": "image/png"}
    for _, url in refs.urls:
        r = tc.get(url)
        assert r.status_code == 200, url
        assert r.headers["content-type"].split(";")[0] == want[url[url.rfind("."):]], (url, r.headers["content-type"])
        assert len(r.content) > 500, url
    js = tc.get(next(u for t, u in refs.urls if t == "script")).text
    assert "SwaggerUIBundle" in js  # the real bundle, not an error page
    assert tc.get(tc.app.openapi_url).status_code == 200  # what the page's script fetches


def test_no_other_file_is_served_under_the_docs_assets(tc):
    for name in ("index.html", "swagger-initializer.js", "..%2Fapp.py", "swagger-ui.js.map"):
        r = tc.get(f"/docs/assets/{name}")
        assert r.status_code == 404, name
        assert r.json()["error"]["code"] == "not_found"


def test_the_docs_policy_allows_the_page_its_own_files_and_its_one_inline_script_only(tc):
    _, refs = _page(tc)
    csp = {d.split()[0]: d.split()[1:] for d in tc.get("/docs").headers["content-security-policy"].split("; ")}
    assert csp["default-src"] == ["'none'"] and csp["frame-ancestors"] == ["'none'"]
    want = sorted(f"'sha256-{base64.b64encode(hashlib.sha256(s.encode()).digest()).decode()}'" for s in refs.inline)
    assert len(want) == 1 and sorted(csp["script-src"]) == sorted(["'self'", *want])
    for directive in ("style-src", "img-src", "connect-src"):
        assert csp[directive][0] == "'self'", directive
        assert not any(s.startswith(("http", "*")) or "." in s for s in csp[directive]), csp[directive]
    assert csp["connect-src"] == ["'self'"]


def test_redoc_is_not_served(tc):
    assert tc.get("/redoc").status_code == 404  # its pages would load from a CDN; Swagger UI is the API page
