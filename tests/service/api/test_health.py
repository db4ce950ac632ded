"""/health, /ready, /metrics, /v1/formats and the request id."""

from __future__ import annotations

import json

from ..conftest import BRACKET_SPEC, MOVES, upload_bracket


def test_ready_metrics_and_request_ids(client, tc):
    r = tc.get("/ready")
    assert r.status_code == 200 and r.json() == {"ready": True, "checks": {"store_writable": True, "workers": True,
                                                                           "sweeper": True, "parse_workers": True}}
    s = client.create_session(upload_bracket(client)["id"], BRACKET_SPEC)
    client.deform(s["id"], MOVES[0])
    tc.get("/v1/sessions/s_nope")
    text = tc.get("/metrics").text
    assert 'tetmorph_requests_total{method="POST",route="/v1/sessions/{session_id}/deform",status="200"} 1.0' in text
    assert 'tetmorph_requests_total{method="GET",route="/v1/sessions/{session_id}",status="404"} 1.0' in text
    assert "tetmorph_solve_seconds_count 1.0" in text and "tetmorph_build_seconds_count 1.0" in text
    assert 'tetmorph_sessions{status="ready"} 1.0' in text and 'tetmorph_queue_depth{pool="tetrahedralize"}' in text
    cache = float(next(ln.split()[1] for ln in text.splitlines() if ln.startswith("tetmorph_cache_bytes ")))
    assert cache == tc.get("/health").json()["cache_bytes"] > 0
    r = tc.get("/health", headers={"X-Request-ID": "abc-123"})
    assert r.headers["x-request-id"] == "abc-123"
    ids = {tc.get("/health").headers["x-request-id"] for _ in range(3)}
    assert len(ids) == 3
    assert tc.get("/v1/nowhere").headers["x-request-id"]


def test_metrics_labels_are_route_templates_whatever_the_client_asks(tc):
    for k in range(40):
        tc.get(f"/editor/no-such-file-{k}.js")
        tc.get(f"/v1/sessions/s_{k}")
        tc.get(f"/v1/unknown/{k}")
    routes = set()
    for ln in tc.get("/metrics").text.splitlines():
        if ln.startswith("tetmorph_requests_total{"):
            routes.add(ln.split('route="')[1].split('"')[0])
    assert "no-such-file" not in " ".join(routes) and not any("s_1" in r for r in routes)
    assert {"/editor/{path}", "/v1/sessions/{session_id}", "unmatched"} <= routes
    assert len(routes) <= 6, routes


def test_metrics_method_labels_are_a_bounded_set_whatever_methods_the_client_sends(tc):
    for k in range(30):
        assert tc.request(f"TETMORPH{k}", "/health").status_code == 405
        assert tc.request(f"TETMORPH{k}", f"/v1/sessions/s_{k}").status_code == 405
    tc.get("/health")
    methods = set()
    for ln in tc.get("/metrics").text.splitlines():
        if ln.startswith(("tetmorph_requests_total{", "tetmorph_request_seconds_count{")):
            methods.add(ln.split('method="')[1].split('"')[0])
    assert "GET" in methods and "other" in methods and not any("TETMORPH" in m for m in methods), methods
    assert methods <= {"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS", "other"}, methods


def test_an_unbuilt_editor_is_a_404_that_says_how_to_build_it(tc, monkeypatch, tmp_path):
    import service.app as app_module

    monkeypatch.setattr(app_module, "EDITOR_DIR", tmp_path / "no-editor")
    r = tc.get("/editor/main.js")
    assert r.status_code == 404 and "make web" in r.json()["error"]["message"]


def test_every_response_says_no_sniffing_no_framing_no_referrer(tc):
    for path in ("/health", "/", "/editor/main.js", "/v1/sessions/s_nope", "/openapi.json"):
        h = tc.get(path).headers
        assert h["x-content-type-options"] == "nosniff" and h["x-frame-options"] == "DENY", path
        assert h["referrer-policy"] == "no-referrer", path


def test_every_api_answer_has_a_content_security_policy_that_loads_nothing(tc):
    for path in ("/health", "/editor/main.js", "/v1/sessions/s_nope", "/openapi.json", "/v1/nosuch"):
        csp = tc.get(path).headers["content-security-policy"]
        assert "default-src 'none'" in csp and "frame-ancestors 'none'" in csp, path
    docs = tc.get("/docs").headers["content-security-policy"]  # Swagger UI's own policy (tests/service/test_docs_page)
    assert "default-src 'none'" in docs and "frame-ancestors 'none'" in docs


