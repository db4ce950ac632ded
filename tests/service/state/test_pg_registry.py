"""Two replicas on one PostgreSQL (real server) and one data directory: what one commits, the other serves."""

from __future__ import annotations

import contextlib

import numpy as np
import psycopg
import pytest

from tests.pg_fixture import fresh_database, pg_url  # noqa: F401 - the fixture

from ..conftest import BRACKET, BRACKET_SPEC, MOVES, err, running


@contextlib.contextmanager
def replicas(tmp_path, url, **settings):
    data = tmp_path / "data"
    with running(data, database_url=url, replica_id="A", **settings) as a, \
            running(data, database_url=url, replica_id="B", **settings) as b:
        yield a, b


@pytest.fixture
def db(pg_url):  # noqa: F811
    return fresh_database(pg_url)


def test_what_one_replica_commits_the_other_serves(tmp_path, db, bracket_library):
    _, want = bracket_library
    with replicas(tmp_path, db) as (a, b):
        mid = a.post("/v1/meshes", files=[("file", ("bracket.inp", BRACKET.read_bytes()))]).json()["id"]
        assert b.get(f"/v1/meshes/{mid}").status_code == 200
        r = a.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC})
        assert r.status_code in (201, 202) and r.headers["x-tetmorph-replica"] == "A"
        sid = r.json()["id"]
        r = b.post(f"/v1/sessions/{sid}/deform", json=MOVES[0])
        assert r.status_code == 200 and r.headers["x-tetmorph-version"] == "1"
        assert r.headers["x-tetmorph-replica"] == "B"
        got = a.get(f"/v1/sessions/{sid}/positions")  # A had the session at version 0: it reloads
        assert got.headers["x-tetmorph-version"] == "1"
        np.testing.assert_allclose(np.asarray(got.json()["positions"]), want[0], atol=1e-9)
        r = a.post(f"/v1/sessions/{sid}/deform", json=MOVES[1])
        assert r.headers["x-tetmorph-version"] == "2"
        got = b.get(f"/v1/sessions/{sid}/positions")
        np.testing.assert_allclose(np.asarray(got.json()["positions"]), want[1], atol=1e-9)
        assert [s["id"] for s in b.get("/v1/sessions").json()] == [sid]
        assert b.get(f"/v1/sessions/{sid}").json()["version"] == 2
        # a MOVE solved from a version another replica has replaced is not committed: 409, reloaded
        ra = a.app.state.registry
        s = ra.sessions.lookup("public", sid)  # A's copy at version 2
        assert b.post(f"/v1/sessions/{sid}/deform", json=MOVES[2]).headers["x-tetmorph-version"] == "3"
        with pytest.raises(Exception) as e:
            a.portal.call(ra.moves.deform, s, MOVES[0])
        assert e.value.code == "version_conflict" and e.value.status == 409
        assert s.version == 3 and s.last_move == MOVES[2]
        np.testing.assert_allclose(np.asarray(a.get(f"/v1/sessions/{sid}/positions").json()["positions"]), want[2],
                                   atol=1e-9)
        assert err(a.delete(f"/v1/meshes/{mid}"))["code"] == "mesh_in_use"
        assert a.delete(f"/v1/sessions/{sid}").status_code == 204
        assert err(b.get(f"/v1/sessions/{sid}"))["code"] == "session_not_found"
        assert b.delete(f"/v1/meshes/{mid}").status_code == 204
        assert err(a.get(f"/v1/meshes/{mid}"))["code"] == "mesh_not_found"


