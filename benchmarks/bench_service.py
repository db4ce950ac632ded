"""Service round trip over loopback vs the library, and concurrent clients.

1. One ~100k-tet session (the gmsh bracket of tests/data/make_bracket.py at
   mesh size 0.95, FIXED end fixed, LOAD end moved): median update time of the
   library (``Deformer.solve``, solve + inversion check, in this process) and
   the median HTTP round trip of ``POST /deform`` with the binary float64 body
   (``service.client.Client.deform``) against ``tetmorph serve`` on 127.0.0.1.
   Target: round trip <= 1.3 x library + 5 ms.
2. ``--clients`` threads, each with its own session on the same mesh, each
   sending ``--updates`` MOVEs back to back: errors, throughput, p50 and p95
   latency, and the server's peak RSS (VmHWM).

    python benchmarks/bench_service.py [--size 0.95] [--updates 100] [--clients 20]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from service.client import Client  # noqa: E402
from service.process import serve_process  # noqa: E402
from solver import read_mesh  # noqa: E402
from solver.deform.deformer import precompute  # noqa: E402
from tests.data.make_bracket import make_bracket  # noqa: E402

SPEC = {"selections": {"root": {"set": "FIXED"}, "tip": {"set": "LOAD"}},
        "fixed": ["root"], "handles": {"tip": "tip"}}


def move(k: int) -> dict:
    a = 5.0 + (k % 10)
    return {"handles": {"tip": {"translation": [0.0, 0.5 * (k % 7), 2.0],
                                "rotation": {"axis": [1, 0, 0], "angle_deg": a}}}}


def vm_hwm_gb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 2**20
    return float("nan")


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--size", type=float, default=0.95, help="gmsh MeshSizeMax of the bracket")
    p.add_argument("--updates", type=int, default=100)
    p.add_argument("--clients", type=int, default=20)
    p.add_argument("--round-trips", type=int, default=50)
    a = p.parse_args()
    work = Path(tempfile.mkdtemp(prefix="tetmorph-bench-"))
    deck = work / "bracket.inp"
    make_bracket(a.size, str(deck))
    mesh = read_mesh(deck)
    print(f"mesh: {deck.name}, {mesh.T.shape[0]} tets, {mesh.n} vertices", flush=True)

    d = precompute(mesh, SPEC)
    lib = []
    for k in range(a.round_trips):
        t0 = time.perf_counter()
        r = d.solve(move(k))
        lib.append(1e3 * (time.perf_counter() - t0))
    V_lib = r.V
    del d

    env = {"TETMORPH_RATE_LIMIT_PER_S": "0", "TETMORPH_MAX_SESSIONS": str(a.clients + 4),
           "TETMORPH_SOLVE_WORKERS": "2"}
    with serve_process(work / "data", env=env) as (url, proc), Client(url) as c:
        mid = c.upload_mesh(deck)["id"]
        sid = c.create_session(mid, SPEC)["id"]
        c.deform(sid, move(0))  # warm-up
        rt = []
        for k in range(a.round_trips):
            t0 = time.perf_counter()
            X, _ = c.deform(sid, move(k))
            rt.append(1e3 * (time.perf_counter() - t0))
        assert np.abs(X - V_lib).max() < 1e-9, "service and library disagree"
        lib_ms, rt_ms = statistics.median(lib), statistics.median(rt)
        print("\n| tets | library update ms (median) | HTTP round trip ms, binary f64 (median) "
              "| target 1.3 x lib + 5 ms | met |")
        print("|---:|---:|---:|---:|:-:|")
        target = 1.3 * lib_ms + 5
        print(f"| {mesh.T.shape[0]} | {lib_ms:.1f} | {rt_ms:.1f} | {target:.1f} | "
              f"{'yes' if rt_ms <= target else 'no'} |", flush=True)

        t0 = time.perf_counter()
        sessions = [c.create_session(mid, SPEC)["id"] for _ in range(a.clients)]
        build_s = time.perf_counter() - t0
        lat: list[float] = []
        errors: list[str] = []
        lock = threading.Lock()

        def worker(sid: str, seed: int) -> None:
            with Client(url) as cc:
                for k in range(a.updates):
                    t = time.perf_counter()
                    try:
                        cc.deform(sid, move(seed + k))
                    except Exception as e:  # noqa: BLE001 - counted and reported
                        with lock:
                            errors.append(repr(e))
                        continue
                    with lock:
                        lat.append(1e3 * (time.perf_counter() - t))

        threads = [threading.Thread(target=worker, args=(s, i)) for i, s in enumerate(sessions)]
        t0 = time.perf_counter()
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        wall = time.perf_counter() - t0
        health = c.http.get("/health").json()
        peak = vm_hwm_gb(proc.pid)
        q = np.percentile(lat, [50, 95]) if lat else [float("nan")] * 2
        print(f"\n| clients x updates | errors | build {a.clients} sessions s | throughput "
              "updates/s | p50 ms | p95 ms | server peak RSS GB | cached sessions |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|")
        print(f"| {a.clients} x {a.updates} | {len(errors)} | {build_s:.1f} | "
              f"{len(lat) / wall:.1f} | {q[0]:.1f} | {q[1]:.1f} | {peak:.2f} | "
              f"{health['cached_sessions']} |")
        if errors:
            print("first errors:", errors[:3])


if __name__ == "__main__":
    main()
