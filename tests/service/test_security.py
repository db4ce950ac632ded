"""API keys, tenants and owner ids."""

from __future__ import annotations

import pytest

from service.client import Client, TetmorphError

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


def test_owner_ids_are_salted_per_installation_and_legacy_ids_move(tmp_path):
    import hashlib
    import json
    import stat

    from service.security import SECRET_FILE

    with running(tmp_path / "a", api_keys="alpha") as tc:
        Client(http=tc, api_key="alpha").upload_arrays(*_tet(), name="t")
    secret = tmp_path / "a" / SECRET_FILE
    assert stat.S_IMODE(secret.stat().st_mode) == 0o600 and len(secret.read_text().strip()) == 64
    (meta,) = [json.loads(p.read_text()) for p in (tmp_path / "a" / "meshes").rglob("meta.json")]
    unsalted = "k_" + hashlib.sha256(b"alpha").hexdigest()[:16]
    assert meta["owner"] != unsalted and meta["owner"].startswith("o_")
    with running(tmp_path / "b", api_keys="alpha") as tc:  # another installation: another owner id
        Client(http=tc, api_key="alpha").upload_arrays(*_tet(), name="t")
    (meta_b,) = [json.loads(p.read_text()) for p in (tmp_path / "b" / "meshes").rglob("meta.json")]
    assert meta_b["owner"] != meta["owner"]
    # data written by an earlier version under the unsalted id is still alpha's after the upgrade
    path = next((tmp_path / "a" / "meshes").rglob("meta.json"))
    path.write_text(json.dumps({**meta, "owner": unsalted}))
    with running(tmp_path / "a", api_keys="alpha") as tc:
        assert [m["id"] for m in tc.get("/v1/meshes", headers={"X-API-Key": "alpha"}).json()] == [meta["id"]]
    assert json.loads(path.read_text())["owner"] == meta["owner"]


def test_rotating_a_key_keeps_its_data(tmp_path):
    with running(tmp_path, api_keys="acme=old") as tc:
        mid = Client(http=tc, api_key="old").upload_arrays(*_tet(), name="t")["id"]
    with running(tmp_path, api_keys="acme=old,acme=new") as tc:  # both work during the change
        for key in ("old", "new"):
            assert tc.get(f"/v1/meshes/{mid}", headers={"X-API-Key": key}).status_code == 200
    with running(tmp_path, api_keys="acme=new") as tc:
        assert tc.get(f"/v1/meshes/{mid}", headers={"X-API-Key": "new"}).status_code == 200
        assert err(tc.get(f"/v1/meshes/{mid}", headers={"X-API-Key": "old"}))["code"] == "invalid_api_key"
    with running(tmp_path / "bare", api_keys="k1") as tc:  # a bare key rotates under its own name
        mid = Client(http=tc, api_key="k1").upload_arrays(*_tet(), name="t")["id"]
    with running(tmp_path / "bare", api_keys="k1=k2") as tc:
        assert tc.get(f"/v1/meshes/{mid}", headers={"X-API-Key": "k2"}).status_code == 200


def test_access_log_redacts_the_query_key(tmp_path, caplog):
    import logging

    with running(tmp_path, api_keys="s3cret-key") as tc, caplog.at_level(logging.INFO, logger="tetmorph.access"):
        tc.get("/v1/meshes?api_key=s3cret-key&limit=5")
        tc.get("/v1/meshes", headers={"X-API-Key": "s3cret-key", "X-Request-ID": "req-42"})
    lines = [r.getMessage() for r in caplog.records if r.name == "tetmorph.access"]
    assert len(lines) == 2 and "api_key=[redacted]" in lines[0]
    assert "s3cret-key" not in caplog.text
    assert "s3cret-key" not in "".join(p.read_text(errors="replace") for p in tmp_path.rglob("*") if p.is_file())


def test_access_log_redacts_a_percent_encoded_query_key(tmp_path, caplog):
    import logging

    with running(tmp_path, api_keys="s3cret-key") as tc, caplog.at_level(logging.INFO, logger="tetmorph.access"):
        for q in ("api%5Fkey", "%61pi_key", "API%255Fkey"):
            tc.get(f"/v1/meshes?{q}=s3cret-key&limit=5", headers={"X-API-Key": "s3cret-key"})
    lines = [r.getMessage() for r in caplog.records if r.name == "tetmorph.access"]
    assert len(lines) == 3 and all("=[redacted]&limit=5" in ln for ln in lines)
    assert "s3cret-key" not in caplog.text


def _tet():
    import numpy as np

    return np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]), np.array([[0, 1, 2, 3]])