def test_limits_and_sweeps_count_every_replica(tmp_path, db):
    with replicas(tmp_path, db, max_sessions=2, rate_limit_per_s=0.5, rate_burst=6) as (a, b):
        mid = a.post("/v1/meshes", files=[("file", ("bracket.inp", BRACKET.read_bytes()))]).json()["id"]
        s1 = a.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC}).json()["id"]
        b.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC})
        e = err(a.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC}))
        assert e["code"] == "session_limit" and e["details"]["sessions"] == 2
        statuses = [c.get("/v1/sessions").status_code for _ in range(4) for c in (a, b)]
        assert statuses.count(429) >= 3  # one bucket of 6 for both replicas: 4 + 8 requests (a few refilled)
        assert err(a.get("/v1/sessions"))["code"] == "rate_limited"
    with replicas(tmp_path, db, session_ttl_s=60.0) as (a, b):
        with psycopg.connect(db, autocommit=True) as c:
            c.execute("UPDATE tm_sessions SET last_used = last_used - 3600 WHERE id = %s", (s1,))
        assert b.app.state.registry.sessions.sweep() == [s1]
        assert a.app.state.registry.sessions.sweep() == []  # swept once, whichever replica sweeps
        e = err(a.get(f"/v1/sessions/{s1}"))
        assert e["status"] == 410 and e["code"] == "session_expired"
        assert len(a.get("/v1/sessions").json()) == 1
        r = a.get("/ready")
        assert r.status_code == 200 and r.json()["checks"]["store_writable"] is True


PRESETS = [{"name": "lift 4", "move": MOVES[0]}, {"name": "twist", "move": MOVES[1]}]


def test_presets_are_shared_by_the_replicas_and_never_make_a_move_conflict(tmp_path, db, bracket_library):
    _, want = bracket_library
    with replicas(tmp_path, db) as (a, b):
        mid = a.post("/v1/meshes", files=[("file", ("bracket.inp", BRACKET.read_bytes()))]).json()["id"]
        sid = a.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC}).json()["id"]
        assert b.get(f"/v1/sessions/{sid}").json()["presets"] == []
        assert b.post(f"/v1/sessions/{sid}/deform", json=MOVES[2]).headers["x-tetmorph-version"] == "1"
        ra = a.app.state.registry
        s = ra.sessions.lookup("public", sid)  # A's copy, at version 1
        r = b.patch(f"/v1/sessions/{sid}", json={"presets": PRESETS})
        assert r.status_code == 200 and r.json()["presets"] == PRESETS and r.json()["version"] == 1
        # A holds the session at the same version: its answers read the presets B saved
        assert a.get(f"/v1/sessions/{sid}").json()["presets"] == PRESETS
        assert [x["presets"] for x in a.get("/v1/sessions").json()] == [PRESETS]
        # B replaces them while A solves a MOVE from version 1: A's MOVE commits (no 409) and keeps B's presets
        assert b.patch(f"/v1/sessions/{sid}", json={"presets": PRESETS[1:]}).status_code == 200
        a.portal.call(ra.moves.deform, s, MOVES[0])
        assert s.version == 2
        doc = b.get(f"/v1/sessions/{sid}").json()
        assert doc["version"] == 2 and doc["last_move"] == MOVES[0] and doc["presets"] == PRESETS[1:]
        assert a.post(f"/v1/sessions/{sid}/reset").json()["presets"] == PRESETS[1:]
        # a refused PATCH leaves the stored presets as they were
        bad = {"presets": [{"name": "x", "move": {"handles": {"tip": {"translation": [1, 2]}}}}]}
        assert err(a.patch(f"/v1/sessions/{sid}", json=bad))["code"] == "invalid_request"
        with psycopg.connect(db, autocommit=True) as c:
            record, presets, version = c.execute("SELECT record, presets, version FROM tm_sessions WHERE id = %s",
                                                 (sid,)).fetchone()
        assert presets == PRESETS[1:] and "presets" not in record and version == 3
    with replicas(tmp_path, db) as (a, b):  # replicas started afterwards (empty caches) have them
        doc = a.get(f"/v1/sessions/{sid}").json()
        assert doc["presets"] == PRESETS[1:] and doc["status"] == "stored"
        X = np.asarray(a.post(f"/v1/sessions/{sid}/deform", json=doc["presets"][0]["move"]).json()["positions"])
        np.testing.assert_allclose(X, want[1], atol=1e-9)
        assert b.delete(f"/v1/sessions/{sid}").status_code == 204
        assert err(a.patch(f"/v1/sessions/{sid}", json={"presets": PRESETS}))["code"] == "session_not_found"


