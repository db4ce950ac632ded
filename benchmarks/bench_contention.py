"""Per-update cost under load: tetmorph against the harmonic peer, quiet, beside busy processes, and concurrent.

The comparison of ``bench_update.py`` (same bracket decks, same fixed and
handle vertices, same six MOVEs, the same harmonic k = 1 peer with CHOLMOD's
own solve), run under four loads:

``quiet``
    nothing else running (as ``bench_update.py``).
``busy``
    ``--busy`` processes (default: one per core this process may run on) that
    spin for the whole measurement, as another job on a shared workstation or
    CI runner does. They are started after set-up and killed when the
    measurement ends; each also stops by itself after ``--busy-limit`` seconds.
``s2``, ``s4``
    2 and 4 threads of this process solving at once on one precompute, as the
    service does for concurrent sessions on one mesh (the peer: its one CHOLMOD
    factor, likewise).

Each (size, case, repeat) is a process of its own that sets up once and then
measures every load in turn; cases alternate, repeats follow each other. An
update's time is the wall time of one call as its caller sees it (for
tetmorph ``Deformer.solve``, REPORT and element check included; for the peer
parse, right-hand side, back-substitution and positions), median over the
calls after a warm pass; ``sN`` takes every thread's calls. The table gives
the median [min-max] over repeats and the ratio to the peer measured under
the same load, in the same run, and ``solves in flight`` reports the most
tetmorph solves that ran at once (``solver.linalg.threads.in_flight``).

    python benchmarks/bench_contention.py [--sizes 0.95,0.44] [--repeats 3] [--loads quiet,busy,s2,s4]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_update import SPEC, Harmonic, _moves  # noqa: E402

LOADS = ("quiet", "busy", "s2", "s4")
#: What a busy process runs until killed or ``sys.argv[1]`` seconds have passed (``--busy-kind``).
BUSY = {
    # a single-threaded compute job
    "spin": "import sys, time\nend = time.monotonic() + float(sys.argv[1])\nwhile time.monotonic() < end:\n    pass\n",
    # a multi-threaded OpenMP job with libgomp's default spin waits (another OpenMP or MKL program): the
    # compiled core's rotation loop, imported without solver (whose import bounds the spin waits)
    "omp": ("import os, sys, time\nfor k in ('GOMP_SPINCOUNT', 'OMP_WAIT_POLICY'):\n    os.environ.pop(k, None)\n"
            "import numpy as np, tetmorph_core\n"
            "v = np.random.rand(200_000, 3); r = 0.1 * np.random.rand(200_000, 3); out = np.empty_like(v)\n"
            "f = np.ones(1)\nend = time.monotonic() + float(sys.argv[1])\n"
            "while time.monotonic() < end:\n    tetmorph_core.geometry_rotate_by_log(v, r, f, True, out)\n"
            "    time.sleep(0.0005)\n"),
    # a memory-bandwidth job (array copies of 256 MB)
    "memory": ("import sys, time\nimport numpy as np\na = np.ones(2**25)\nb = np.empty_like(a)\n"
               "end = time.monotonic() + float(sys.argv[1])\nwhile time.monotonic() < end:\n    np.copyto(b, a)\n"),
}


def cores() -> int:
    """Cores this process may run on."""
    return len(os.sched_getaffinity(0))


def timed_calls(update, docs: list[dict], threads: int) -> list[float]:
    """Milliseconds per call of ``update`` over ``docs``, by ``threads`` threads at once (each all of ``docs``)."""
    out: list[float] = []
    lock = threading.Lock()
    start = threading.Barrier(threads)

    def worker(shift: int) -> None:
        mine = []
        start.wait()
        for doc in docs[shift:] + docs[:shift]:  # threads start on different MOVEs
            t = time.perf_counter()
            update(doc)
            mine.append(1e3 * (time.perf_counter() - t))
        with lock:
            out.extend(mine)

    ts = [threading.Thread(target=worker, args=(j,)) for j in range(threads)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    return out


def measure(size: float, case: str, loads: list[str], moves: int, passes: int, busy: int, limit: float,
            kind: str = "spin") -> dict:
    from bench_solver import bracket_deck

    deck = bracket_deck(size)
    if case == "harmonic":
        h = Harmonic(deck)
        setup_s, update, tets = h.setup_s, h.update, None
    else:
        from solver import precompute, read_mesh
        from solver.linalg import threads as th

        mesh = read_mesh(deck)
        t0 = time.perf_counter()
        d = precompute(mesh, {**SPEC, "precision": "mixed"})
        setup_s, update, tets = time.perf_counter() - t0, d.solve, int(len(mesh.T))
    docs = _moves(moves)
    for doc in docs:  # warm: first calls, page touches
        update(doc)
    out: dict = {"setup_s": setup_s, "tets": tets}
    for load in loads:
        procs = []
        if load == "busy":
            procs = [subprocess.Popen([sys.executable, "-c", BUSY[kind], str(limit)]) for _ in range(busy)]
            time.sleep(0.3)  # let them reach the loop
        if case != "harmonic" and hasattr(th, "in_flight_reset"):  # (older tetmorph: no counter)
            th.in_flight_reset()
        try:
            s = int(load[1:]) if load.startswith("s") else 1
            ms = timed_calls(update, docs * passes, s)
        finally:
            for p in procs:
                p.kill()
                p.wait()
        out[load] = {"median_ms": float(np.median(ms)), "p90_ms": float(np.percentile(ms, 90)), "calls": len(ms)}
        if case != "harmonic":
            out[load]["in_flight_max"] = th.in_flight_peak() if hasattr(th, "in_flight_peak") else 0
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="0.95,0.44")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--loads", default=",".join(LOADS))
    p.add_argument("--moves", type=int, default=6)
    p.add_argument("--passes", type=int, default=4, help="passes over the MOVEs per load and thread")
    p.add_argument("--busy", type=int, default=cores(), help="busy processes of the busy load (default: cores)")
    p.add_argument("--busy-kind", default="spin", choices=sorted(BUSY), help="what each busy process runs")
    p.add_argument("--busy-limit", type=float, default=600.0, help="seconds after which a busy process stops itself")
    p.add_argument("--case", help=argparse.SUPPRESS)
    a = p.parse_args()
    loads = a.loads.split(",")
    bad = sorted(set(loads) - set(LOADS))
    if bad:
        p.error(f"unknown loads {bad}; use {list(LOADS)}")
    if a.case:
        size, case = a.case.split(":")
        r = measure(float(size), case, loads, a.moves, a.passes, a.busy, a.busy_limit, a.busy_kind)
        print(json.dumps(r))
        return
    from bench_solver import bracket_deck

    print(f"{cores()} cores; busy load: {a.busy} {a.busy_kind} processes; s2, s4: threads solving at once")
    for size in a.sizes.split(","):
        bracket_deck(float(size))
        runs: dict[str, list[dict]] = {"harmonic": [], "tetmorph": []}
        for _ in range(a.repeats):
            for case in runs:
                cmd = [sys.executable, __file__, "--case", f"{size}:{case}", "--loads", a.loads, "--moves",
                       str(a.moves), "--passes", str(a.passes), "--busy", str(a.busy), "--busy-limit",
                       str(a.busy_limit), "--busy-kind", a.busy_kind]
                r = subprocess.run(cmd, capture_output=True, text=True)
                if r.returncode != 0:
                    print(f"{case} {size} failed: {(r.stderr.strip().splitlines() or ['?'])[-1]}")
                    continue
                runs[case].append(json.loads(r.stdout.strip().splitlines()[-1]))
        tets = next((r["tets"] for r in runs["tetmorph"] if r.get("tets")), 0)
        print(f"\nbracket, {tets:,} tets (gmsh size {size}); per update, median [min-max] over {a.repeats} runs")
        print("| load | harmonic ms | tetmorph ms | ratio | tetmorph p90 ms | solves in flight |")
        print("|---|---:|---:|---:|---:|---:|")

        def spread(v: list[float]) -> str:
            return f"{np.median(v):.1f} [{min(v):.1f}-{max(v):.1f}]" if v else "-"

        for load in loads:
            h = [r[load]["median_ms"] for r in runs["harmonic"]]
            t = [r[load]["median_ms"] for r in runs["tetmorph"]]
            p90 = [r[load]["p90_ms"] for r in runs["tetmorph"]]
            fl = max((r[load]["in_flight_max"] for r in runs["tetmorph"]), default=0)
            ratio = f"{np.median(t) / np.median(h):.2f}" if h and t else "-"
            print(f"| {load} | {spread(h)} | {spread(t)} | {ratio} | {spread(p90)} | {fl} |")
        hs = [r["setup_s"] for r in runs["harmonic"]]
        ts = [r["setup_s"] for r in runs["tetmorph"]]
        if hs and ts:
            print(f"set-up (quiet): harmonic {np.median(hs):.2f} s, tetmorph {np.median(ts):.2f} s")


if __name__ == "__main__":
    main()
