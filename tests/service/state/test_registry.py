"""Registry behaviour: the factorization cache, idle sweeping, restarts, concurrency."""

from __future__ import annotations

import numpy as np
import pytest

from service.binary import decode_frame

from ..conftest import BRACKET, BRACKET_SPEC, MOVES, err, running, upload_bracket


def test_lru_budget_evicts_and_rebuilds_transparently(tmp_path, bracket_library):
    _, expected = bracket_library
    with running(tmp_path, cache_budget_mb=0.001) as tc:
        from service.client import Client

        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        a = c.create_session(mid, BRACKET_SPEC)
        b = c.create_session(mid, BRACKET_SPEC)
        assert c.session(a["id"])["status"] == "evicted"
        assert tc.get("/health").json()["evictions"] >= 1
        X, _ = c.deform(a["id"], MOVES[1])  # rebuilt on use
        np.testing.assert_allclose(X, expected[1], atol=1e-12)
        assert c.session(a["id"])["builds"] == 2
        assert c.session(b["id"])["status"] == "evicted"


def test_idle_sessions_are_swept(tmp_path):
    with running(tmp_path, session_ttl_s=60) as tc:
        from service.client import Client

        c = Client(http=tc)
        s = c.create_session(upload_bracket(c)["id"], BRACKET_SPEC)
        reg = tc.app.state.registry
        import time

        assert s["expires_at"] == pytest.approx(s["last_used"] + 60)
        assert reg.sessions.sweep(now=time.time() + 30) == []
        assert reg.sessions.sweep(now=time.time() + 120) == [s["id"]]
        r = tc.get(f"/v1/sessions/{s['id']}")  # gone, and it says why (it used to answer 404)
        assert r.status_code == 410 and err(r)["code"] == "session_expired"
        assert tc.get("/v1/sessions").json() == []
    with running(tmp_path) as tc:  # and it stays gone after a restart
        r = tc.get(f"/v1/sessions/{s['id']}")
        assert r.status_code == 410 and err(r)["details"]["session_id"] == s["id"]
    with running(tmp_path, expired_memory_s=0.001) as tc:  # remembered for a while only, then 404
        tc.app.state.registry.sessions.sweep(now=time.time() + 1000)
        assert tc.get(f"/v1/sessions/{s['id']}").status_code == 404


def test_polling_counts_as_use(tmp_path):
    """Any authenticated use of a session (here GET) postpones its expiry."""
    import time

    with running(tmp_path, session_ttl_s=5) as tc:
        from service.client import Client

        c = Client(http=tc)
        s = c.create_session(upload_bracket(c)["id"], BRACKET_SPEC)
        reg = tc.app.state.registry
        time.sleep(0.05)
        polled = tc.get(f"/v1/sessions/{s['id']}").json()
        assert polled["last_used"] > s["last_used"] and polled["expires_at"] == pytest.approx(polled["last_used"] + 5)
        assert reg.sessions.sweep(now=s["last_used"] + 5.02) == []  # expired by creation time, alive by the poll
        assert reg.sessions.sweep(now=polled["last_used"] + 5.5) == [s["id"]]


def test_restart_keeps_meshes_sessions_and_last_move(tmp_path, bracket_library):
    _, expected = bracket_library
    from service.client import Client

    with running(tmp_path) as tc:
        c = Client(http=tc)
        mid = upload_bracket(c)["id"]
        sid = c.create_session(mid, BRACKET_SPEC)["id"]
        c.deform(sid, MOVES[2])
    with running(tmp_path) as tc:
        c = Client(http=tc)
        assert c.session(sid)["status"] == "stored" and c.session(sid)["last_move"] == MOVES[2]
        np.testing.assert_allclose(c.positions(sid), expected[2], atol=1e-12)  # rebuilt
        X, _ = c.deform(sid, MOVES[0])
        np.testing.assert_allclose(X, expected[0], atol=1e-12)
        assert c.mesh(mid)["info"]["tetrahedra"] == 4228


def test_concurrent_updates_serialize_per_session_and_run_across_sessions(tmp_path,
                                                                          bracket_library):
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    import httpx

    from service.app import create_app

    _, expected = bracket_library
    app = create_app(data_dir=tmp_path)

    async def scenario():
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as ac:
            up = await ac.post("/v1/meshes", files=[("file", ("b.inp", BRACKET.read_bytes()))])
            mid = up.json()["id"]
            sids = [(await ac.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC}
                                   )).json()["id"] for _ in range(2)]
            calls = [ac.post(f"/v1/sessions/{sids[k % 2]}/deform", json=MOVES[k % 3],
                             params={"result": "binary"}) for k in range(12)]
            rs = await asyncio.gather(*calls)
            docs = [(await ac.get(f"/v1/sessions/{s}")).json() for s in sids]
            return rs, docs

    # in a thread of its own: a session-wide Playwright browser keeps an event loop running in this one
    with ThreadPoolExecutor(1) as pool:
        rs, docs = pool.submit(asyncio.run, scenario()).result()
    assert [r.status_code for r in rs] == [200] * 12
    for k, r in enumerate(rs):  # every answer is its own MOVE's exact result
        np.testing.assert_allclose(decode_frame(r.content)[0], expected[k % 3], atol=1e-12)
    assert [d["updates"] for d in docs] == [6, 6]
    app.state.registry.close()


def test_all_finite_checks_every_number_of_a_result():
    from service.state.moves import all_finite

    assert all_finite({"a": 1, "b": [0.5, {"c": None, "d": "x"}], "e": True})
    for bad in (float("inf"), -float("inf"), float("nan")):
        assert not all_finite({"report": {"timings": {"update": {"total_ms": bad}}}})
        assert not all_finite([1.0, [2.0, bad]])