def test_a_database_made_before_presets_gains_them_and_its_sessions_have_none(tmp_path, db):
    from service.state.pg_store import PgStore

    rec = {"id": "s_old0000000000000", "owner": "public", "mesh_id": "m_x", "spec": BRACKET_SPEC,
           "created": 1.0, "last_used": 2.0, "last_move": MOVES[0], "failed": None, "version": 4}
    with psycopg.connect(db, autocommit=True) as c:  # the table as the service made it before presets
        c.execute("CREATE TABLE tm_sessions (id text PRIMARY KEY, owner text NOT NULL, mesh_id text NOT NULL, "
                  "created double precision NOT NULL, last_used double precision NOT NULL, "
                  "version bigint NOT NULL DEFAULT 0, record jsonb NOT NULL)")
        c.execute("INSERT INTO tm_sessions VALUES (%s, 'public', 'm_x', 1.0, 2.0, 4, %s)",
                  (rec["id"], psycopg.types.json.Jsonb(rec)))
    store = PgStore(db, tmp_path / "data")
    try:
        loaded = store.load_session(rec["id"])
        assert loaded == {**rec, "presets": []} and store.load_presets(rec["id"]) == []
        assert store.save_presets(rec["id"], PRESETS) and store.load_presets(rec["id"]) == PRESETS
        assert store.load_session(rec["id"])["version"] == 4  # no version for presets
        # a commit (from a copy with stale presets) and an update write the record, never the presets
        assert store.commit_session({**loaded, "last_move": MOVES[1]}, 4) == 5
        assert not store.update_session({**loaded, "last_move": MOVES[2]}, 4)  # not at that version any more
        assert store.update_session({**loaded, "last_move": MOVES[2]}, 5)
        assert store.load_presets(rec["id"]) == PRESETS and store.load_session(rec["id"])["last_move"] == MOVES[2]
        assert [r["presets"] for r in store.list_sessions()] == [PRESETS]
        assert not store.save_presets("s_none", []) and store.load_presets("s_none") is None
        assert not store.save_presets("../x", []) and store.load_presets("../x") is None
    finally:
        store.close()
    again = PgStore(db, tmp_path / "data")  # the column exists now: starting again changes nothing
    try:
        assert again.load_presets(rec["id"]) == PRESETS
    finally:
        again.close()


def test_a_database_outage_answers_503_with_retry_after_and_loses_nothing(tmp_path):
    """The real server stopped and started again under requests: 503s while it is down, never a 500."""
    import tempfile

    from service.client import Client
    from service.cluster.postgres import LocalPostgres
    from service.process import free_port

    pg = LocalPostgres(tempfile.mkdtemp(prefix="tetmorph-pg-outage-"), free_port(), fast=True)
    url = pg.start()
    try:
        with running(tmp_path / "data", database_url=url, rate_limit_per_s=0) as tc:
            c = Client(http=tc)
            mid = c.upload_mesh(BRACKET)["id"]
            sid = c.create_session(mid, BRACKET_SPEC)["id"]
            c.deform(sid, MOVES[0])
            pg.stop()
            seen = {}
            for k in range(20):  # reads, a MOVE, an upload: every one 503, none stored
                r = [tc.get(f"/v1/sessions/{sid}"), tc.get("/v1/sessions"),
                     tc.post(f"/v1/sessions/{sid}/deform", json=MOVES[1 + k % 2]),
                     tc.get("/ready")][k % 4]
                seen[r.status_code] = seen.get(r.status_code, 0) + 1
                if r.status_code == 503 and r.request.url.path != "/ready":
                    assert r.headers["retry-after"] == "1" and err(r)["code"] == "store_unavailable", r.text
            assert set(seen) == {503}, seen
            assert tc.get("/health").status_code == 200  # liveness: the process itself is fine
            pg.start()
            assert tc.get("/ready").status_code == 200
            doc = c.session(sid)
            assert doc["last_move"] == MOVES[0] and doc["version"] == 1  # nothing lost, nothing doubled
            X, _ = c.deform(sid, MOVES[1])
            assert c.session(sid)["version"] == 2
            # the client waits out an outage: a MOVE sent while the database restarts is answered once
            import threading

            pg.stop()
            threading.Timer(1.5, pg.start).start()
            patient = Client(http=tc, retries=6, backoff_s=0.5)
            X, _ = patient.deform(sid, MOVES[2])
            assert c.session(sid)["version"] == 3 and c.session(sid)["last_move"] == MOVES[2]
    finally:
        pg.remove()


