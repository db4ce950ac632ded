"""Per-update cost of tetmorph against a harmonic (k = 1) solve of the same mesh, side by side.

The peer is libigl-style harmonic deformation: ``igl.cotmatrix(V, T)``, ``Q = -L``,
the fixed and handle rows eliminated, one CHOLMOD factor of ``Q_uu``, and per
update ``D_u = Q_uu^{-1} (-Q_ub D_b)`` for the three coordinates of the
displacements. It is computed here, with the same fixed and handle vertices
and the same targets as tetmorph (handle vertices rotated and translated
about their centroid). Each case runs in its own process (its own peak RSS);
cases alternate and repeat, and the table gives the median and the spread.

Meshes: the CAD bracket of ``tests/data/make_bracket.py`` at gmsh sizes
``--sizes 0.95,0.44`` (107k and 1.03M tets). Cases (``--cases``):

``harmonic``       the peer
``mixed``          tetmorph's default (single-precision interior factor, residual checked)
``pardiso``        ``mixed`` with PARDISO's and CHOLMOD's own solves at every size
                   (``SolveOptions(sweeps=False)``; the default back-substitutes by the
                   supernodal sweeps of :mod:`solver.linalg.supernodal`)
``exact``          tetmorph with ``precision: "exact"`` (double-precision interior factor)
``many``           tetmorph ``solve_many`` of the same moves, per-move cost
``boundary``       tetmorph ``solve_boundary``: the boundary frame of the editor's stream

An update's time is what its REPORT times: ``rhs_ms + solve_ms + check_ms +
report_ms`` (``check_ms`` is the element check alone, ``report_ms`` the rest
of the REPORT: constraint residuals, displacement, targets).

Each process first loads its compiled code, timed as ``load``: the peer's
``import igl`` (numpy and scipy already imported), tetmorph's
``import solver`` and :func:`solver.load_kernels` (the compiled core, the
modules and document models of a set-up: what the service does at start),
numpy and scipy imported before either is timed. Both load from compiled bytecode, as an
installed package does (pip compiles it at install; a checkout writes ``__pycache__`` on first
import): the run compiles ``solver`` first, since an environment with ``PYTHONDONTWRITEBYTECODE``
would otherwise leave a checkout compiling its changed modules in every process. Set-up is then
timed twice: ``setup`` is the first in the process, ``warm setup`` a second set-up of the same mesh in the same
process, as a running service sets up every new session. ``cold ratio``
compares load + first set-up, the one-off cost of a pipeline that sets up
one mesh per process.

Also printed: this machine's read bandwidth (a pass over a 1 GB array, in this
process) and each solve's memory-traffic floor (bytes of factor read per
update over that bandwidth).

    python benchmarks/bench_update.py [--sizes 0.95,0.44] [--repeats 3] [--moves 6]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def _moves(k: int) -> list[dict]:
    return [{"handles": {"top": {"translation": [10.0 * (j + 1) / k, 0, 0],
                                 "rotation": {"axis": [0, 1, 0], "angle_deg": 20.0 * (j + 1) / k}}}}
            for j in range(k)]


SPEC = {"selections": {"bottom": {"set": "FIXED"}, "top": {"set": "LOAD"}}, "fixed": ["bottom"],
        "handles": {"top": "top"}}


def bandwidth_gbs() -> float:
    """Read bandwidth of this machine: the best of 5 sums over a 1 GB float32 array."""
    a = np.ones(2**28, np.float32)
    best = 0.0
    for _ in range(5):
        t = time.perf_counter()
        a.sum()
        best = max(best, a.nbytes / (time.perf_counter() - t) / 1e9)
    return best


class CholmodMetis:
    """The peer's factor: CHOLMOD as its users call it (supernodal, its own METIS ordering).

    The same as tetmorph's CHOLMOD factor before that took its ordering from
    ``solver/linalg/ordering.py``, so that the peer's figures stay comparable.
    """

    def __init__(self, M) -> None:
        from sksparse.cholmod import cholesky

        from solver.linalg import factorization as fz

        fz._quiet_system_blas()  # one thread for the system OpenBLAS, as for tetmorph's CHOLMOD factors
        self._f = cholesky(M, mode="supernodal", ordering_method="metis")
        L = self._f.L()
        self.nbytes = int(L.data.nbytes + L.indices.nbytes + L.indptr.nbytes)

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._f(b)


class Harmonic:
    """The peer: one CHOLMOD factor of the harmonic system, three right-hand sides per update."""

    def __init__(self, deck: Path) -> None:
        from solver import read_mesh
        from solver.constraints.move import parse_move

        t0 = time.perf_counter()
        import igl  # its compiled library: the peer's per-process load (numpy and scipy already loaded)

        self.load_s = time.perf_counter() - t0

        self._parse = parse_move
        mesh = read_mesh(deck)
        V, T = mesh.V, mesh.T
        fixed, top = mesh.sets["FIXED"], mesh.sets["LOAD"]
        t0 = time.perf_counter()
        L = igl.cotmatrix(V, T)
        Q = (-L).tocsr()
        known = np.zeros(len(V), bool)
        known[fixed] = known[top] = True
        self.b = np.flatnonzero(known)
        self.u = np.flatnonzero(~known & mesh.referenced)
        Quu = Q[self.u][:, self.u].tocsc()
        self.Qub = Q[self.u][:, self.b].tocsr()
        self.f = CholmodMetis(Quu)
        self.setup_s = time.perf_counter() - t0
        self.V, self.top = V, top
        self.c = V[top].mean(axis=0)

    def update(self, doc: dict) -> np.ndarray:
        """Positions for one MOVE document."""
        V, top, b, u = self.V, self.top, self.b, self.u
        hm = self._parse(doc, ["top"]).handles["top"]
        D = np.zeros((len(V), 3))
        D[top] = hm.apply(V[top], self.c) - V[top]
        X = V.copy()
        X[b] += D[b]
        X[u] += self.f.solve(-(self.Qub @ D[b]))
        return X


def run_harmonic(deck: Path, k: int) -> dict:
    h = Harmonic(deck)
    times = []
    for doc in _moves(k) * 3:
        t = time.perf_counter()
        h.update(doc)
        times.append(1e3 * (time.perf_counter() - t))
    f = h.f
    out = {"load_s": h.load_s, "setup_s": h.setup_s, "update_ms": float(np.median(times[k:])),
           "factor_nnz": int(f.nbytes // 12), "factor_bytes": int(f.nbytes),
           "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20}
    del h, f
    out["setup_warm_s"] = Harmonic(deck).setup_s  # a second set-up in the same process (as a service's)
    return out


def run_tetmorph(deck: Path, k: int, case: str) -> dict:
    import scipy.sparse  # noqa: F401 - numpy and scipy are loaded before the load is timed, as for the peer
    import scipy.sparse.linalg  # noqa: F401

    assert "solver" not in sys.modules, "the load must be timed in a fresh process"
    t0 = time.perf_counter()
    import solver  # tetmorph's per-process load: its modules, the compiled core, the document models

    solver.load_kernels()
    load_s = time.perf_counter() - t0
    from solver import SolveOptions, precompute, read_mesh

    options = SolveOptions(sweeps=False) if case == "pardiso" else None
    mesh = read_mesh(deck)
    spec = {**SPEC, "precision": "exact" if case == "exact" else "mixed"}
    t1 = time.perf_counter()
    d = precompute(mesh, spec, options=options)
    setup = time.perf_counter() - t1
    moves = _moves(k)
    out: dict = {"load_s": load_s, "setup_s": setup}
    if case == "many":
        d.solve_many(moves)  # warm
        ts = []
        for _ in range(3):
            t = time.perf_counter()
            d.solve_many(moves)
            ts.append(1e3 * (time.perf_counter() - t) / k)
        out["update_ms"] = float(np.median(ts))
    elif case == "boundary":
        ts, full = [], []
        for doc in moves * 3:
            t = time.perf_counter()
            st = d.solve_boundary(doc)
            ts.append(1e3 * (time.perf_counter() - t))
            r = d.solve(st)
            u = r.report["timings"]["update"]
            full.append(ts[-1] + u["solve_ms"] + u["check_ms"] + u["report_ms"])
        out["update_ms"] = float(np.median(ts[k:]))
        out["full_ms"] = float(np.median(full[k:]))
    else:
        ts, parts = [], []
        for doc in moves * 3:
            r = d.solve(doc)
            u = r.report["timings"]["update"]
            ts.append(u["rhs_ms"] + u["solve_ms"] + u["check_ms"] + u["report_ms"])
            parts.append((u["solve_ms"], u["check_ms"], u["report_ms"]))
        out["update_ms"] = float(np.median(ts[k:]))
        out["solve_ms"] = float(np.median([p[0] for p in parts[k:]]))
        out["check_ms"] = float(np.median([p[1] for p in parts[k:]]))
        out["report_ms"] = float(np.median([p[2] for p in parts[k:]]))
        out["inverted"] = r.report["inverted_elements"]
        out["mean_value_residual"] = r.report.get("mean_value_residual")
    pos = d.data.positions
    out["interior_factor_bytes"] = int(pos.interior.nbytes) if getattr(pos, "interior", None) is not None else 0
    out["boundary_factor_bytes"] = int(pos.system.nbytes) if pos.system is not None else 0
    out["tets"] = int(len(mesh.T))
    out["lu_backend"] = pos.lu_backend
    out["peak_rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    del d, pos
    t0 = time.perf_counter()
    precompute(mesh, spec, options=options)  # a second set-up in this process: kernels loaded, as in a service
    out["setup_warm_s"] = time.perf_counter() - t0
    return out


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--sizes", default="0.95,0.44")
    p.add_argument("--cases", default="harmonic,mixed,exact,many,boundary")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--moves", type=int, default=6)
    p.add_argument("--case", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.case == "bandwidth":
        print(json.dumps({"gbs": bandwidth_gbs()}))
        return
    if a.case:
        size, case = a.case.split(":")
        from bench_solver import bracket_deck

        deck = bracket_deck(float(size))
        r = run_harmonic(deck, a.moves) if case == "harmonic" else run_tetmorph(deck, a.moves, case)
        print(json.dumps(r))
        return
    from bench_solver import bracket_deck

    # in its own process: a child's peak RSS would otherwise start at this process's (Linux keeps
    # ru_maxrss across fork and exec)
    out = subprocess.run([sys.executable, __file__, "--case", "bandwidth"], capture_output=True, text=True, check=True)
    bw = json.loads(out.stdout)["gbs"]
    print(f"read bandwidth: {bw:.1f} GB/s (best of 5 passes over 1 GB)")
    import compileall
    import importlib.util

    package = importlib.util.find_spec("solver")
    assert package is not None and package.origin is not None
    compileall.compile_dir(os.path.dirname(package.origin), quiet=1)  # the bytecode an install has
    cases = a.cases.split(",")
    for size in a.sizes.split(","):
        bracket_deck(float(size))
        runs: dict[str, list[dict]] = {c: [] for c in cases}
        for _ in range(a.repeats):
            for c in cases:
                out = subprocess.run([sys.executable, __file__, "--case", f"{size}:{c}", "--moves", str(a.moves)],
                                     capture_output=True, text=True)
                if out.returncode != 0:
                    print(f"{c} {size} failed: {out.stderr.strip().splitlines()[-1]}")
                    continue
                runs[c].append(json.loads(out.stdout.strip().splitlines()[-1]))
        h = runs.get("harmonic", [])
        hs = float(np.median([r["setup_s"] for r in h])) if h else float("nan")
        hu = float(np.median([r["update_ms"] for r in h])) if h else float("nan")
        tets = next((r["tets"] for c in cases for r in runs[c] if "tets" in r), 0)
        print(f"\nbracket, {tets:,} tets (gmsh size {size}); median [min-max] of {a.repeats} runs")
        hw = float(np.median([r["setup_warm_s"] for r in h])) if h else float("nan")
        hc = float(np.median([r["load_s"] + r["setup_s"] for r in h])) if h else float("nan")
        print("| case | load s | setup s | setup ratio | cold ratio | warm setup s | warm ratio | update ms "
              "| update ratio | solve ms | check ms | report ms | peak RSS GB |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for c in cases:
            rs = runs[c]
            if not rs:
                continue
            s = [r["setup_s"] for r in rs]
            up = [r["update_ms"] for r in rs]

            def spread(v: list[float], fmt: str) -> str:
                return f"{np.median(v):{fmt}} [{min(v):{fmt}}-{max(v):{fmt}}]"

            solve = spread([r["solve_ms"] for r in rs], ".1f") if "solve_ms" in rs[0] else ""
            check = spread([r["check_ms"] for r in rs], ".1f") if "check_ms" in rs[0] else ""
            rest = spread([r["report_ms"] for r in rs], ".1f") if "report_ms" in rs[0] else ""
            label = {"harmonic": "harmonic k=1 (peer)", "mixed": "tetmorph default (mixed)",
                     "pardiso": "tetmorph mixed, PARDISO and CHOLMOD solves",
                     "exact": "tetmorph precision exact", "many": f"tetmorph solve_many ({a.moves} moves), per move",
                     "boundary": "tetmorph boundary frame"}[c]
            w = [r["setup_warm_s"] for r in rs]
            ld = [r["load_s"] for r in rs]
            cold = float(np.median([r["load_s"] + r["setup_s"] for r in rs]))
            print(f"| {label} | {spread(ld, '.2f')} | {spread(s, '.2f')} | {np.median(s) / hs:.2f} | "
                  f"{cold / hc:.2f} | {spread(w, '.2f')} | "
                  f"{np.median(w) / hw:.2f} | {spread(up, '.1f')} | "
                  f"{np.median(up) / hu:.2f} | {solve} | {check} | {rest} | {max(r['peak_rss_gb'] for r in rs):.2f} |")
            if c == "boundary":
                full = float(np.median([r["full_ms"] for r in rs]))
                print(f"|  boundary frame / full update | | | | | | | | {np.median(up) / full:.2f} | | | | |")
        floor = []
        for c in ("harmonic", "mixed", "pardiso", "exact"):
            if runs.get(c):
                r = runs[c][0]
                nbytes = r.get("factor_bytes") or (r["interior_factor_bytes"] + r["boundary_factor_bytes"])
                lu = f" ({r['lu_backend']})" if r.get("lu_backend") else ""
                floor.append(f"{c}{lu}: {nbytes / 1e9:.3f} GB of factors, floor {1e3 * nbytes / 1e9 / bw:.1f} ms")
        print("memory-traffic floor per update (factor bytes / bandwidth): " + "; ".join(floor))


if __name__ == "__main__":
    main()
