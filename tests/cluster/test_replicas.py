"""Three replicas behind HAProxy on one PostgreSQL, all real and on 127.0.0.1.

The module's tests run in order on one cluster: sessions spread and stick,
``kill -9`` of a replica while clients stream MOVEs, two clients racing on one
session through two replicas, and the killed replica restarted with nothing
in memory.
"""

from __future__ import annotations

import collections
import tempfile
import threading
import time
from typing import Any

import httpx
import numpy as np
import psycopg
import pytest

from service.cluster.local import LocalCluster
from solver import read_mesh
from solver.deform.deformer import Deformer

from ..service.conftest import BRACKET, BRACKET_SPEC

SESSIONS = 20
#: Every client loop ends by this many seconds, whatever happens.
CLIENT_LIMIT_S = 60.0


@pytest.fixture(scope="module")
def cluster():
    c = LocalCluster(tempfile.mkdtemp(prefix="tetmorph-cluster-"), replicas=3, fast_pg=True,
                     env={"TETMORPH_RATE_LIMIT_PER_S": "0", "TETMORPH_MAX_SESSIONS": "100"})
    try:
        c.start()
        yield c
    finally:
        c.stop()
        c.pg.remove()


@pytest.fixture(scope="module")
def library():
    return Deformer(read_mesh(BRACKET), BRACKET_SPEC)


@pytest.fixture(scope="module")
def sessions(cluster) -> list[str]:
    with httpx.Client(base_url=cluster.url, timeout=60) as c:
        mid = c.post("/v1/meshes", files=[("file", ("bracket.inp", BRACKET.read_bytes()))]).json()["id"]
        out = []
        for _ in range(SESSIONS):
            r = c.post("/v1/sessions", json={"mesh_id": mid, "spec": BRACKET_SPEC})
            assert r.status_code in (201, 202), r.text
            out.append(r.json()["id"])
        return out


def move(t: float) -> dict[str, Any]:
    return {"handles": {"tip": {"translation": [0.0, 0.5 * t, t]}}}


def owner_of(c: httpx.Client, sid: str) -> str:
    return c.get(f"/v1/sessions/{sid}").headers["x-tetmorph-replica"]


def test_sessions_spread_over_the_replicas_and_each_is_served_by_one(cluster, sessions):
    seen: dict[str, set[str]] = collections.defaultdict(set)
    with httpx.Client(base_url=cluster.url, timeout=60) as c:
        for k in range(3):
            for sid in sessions:
                for r in (c.get(f"/v1/sessions/{sid}"),
                          c.post(f"/v1/sessions/{sid}/deform?result=report", json=move(0.1 * (k + 1))),
                          c.get(f"/v1/sessions/{sid}/positions?result=binary")):
                    assert r.status_code == 200, r.text
                    seen[sid].add(r.headers["x-tetmorph-replica"])
    assert all(len(v) == 1 for v in seen.values()), seen
    spread = collections.Counter(next(iter(v)) for v in seen.values())
    assert set(spread) == {"r1", "r2", "r3"}, spread


def commit_until_done(c: httpx.Client, sid: str, mv: dict[str, Any], deadline: float) -> httpx.Response:
    """POST a MOVE until it commits (502/503 while the ring changes, 409 after a reload), bounded in time."""
    while True:
        try:
            r = c.post(f"/v1/sessions/{sid}/deform?result=report", json=mv)
            if r.status_code == 200:
                return r
            assert r.status_code in (409, 502, 503, 504), r.text
        except httpx.TransportError:
            pass
        assert time.monotonic() < deadline, f"session {sid}: no commit before the deadline"
        time.sleep(0.05)


def test_kill_9_of_a_replica_loses_nothing_committed(cluster, sessions, library):
    with httpx.Client(base_url=cluster.url, timeout=60) as c:
        owners = {sid: owner_of(c, sid) for sid in sessions}
    victim = collections.Counter(owners.values()).most_common(1)[0][0]
    last: dict[str, float] = {}
    errors: list[BaseException] = []
    deadline = time.monotonic() + CLIENT_LIMIT_S
    stop = threading.Event()

    def client(mine: list[str]) -> None:
        try:
            with httpx.Client(base_url=cluster.url, timeout=30) as c:
                for k in range(1, 200):
                    if stop.is_set():
                        return
                    for sid in mine:
                        t = round(k * 0.05, 3)
                        commit_until_done(c, sid, move(t), deadline)
                        last[sid] = t
        except BaseException as e:  # noqa: BLE001 - reported by the test
            errors.append(e)

    threads = [threading.Thread(target=client, args=(sessions[i::4],)) for i in range(4)]
    for th in threads:
        th.start()
    time.sleep(2.0)
    cluster.kill(victim)
    killed_at = time.monotonic()
    time.sleep(6.0)
    stop.set()
    for th in threads:
        th.join(CLIENT_LIMIT_S)
    assert not errors, errors
    assert all(not th.is_alive() for th in threads)
    with psycopg.connect(cluster.pg.url) as db:
        stored = dict(db.execute("SELECT id, record -> 'last_move' FROM tm_sessions").fetchall())
    moved = 0
    with httpx.Client(base_url=cluster.url, timeout=60) as c:
        for sid in sessions:
            assert stored[sid] == move(last[sid]), sid  # the last MOVE each client saw committed is the record's
            r = c.get(f"/v1/sessions/{sid}/positions")
            assert r.status_code == 200 and r.headers["x-tetmorph-replica"] != victim
            np.testing.assert_allclose(np.asarray(r.json()["positions"]), library.solve(move(last[sid])).V,
                                       atol=1e-9)
            moved += owners[sid] == victim
    assert moved >= 1
    print(f"killed {victim} ({moved} sessions) {time.monotonic() - killed_at:.1f} s before the check")