def test_a_stream_during_a_database_outage_is_closed_with_try_again_later_or_answered_503(tmp_path):
    """The real PostgreSQL stopped: a stream opened then is accepted and closed with 1013 and a reason (not an
    HTTP 500 handshake refusal); a MOVE on a stream already open is answered 503 store_unavailable and the
    stream stays open; after the restart nothing was committed and streams serve again."""
    import json
    import tempfile

    from starlette.websockets import WebSocketDisconnect

    from service.binary import decode_frame
    from service.client import Client
    from service.cluster.postgres import LocalPostgres
    from service.process import free_port

    pg = LocalPostgres(tempfile.mkdtemp(prefix="tetmorph-pg-stream-"), free_port(), fast=True)
    url = pg.start()
    try:
        with running(tmp_path / "data", database_url=url, rate_limit_per_s=0) as tc:
            c = Client(http=tc)
            sid = c.create_session(c.upload_mesh(BRACKET)["id"], BRACKET_SPEC)["id"]
            c.deform(sid, MOVES[0])
            path = f"/v1/sessions/{sid}/stream"
            with tc.websocket_connect(path) as ws:
                pg.stop()
                ws.send_text(json.dumps({"seq": 1, "move": MOVES[1]}))
                e = ws.receive_json()
                assert e["seq"] == 1 and e["error"]["code"] == "store_unavailable" and e["error"]["status"] == 503
                with pytest.raises(WebSocketDisconnect) as closed:
                    with tc.websocket_connect(path) as other:
                        other.receive_text()
                assert closed.value.code == 1013 and "try again" in closed.value.reason, closed.value
                ws.send_text(json.dumps({"seq": 2, "move": MOVES[2]}))  # still open, still answering
                assert ws.receive_json()["error"]["code"] == "store_unavailable"
            pg.start()
            doc = c.session(sid)
            assert doc["last_move"] == MOVES[0] and doc["version"] == 1  # nothing committed meanwhile
            with tc.websocket_connect(path) as ws:
                ws.send_text(json.dumps({"seq": 3, "move": MOVES[1]}))
                _, head = decode_frame(ws.receive_bytes())
                assert head["seq"] == 3 and head["version"] == 2
    finally:
        pg.remove()


def test_the_undo_history_is_shared_by_the_replicas_and_never_makes_a_move_conflict(tmp_path, db):
    with replicas(tmp_path, db) as (a, b):
        mid = a.post("/v1/meshes", files=[("file", ("bracket.inp", BRACKET.read_bytes()))]).json()["id"]
        sid = a.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC}).json()["id"]
        assert b.get(f"/v1/sessions/{sid}/history").json() == {"applied": [], "undone": []}
        ra = a.app.state.registry
        s = ra.sessions.lookup("public", sid)  # A's copy, at version 0
        kept = {"applied": MOVES[:2], "undone": MOVES[2:]}
        assert b.put(f"/v1/sessions/{sid}/history", json=kept).json() == kept
        assert a.get(f"/v1/sessions/{sid}/history").json() == kept  # saved on B, read on A
        a.portal.call(ra.moves.deform, s, MOVES[1])  # solved from version 0 after B's write: no 409
        assert s.version == 1
        bad = {"applied": MOVES[:1], "undone": [{"rotate": 1}]}
        assert err(a.put(f"/v1/sessions/{sid}/history", json=bad))["code"] == "invalid_request"
        with psycopg.connect(db, autocommit=True) as c:
            record, history, version = c.execute("SELECT record, history, version FROM tm_sessions WHERE id = %s",
                                                 (sid,)).fetchone()
        assert history == kept and "history" not in record and version == 1
        assert b.delete(f"/v1/sessions/{sid}").status_code == 204
        assert a.get(f"/v1/sessions/{sid}/history").status_code == 404


