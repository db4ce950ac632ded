"""API keys, tenants and owner ids."""

from __future__ import annotations

import pytest

from service.client import TetmorphError

from .conftest import BRACKET_SPEC, MOVES, err, running, upload_bracket


def test_api_keys_isolate_tenants(tmp_path):
    from service.client import Client

    with running(tmp_path, api_keys="alpha,beta") as tc:
        r = tc.get("/v1/meshes")
        assert r.status_code == 401 and err(r)["code"] == "missing_api_key"
        r = tc.get("/v1/meshes", headers={"X-API-Key": "gamma"})
        assert r.status_code == 401 and err(r)["code"] == "invalid_api_key"
        a, b = Client(http=tc, api_key="alpha"), Client(http=tc, api_key="beta")
        mid = upload_bracket(a)["id"]
        sid = a.create_session(mid, BRACKET_SPEC)["id"]
        for call in (lambda: b.mesh(mid), lambda: b.session(sid), lambda: b.deform(sid, MOVES[0]),
                     lambda: b.delete_session(sid), lambda: b.create_session(mid, BRACKET_SPEC)):
            with pytest.raises(TetmorphError) as e:
                call()
            assert e.value.status == 404
        assert b.http.get("/v1/meshes", headers={"X-API-Key": "beta"}).json() == []
        assert len(a.http.get("/v1/sessions", headers={"Authorization": "Bearer alpha"}).json()) == 1
        assert tc.get("/health").status_code == 200  # liveness needs no key
    assert "alpha" not in "".join(p.read_text() for p in tmp_path.rglob("*.json"))


def test_connection_slots_per_key():
    from service.security import ConnectionSlots

    slots = ConnectionSlots(limit=2)
    a, b = slots.acquire("k"), slots.acquire("k")
    from service.errors import ServiceError

    with pytest.raises(ServiceError) as e:
        slots.acquire("k")
    assert e.value.code == "connection_limit" and e.value.status == 429
    slots.acquire("other").release()
    a.release()
    a.release()  # idempotent
    slots.acquire("k")
    b.release()
