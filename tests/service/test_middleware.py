"""Request limits: body size, elements, sessions, rate."""

from __future__ import annotations

import json

from .conftest import BRACKET, BRACKET_SPEC, err, running, upload_bracket


def test_limits(tmp_path):
    from service.client import Client

    with running(tmp_path, max_upload_mb=0.1) as tc:
        r = tc.post("/v1/meshes", files=[("file", ("b.inp", BRACKET.read_bytes()))])
        assert r.status_code == 413 and err(r)["code"] == "payload_too_large"
        assert "bytes" in err(r)["message"]
    with running(tmp_path, max_elements=1000) as tc:
        r = tc.post("/v1/meshes", files=[("file", ("b.inp", BRACKET.read_bytes()))])
        assert r.status_code == 422 and err(r)["code"] == "too_many_elements"
        assert "4228" in err(r)["message"]
    with running(tmp_path, max_sessions=1) as tc:
        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        c.create_session(mid, BRACKET_SPEC)
        r = tc.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC})
        assert r.status_code == 429 and err(r)["code"] == "session_limit"
    with running(tmp_path, rate_limit_per_s=0.5, rate_burst=3) as tc:
        codes = [tc.get("/v1/meshes").status_code for _ in range(4)]
        assert codes == [200, 200, 200, 429]
        r = tc.get("/v1/meshes")
        assert err(r)["code"] == "rate_limited" and int(r.headers["retry-after"]) >= 1


def _raw_exchange(port: int, requests: list[bytes]) -> list[bytes]:
    """Send requests one after another on ONE TCP connection; return each response's head and body."""
    import socket

    out = []
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        f = s.makefile("rb")
        for req in requests:
            s.sendall(req)
            head = b""
            while not head.endswith(b"\r\n\r\n"):
                line = f.readline()
                assert line, "the server closed the connection"
                head += line
            length = int(next(h.split(b":")[1] for h in head.split(b"\r\n") if h.lower().startswith(b"content-length")))
            out.append(head + f.read(length))
    return out


def test_errors_keep_the_connection_alive(tmp_path):
    """After 404, 422, 413 and a 500 the same keep-alive connection serves the next request."""
    from service.process import serve_process

    env = {"TETMORPH_MAX_UPLOAD_MB": "0.01", "TETMORPH_SOLVER": "nonesuch", "TETMORPH_LOAD_KERNELS": "0"}
    with serve_process(tmp_path, env=env) as (url, _):
        port = int(url.rsplit(":", 1)[1])
        get = b"GET /health HTTP/1.1\r\nhost: x\r\n\r\n"
        mesh = b"\r\n".join([b"--B", b'Content-Disposition: form-data; name="file"; filename="c.inp"', b"",
                             b"*NODE\n1,0,0,0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n*ELEMENT, TYPE=C3D4\n1,1,2,3,4\n",
                             b"--B--", b""])
        upload = (b"POST /v1/meshes HTTP/1.1\r\nhost: x\r\ncontent-type: multipart/form-data; boundary=B\r\n"
                  b"content-length: " + str(len(mesh)).encode() + b"\r\n\r\n" + mesh)
        big = b"x" * 20000
        too_big = (b"POST /v1/meshes/arrays HTTP/1.1\r\nhost: x\r\ncontent-type: application/json\r\n"
                   b"content-length: " + str(len(big)).encode() + b"\r\n\r\n" + big)
        bad_json = (b"POST /v1/sessions HTTP/1.1\r\nhost: x\r\ncontent-type: application/json\r\n"
                    b"content-length: 5\r\n\r\n{nope")
        nowhere = b"GET /v1/nowhere HTTP/1.1\r\nhost: x\r\n\r\n"
        answers = _raw_exchange(port, [get, nowhere, bad_json, too_big, upload, get])
        statuses = [int(a.split(b" ")[1]) for a in answers]
        assert statuses == [200, 404, 422, 413, 201, 200], statuses
        mid = json.loads(answers[4].split(b"\r\n\r\n", 1)[1])["id"]
        spec = json.dumps({"mesh_id": mid, "spec": {"selections": {"a": {"ids": [0]}, "b": {"ids": [3]}},
                                                    "fixed": ["a"], "handles": {"h": "b"}}}).encode()
        create = (b"POST /v1/sessions HTTP/1.1\r\nhost: x\r\ncontent-type: application/json\r\ncontent-length: "
                  + str(len(spec)).encode() + b"\r\n\r\n" + spec)
        answers = _raw_exchange(port, [create, get])  # 500 unknown_backend, then the same connection goes on
        assert [int(a.split(b" ")[1]) for a in answers] == [500, 200]
        assert b"connection: close" not in answers[0].lower()


def test_text_that_is_not_valid_unicode_is_refused_before_anything_is_stored(tmp_path):
    """A lone surrogate escape is valid JSON but no UTF-8 answer can hold it; NUL cannot go into jsonb."""
    from service.client import Client

    with running(tmp_path) as tc:
        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        spec = json.dumps(BRACKET_SPEC)
        for bad, field in [(spec.replace('"tip"', '"tip\\ud800"', 1), "body.spec"),
                           (spec.replace('"tip"', '"tip\\u0000"', 1), "body.spec")]:
            r = tc.post("/v1/sessions", content=f'{{"mesh_id": "{mid}", "spec": {bad}}}',
                        headers={"content-type": "application/json"})
            assert r.status_code == 422 and err(r)["code"] == "invalid_request", r.text
            assert err(r)["details"]["field"].startswith(field)
        assert tc.get("/v1/sessions").json() == []  # nothing was stored
        sid = c.create_session(mid, BRACKET_SPEC)["id"]
        good = tc.patch(f"/v1/sessions/{sid}", json={"presets": [{"name": "up", "move": {}}]})
        assert good.status_code == 200
        for body in ['{"presets": [{"name": "x\\udc00", "move": {}}]}',
                     '{"presets": [{"name": "n", "move": {"handles": {"tip\\ud800": {"scale": 2}}}}]}',
                     '{"presets": [{"name": "nul\\u0000", "move": {}}]}']:
            r = tc.patch(f"/v1/sessions/{sid}", content=body, headers={"content-type": "application/json"})
            assert r.status_code == 422 and "presets[0]" in err(r)["details"]["field"], r.text
        doc = tc.get(f"/v1/sessions/{sid}")
        assert doc.status_code == 200 and doc.json()["presets"] == [{"name": "up", "move": {}}]
        # a paired surrogate (an emoji) is valid text and is kept
        r = tc.patch(f"/v1/sessions/{sid}", content='{"presets": [{"name": "\\ud83d\\ude00", "move": {}}]}',
                     headers={"content-type": "application/json"})
        assert r.status_code == 200 and tc.get(f"/v1/sessions/{sid}").json()["presets"][0]["name"] == "\U0001f600"