def test_a_database_outage_under_concurrent_moves_answers_only_503s_and_loses_nothing(tmp_path):
    """A real server and four clients sending MOVEs at once while the real PostgreSQL is stopped and
    started again: every answer is 200 or 503 (with Retry-After), the outage is seen and
    service resumes, and each session's version afterwards
    is the number of its MOVEs answered 200, its last MOVE the last of them: nothing lost, nothing doubled."""
    import tempfile
    import threading
    import time

    import httpx

    from service.client import Client
    from service.cluster.postgres import LocalPostgres
    from service.process import free_port, serve_process

    pg = LocalPostgres(tempfile.mkdtemp(prefix="tetmorph-pg-load-"), free_port(), fast=True)
    url = pg.start()
    try:
        env = {"TETMORPH_DATABASE_URL": url, "TETMORPH_RATE_LIMIT_PER_S": "0", "TETMORPH_LOAD_KERNELS": "0"}
        with serve_process(tmp_path / "data", env=env) as (base, _):
            with Client(base) as c:
                mid = c.upload_mesh(BRACKET)["id"]
                sids = [c.create_session(mid, BRACKET_SPEC)["id"] for _ in range(4)]
            answers: dict[str, list[tuple[int, dict]]] = {s: [] for s in sids}
            bad: list[str] = []
            # Driven by what was seen, bounded in time and count: the clients move until the outage has
            # been answered 503 and the service has answered 200 again after PostgreSQL restarted.
            deadline = time.monotonic() + 40.0
            restarted = threading.Event()
            lock = threading.Lock()

            def client(sid: str) -> None:
                after = 0
                with httpx.Client(base_url=base, timeout=30) as h:
                    for k in range(400):
                        if time.monotonic() > deadline or after >= 3:
                            return
                        move = {"handles": {"tip": {"translation": [0.0, 0.01 * (k + 1), 0.5]}}}
                        r = h.post(f"/v1/sessions/{sid}/deform?result=report", json=move)
                        with lock:
                            answers[sid].append((r.status_code, move))
                        if r.status_code == 503 and r.headers.get("retry-after") != "1":
                            bad.append(f"503 without Retry-After: {r.text[:200]}")
                        elif r.status_code not in (200, 503):
                            bad.append(f"{r.status_code}: {r.text[:200]}")
                        if restarted.is_set() and r.status_code == 200:
                            after += 1

            def seen(code: int) -> int:
                with lock:
                    return sum(1 for a in answers.values() for c, _ in a if c == code)

            def wait_for(cond, limit_s: float) -> None:
                end = time.monotonic() + limit_s
                while not cond() and time.monotonic() < end:
                    time.sleep(0.02)

            threads = [threading.Thread(target=client, args=(s,)) for s in sids]
            for t in threads:
                t.start()
            wait_for(lambda: seen(200) >= 8, 15.0)  # under load before the outage
            pg.stop()
            wait_for(lambda: seen(503) >= 4, 10.0)
            pg.start()
            restarted.set()
            for t in threads:
                t.join(timeout=60)
            assert not bad, bad[:5]
            codes = [code for a in answers.values() for code, _ in a]
            assert codes.count(503) > 0 and codes.count(200) > 0  # the outage was seen, and service resumed
            with Client(base, retries=6, backoff_s=0.5) as c:
                for sid, a in answers.items():
                    ok = [m for code, m in a if code == 200]
                    doc = c.session(sid)
                    assert doc["version"] == len(ok), (sid, doc["version"], len(ok))
                    assert doc["last_move"] == ok[-1]
    finally:
        pg.remove()