def test_two_clients_racing_through_two_replicas_never_diverge(cluster, sessions, library):
    sid = sessions[0]
    alive = [n for n in cluster.names() if cluster.procs[n].poll() is None]
    a, b = alive[:2]
    results: dict[str, list[tuple[int, float]]] = {a: [], b: []}
    conflicts = collections.Counter()
    deadline = time.monotonic() + CLIENT_LIMIT_S

    def client(name: str, offset: float) -> None:
        with httpx.Client(base_url=cluster.replica_url(name), timeout=30) as c:
            for k in range(25):
                if time.monotonic() > deadline:
                    return
                t = offset + 0.01 * k
                r = c.post(f"/v1/sessions/{sid}/deform?result=report", json=move(t))
                if r.status_code == 409:
                    conflicts[name] += 1
                    assert r.json()["error"]["code"] == "version_conflict"
                    continue
                assert r.status_code == 200, r.text
                results[name].append((int(r.headers["x-tetmorph-version"]), t))

    threads = [threading.Thread(target=client, args=(a, 1.0)), threading.Thread(target=client, args=(b, 2.0))]
    for th in threads:
        th.start()
    for th in threads:
        th.join(CLIENT_LIMIT_S)
    commits = sorted(results[a] + results[b])
    versions = [v for v, _ in commits]
    assert len(set(versions)) == len(versions), "two commits share a version"
    with psycopg.connect(cluster.pg.url) as db:
        version, stored = db.execute("SELECT version, record -> 'last_move' FROM tm_sessions WHERE id = %s",
                                     (sid,)).fetchone()
    assert version == versions[-1] and stored == move(commits[-1][1])
    want = library.solve(move(commits[-1][1])).V
    for name in (a, b):
        r = httpx.get(f"{cluster.replica_url(name)}/v1/sessions/{sid}/positions", timeout=30)
        assert int(r.headers["x-tetmorph-version"]) == version
        np.testing.assert_allclose(np.asarray(r.json()["positions"]), want, atol=1e-9)
    print(f"{len(commits)} commits, conflicts {dict(conflicts)}")


def test_a_restarted_replica_with_an_empty_cache_serves_everything(cluster, sessions, library):
    dead = [n for n in cluster.names() if cluster.procs[n].poll() is not None]
    assert len(dead) == 1
    cluster.start_replica(dead[0])
    cluster.wait_ring(cluster.names())
    with psycopg.connect(cluster.pg.url) as db:
        stored = dict(db.execute("SELECT id, record -> 'last_move' FROM tm_sessions").fetchall())
    direct = httpx.Client(base_url=cluster.replica_url(dead[0]), timeout=60)
    balanced = httpx.Client(base_url=cluster.url, timeout=60)
    assert direct.get("/health").json()["sessions"] == 0
    for sid in sessions:
        want = library.solve(stored[sid]).V
        for c in (direct, balanced):
            r = c.get(f"/v1/sessions/{sid}/positions")
            assert r.status_code == 200, r.text
            np.testing.assert_allclose(np.asarray(r.json()["positions"]), want, atol=1e-9)
    assert direct.get("/health").json()["sessions"] == SESSIONS
    direct.close()
    balanced.close()


def test_a_database_outage_takes_the_replicas_out_of_the_pool_with_503_and_retry_after(cluster, sessions):
    """PostgreSQL stopped under the real balancer: every answer is a 503 with Retry-After, first from the
    replicas, then from HAProxy once each replica's /ready failed; after the restart they rejoin and serve."""
    sid = sessions[0]
    with httpx.Client(base_url=cluster.url, timeout=10) as c:
        assert c.get(f"/v1/sessions/{sid}").status_code == 200
        cluster.pg.stop()
        try:
            for path in (f"/v1/sessions/{sid}", "/v1/sessions"):  # each backend: by session, round-robin
                balancer = None
                deadline = time.monotonic() + 30  # two failed checks 250-500 ms apart take a replica out
                while balancer is None and time.monotonic() < deadline:
                    r = c.get(path)
                    assert r.status_code == 503 and r.headers.get("retry-after") == "1", (path, r.text[:300])
                    if "x-tetmorph-replica" not in r.headers:  # HAProxy's own answer: no replica in the pool
                        balancer = r
                    else:
                        assert r.json()["error"]["code"] == "store_unavailable", r.text
                        time.sleep(0.1)
                assert balancer is not None, f"the replicas never left the pool of {path}"
                e = balancer.json()["error"]
                assert e["status"] == 503 and e["code"] == "unavailable" and "/ready" in e["message"], e
            for name in cluster.names():  # the replicas live, not ready
                assert httpx.get(cluster.replica_url(name) + "/health", timeout=10).status_code == 200
                assert httpx.get(cluster.replica_url(name) + "/ready", timeout=10).status_code == 503
        finally:
            cluster.pg.start()
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            r = c.get(f"/v1/sessions/{sid}")
            if r.status_code == 200:
                break
            assert r.status_code == 503, r.text[:300]
            time.sleep(0.2)
        assert r.status_code == 200 and r.json()["id"] == sid and "x-tetmorph-replica" in r.headers
