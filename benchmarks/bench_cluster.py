"""Cluster figures: throughput and latency through HAProxy with 1 and 3 replicas, the balancer's overhead
against a direct connection, failover time after kill -9, and DOE rows/s on Ray with 1 and 2 actors.

    python benchmarks/bench_cluster.py [--seconds 8] [--clients 6] [--repeat 2] [--ray]

Everything runs on 127.0.0.1 (PostgreSQL, HAProxy, replicas, a local Ray); loops are bounded in time.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import threading
import time
from pathlib import Path

import httpx
import numpy as np

from service.cluster.local import LocalCluster

ROOT = Path(__file__).resolve().parents[1]
BRACKET = ROOT / "tests" / "data" / "bracket.inp"
SPEC = {"selections": {"root": {"set": "FIXED"}, "tip": {"set": "LOAD"}}, "fixed": ["root"], "handles": {"tip": "tip"}}


def move(t: float) -> dict:
    return {"handles": {"tip": {"translation": [0.0, 0.5 * t, t]}}}


def sessions(url: str, n: int) -> list[str]:
    with httpx.Client(base_url=url, timeout=120) as c:
        mid = c.post("/v1/meshes", files=[("file", ("bracket.inp", BRACKET.read_bytes()))]).json()["id"]
        ids = [c.post("/v1/sessions", json={"mesh_id": mid, "spec": SPEC}).json()["id"] for _ in range(n)]
        for sid in ids:  # built where the ring puts them
            assert c.post(f"/v1/sessions/{sid}/deform?result=report", json=move(0.1)).status_code == 200
        return ids


def load(url: str, ids: list[str], seconds: float) -> tuple[float, float, float]:
    """Each client streams MOVEs on its own session: (updates/s, p50 ms, p95 ms)."""
    lat: list[float] = []
    end = time.monotonic() + seconds

    def client(sid: str) -> None:
        with httpx.Client(base_url=url, timeout=60) as c:
            k = 0
            while time.monotonic() < end:
                t0 = time.perf_counter()
                r = c.post(f"/v1/sessions/{sid}/deform?result=report", json=move(0.01 * (k % 100)))
                if r.status_code == 200:
                    lat.append(1e3 * (time.perf_counter() - t0))
                k += 1

    t0 = time.monotonic()
    threads = [threading.Thread(target=client, args=(sid,)) for sid in ids]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    dt = time.monotonic() - t0
    return len(lat) / dt, float(np.percentile(lat, 50)), float(np.percentile(lat, 95))


def failover(c: LocalCluster, sid: str) -> tuple[float, str]:
    with httpx.Client(base_url=c.url, timeout=60) as h:
        owner = h.get(f"/v1/sessions/{sid}").headers["x-tetmorph-replica"]
        c.kill(owner)
        t0 = time.monotonic()
        while time.monotonic() - t0 < 60:
            try:
                r = h.post(f"/v1/sessions/{sid}/deform?result=report", json=move(0.2))
                if r.status_code == 200:
                    return time.monotonic() - t0, owner
            except httpx.TransportError:
                pass
            time.sleep(0.02)
    raise RuntimeError("no failover within 60 s")


def bench_replicas(args: argparse.Namespace) -> None:
    rows: dict[str, list[tuple[float, float, float]]] = {}
    fail: list[float] = []
    for _ in range(args.repeat):
        for n in (1, 3):
            c = LocalCluster(tempfile.mkdtemp(prefix="tetmorph-bench-"), replicas=n, fast_pg=True,
                             env={"TETMORPH_RATE_LIMIT_PER_S": "0", "TETMORPH_MAX_SESSIONS": "100"})
            try:
                c.start()
                ids = sessions(c.url, args.clients)
                rows.setdefault(f"balancer, {n} replica{'s' if n > 1 else ''}", []).append(
                    load(c.url, ids, args.seconds))
                if n == 1:
                    rows.setdefault("direct, 1 replica", []).append(load(c.replica_url("r1"), ids, args.seconds))
                else:
                    fail.append(failover(c, ids[0])[0])
            finally:
                c.stop()
                c.pg.remove()
    print(f"\n{args.clients} clients, each streaming MOVEs (result=report) on its own bracket session "
          f"(4,228 tets), {args.seconds:g} s per run, {args.repeat} runs; median [min, max] of the runs")
    print("| path | updates/s | p50 ms | p95 ms |\n|---|---:|---:|---:|")
    for name, rs in rows.items():
        cols = []
        for k in range(3):
            v = [r[k] for r in rs]
            cols.append(f"{statistics.median(v):.1f} [{min(v):.1f}, {max(v):.1f}]")
        print(f"| {name} | " + " | ".join(cols) + " |")
    print(f"failover after kill -9 of the session's replica, to the first committed MOVE elsewhere (rebuild "
          f"included): {', '.join(f'{x:.2f}' for x in fail)} s")


def bench_ray(args: argparse.Namespace) -> None:
    from solver import read_mesh
    from solver.deform.deformer import Deformer
    from solver.workflows import deck_writer, parse_plan, parse_shapes, run_doe
    from solver.workflows.ray_engine import connect, run_doe_ray
    from tests.solver.workflows.conftest import PLATE, plate_shapes, plate_spec

    rows = 96
    t = np.linspace(-1.0, 1.0, rows)
    plan = parse_plan([[a, a / 2, -a, a / 3] for a in t], ["bend", "hole1_x", "hole2_y", "upper_x"])
    mesh = read_mesh(PLATE)
    out = Path(tempfile.mkdtemp(prefix="tetmorph-bench-ray-"))
    local = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        d = Deformer(mesh, plate_spec())
        run_doe(d, parse_shapes(plate_shapes(), d), plan, block=16, output=deck_writer(mesh, str(out / "l_{i}.inp")))
        local.append(time.perf_counter() - t0)
    ray, _ = connect(None, num_cpus=2)
    res: dict[int, list[float]] = {1: [], 2: []}
    for _ in range(args.repeat):
        for n in (1, 2):
            t0 = time.perf_counter()
            run_doe_ray(mesh, plate_spec(), plate_shapes(), plan, output=str(out / f"r{n}_{{i}}.inp"), block=16,
                        actors=n)
            res[n].append(time.perf_counter() - t0)
    ray.shutdown()
    print(f"\nDOE of {rows} plate variants (block 16, decks written), set-up included; median [min, max] of "
          f"{args.repeat} runs")
    print("| engine | wall s | rows/s | ms per variant |\n|---|---:|---:|---:|")
    for name, v in (("single process", local), ("Ray, 1 actor", res[1]), ("Ray, 2 actors", res[2])):
        m = statistics.median(v)
        print(f"| {name} | {m:.2f} [{min(v):.2f}, {max(v):.2f}] | {rows / m:.1f} | {1e3 * m / rows:.1f} |")


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--seconds", type=float, default=8.0)
    p.add_argument("--clients", type=int, default=6)
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--ray", action="store_true", help="also the Ray DOE table")
    p.add_argument("--no-replicas", action="store_true")
    args = p.parse_args()
    if not args.no_replicas:
        bench_replicas(args)
    if args.ray:
        bench_ray(args)


if __name__ == "__main__":
    main()