def test_a_session_deleted_on_one_replica_is_never_brought_back_by_the_other(tmp_path, db):
    """Delete on A; on B a MOVE, a stream frame, a batch, a read, a build failure recorded while the delete
    lands, and a restart: each answers 404 (or writes nothing), and no row of the session comes back."""
    import json
    import threading
    import time

    from starlette.websockets import WebSocketDisconnect

    from service.client import Client
    from service.state.session import SessionStatus

    def rows(sid: str) -> int:
        with psycopg.connect(db, autocommit=True) as c:
            return int(c.execute("SELECT count(*) FROM tm_sessions WHERE id = %s", (sid,)).fetchone()[0])

    with replicas(tmp_path, db, rate_limit_per_s=0) as (a, b):
        ca, cb = Client(http=a), Client(http=b)
        mid = ca.upload_mesh(BRACKET)["id"]
        sid = ca.create_session(mid, BRACKET_SPEC)["id"]
        cb.deform(sid, MOVES[0])  # B holds a built copy
        with b.websocket_connect(f"/v1/sessions/{sid}/stream") as ws:
            assert a.delete(f"/v1/sessions/{sid}").status_code == 204
            ws.send_text(json.dumps({"seq": 1, "move": MOVES[1]}))
            with pytest.raises(WebSocketDisconnect) as closed:
                ws.receive_text()
            assert closed.value.code == 4404
        for r in (b.post(f"/v1/sessions/{sid}/deform", json=MOVES[1]), b.get(f"/v1/sessions/{sid}"),
                  b.post(f"/v1/sessions/{sid}/batch", json={"shapes": {"shapes": []}, "plan": "x\n1\n"})):
            assert r.status_code == 404 and err(r)["code"] == "session_not_found", r.text
        with pytest.raises(WebSocketDisconnect) as closed:
            with b.websocket_connect(f"/v1/sessions/{sid}/stream") as ws:
                ws.receive_text()
        assert closed.value.code == 4404
        assert rows(sid) == 0

        # B records a build failure of its copy of another session while A's DELETE of it is in flight
        # (its transaction holds the row): the record must not come back once the DELETE commits
        sid2 = ca.create_session(mid, BRACKET_SPEC)["id"]
        assert b.get(f"/v1/sessions/{sid2}").status_code == 200
        reg_b = b.app.state.registry
        s = reg_b.sessions[sid2]
        s.status, s.error = SessionStatus.failed, {"type": "SolverError", "code": "build_failed",
                                                   "message": "x", "details": {}}
        with psycopg.connect(db) as deleting:
            deleting.execute("DELETE FROM tm_sessions WHERE id = %s", (sid2,))  # not committed yet
            t = threading.Thread(target=reg_b.sessions._failed, args=(s,))
            t.start()
            deadline = time.monotonic() + 20
            with psycopg.connect(db, autocommit=True) as watch:  # until B's write waits for the row's lock
                while time.monotonic() < deadline and t.is_alive() and not watch.execute(
                        "SELECT count(*) FROM pg_stat_activity WHERE wait_event_type = 'Lock'").fetchone()[0]:
                    time.sleep(0.05)
            deleting.commit()
            t.join(20)
        assert not t.is_alive() and rows(sid2) == 0
    with running(tmp_path / "data", database_url=db, replica_id="C") as c:  # a restart lists neither
        assert [x["id"] for x in c.get("/v1/sessions").json()] == []
        assert c.get(f"/v1/sessions/{sid}").status_code == 404
