"""Setup, per-update time and peak memory of the split and joint solves.

Meshes: Kuhn-split cube grids with jittered vertices (about 10k, 100k and 1M
tets; a cube is the worst case for nested-dissection fill), fixed bottom 10%
and a handle on the top 10%, moved by a translation + 20 deg rotation. Each
case runs in its own process so that peak RSS is the case's own.

    python benchmarks/bench_solver.py [--sizes 12,26,55] [--modes split,joint] [--updates 10]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import numpy as np


def case(n: int, mode: str, updates: int) -> dict:
    from solver import mesh_from_arrays, precompute
    from solver.testing import cube_mesh

    V, T = cube_mesh(n)
    rng = np.random.default_rng(0)
    V = V + rng.uniform(-0.15 / n, 0.15 / n, V.shape)
    mesh = mesh_from_arrays(V, T)
    spec = {"selections": {"bottom": {"box": {"min": [-1, -1, -1], "max": [2, 2, 0.1]}},
                           "top": {"box": {"min": [-1, -1, 0.9], "max": [2, 2, 2]}}},
            "fixed": ["bottom"], "handles": {"top": "top"}, "solve": mode}
    t0 = time.perf_counter()
    d = precompute(mesh, spec)
    setup = time.perf_counter() - t0
    solve, total = [], []
    for k in range(updates):
        a = 20.0 * (k + 1) / updates
        r = d.solve({"handles": {"top": {"translation": [0.1 * a / 20, 0, 0],
                                         "rotation": {"axis": [0, 1, 0], "angle_deg": a}}}})
        solve.append(r.report["timings"]["update"]["rhs_ms"] + r.report["timings"]["update"]["solve_ms"])
        total.append(r.report["timings"]["update"]["total_ms"])
    return {"tets": len(T), "vertices": len(V), "mode": mode, "setup_s": setup,
            "assembly_s": d.setup_timings["assembly_ms"] / 1e3,
            "factor_s": (d.setup_timings["rotation_factorization_ms"]
                         + d.setup_timings["position_factorization_ms"]) / 1e3,
            "update_solve_ms": float(np.median(solve)), "update_total_ms": float(np.median(total)),
            "inverted": r.report["inverted_elements"],
            "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20}


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--sizes", default="12,26,55")
    p.add_argument("--modes", default="split,joint")
    p.add_argument("--updates", type=int, default=10)
    p.add_argument("--case", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.case:
        n, mode = a.case.split(":")
        print(json.dumps(case(int(n), mode, a.updates)))
        return
    print("| tets | vertices | solve | setup s (assembly + factor) | update ms: solve | update ms: solve+check | peak RSS GB |")
    print("|---:|---:|---|---:|---:|---:|---:|")
    for n in map(int, a.sizes.split(",")):
        for mode in a.modes.split(","):
            out = subprocess.run([sys.executable, __file__, "--case", f"{n}:{mode}", "--updates",
                                  str(a.updates)], capture_output=True, text=True)
            if out.returncode != 0:
                print(f"| {6 * n ** 3} | | {mode} | failed: {out.stderr.strip().splitlines()[-1]} | | | |")
                continue
            r = json.loads(out.stdout.strip().splitlines()[-1])
            print(f"| {r['tets']:,} | {r['vertices']:,} | {mode} | {r['setup_s']:.2f} "
                  f"({r['assembly_s']:.2f} + {r['factor_s']:.2f}) | {r['update_solve_ms']:.1f} | "
                  f"{r['update_total_ms']:.1f} | {r['peak_rss_gb']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