def test_the_editor_page_is_sent_with_its_policy(tc):
    import base64
    import hashlib
    import re

    page = tc.get("/")
    assert page.status_code == 200, "the editor is not built: make web (make check and make test do)"
    csp = {d.split()[0]: d.split()[1:] for d in page.headers["content-security-policy"].split("; ")}
    inline = [b for a, b in re.findall(r"<script([^>]*)>(.*?)</script>", page.text, re.S) if "src=" not in a]
    want = sorted(f"'sha256-{base64.b64encode(hashlib.sha256(b.encode()).digest()).decode()}'" for b in inline)
    assert inline and sorted(x for x in csp["script-src"] if x.startswith("'sha256-")) == want
    assert "'unsafe-inline'" not in csp["script-src"] and csp["frame-ancestors"] == ["'none'"]


def test_the_editor_policy_allows_only_the_pages_own_inline_script():
    import base64
    import hashlib

    from service.observability import editor_csp

    page = '<script type="importmap">{"imports": {}}</script><script type="module" src="/editor/main.js"></script>'
    csp = {d.split()[0]: d.split()[1:] for d in editor_csp(page).split("; ")}
    digest = base64.b64encode(hashlib.sha256(b'{"imports": {}}').digest()).decode()
    assert csp["script-src"] == ["'self'", f"'sha256-{digest}'"]
    assert csp["frame-ancestors"] == ["'none'"] and csp["object-src"] == ["'none'"]


def test_ready_says_what_fails(tc):
    import os
    import stat

    folder = tc.app.state.registry.store.sessions_dir
    mode = folder.stat().st_mode
    os.chmod(folder, stat.S_IREAD | stat.S_IEXEC)
    try:
        if os.access(folder, os.W_OK):  # root ignores the mode: stop the sweeper instead
            tc.portal.call(tc.app.state.sweeper.stop)
            r = tc.get("/ready")
            assert r.status_code == 503 and r.json()["checks"]["sweeper"] is False
        else:
            r = tc.get("/ready")
            assert r.status_code == 503 and r.json()["checks"]["store_writable"] is False
    finally:
        os.chmod(folder, mode)


def test_formats_are_what_round_trips(tc, tmp_path):
    rows = {r["name"]: r for r in tc.get("/v1/formats").json()}
    assert rows["abaqus"]["available"] and rows["abaqus"]["sets"] and rows["abaqus"]["quadratic"]
    assert not rows["ugrid"]["available"]  # it does not round-trip a tet mesh: not offered
    r = tc.get("/v1/meshes/m_x/file?format=ugrid")
    assert r.status_code in (404, 422)
    offered = [n for n, row in rows.items() if row["available"]]
    assert {"xdmf", "exodus", "vtu", "gmsh", "tetgen"} <= set(offered)


def test_every_offered_format_downloads(client, tc):
    mid = upload_bracket(client)["id"]
    # a format written back in place only takes no deck of another format: tests/service/api/test_deck_uploads.py
    offered = [r["name"] for r in tc.get("/v1/formats").json() if r["available"] and r["converts_to"]]
    failed = {}
    for name in offered:
        strict = tc.get(f"/v1/meshes/{mid}/file", params={"format": name})
        # a format that cannot hold the deck's sets or faces refuses, saying what would be lost
        assert strict.status_code == 200 or (strict.status_code == 422
                                             and strict.json()["error"]["code"] == "lossy_write"), name
        r = tc.get(f"/v1/meshes/{mid}/file", params={"format": name, "lossy": "true"})
        if r.status_code != 200 or not r.content:
            failed[name] = r.text[:200]
        elif strict.status_code == 422:  # the lossy write says what it dropped
            assert json.loads(r.headers["X-Tetmorph-Dropped"]), name
        for text in (r.text, strict.text):
            assert "/tmp" not in text and str(tc.app.state.settings.data_dir) not in text
    assert failed == {}


def test_metrics_show_the_solves_in_flight_and_the_threads_one_would_get(tc):
    from solver.linalg import threads

    def value(text: str, name: str) -> float:
        return float(next(ln.split()[1] for ln in text.splitlines() if ln.startswith(name + " ")))

    assert value(tc.get("/metrics").text, "tetmorph_solves_in_flight") == 0
    with threads.solving():  # a solve of this process under way, as a solve pool thread holds it
        text = tc.get("/metrics").text
    assert value(text, "tetmorph_solves_in_flight") == 1
    assert 1 <= value(text, "tetmorph_solve_threads") <= threads.cores()
    assert value(tc.get("/metrics").text, "tetmorph_solves_in_flight") == 0


def test_solve_pool_defaults_to_one_thread_per_core_and_solver_threads_cap_each_solve():
    from service.app import create_app
    from service.settings import Settings
    from solver.linalg import threads

    assert Settings().solve_pool_size == threads.cores()
    assert Settings(solve_workers=3).solve_pool_size == 3
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        try:
            app = create_app(Settings(data_dir=d, solver_threads=1))
            assert app.state.registry.builder.solve_workers == threads.cores()
            with threads.solving() as k:
                assert k == 1
        finally:
            threads.configure(None)
