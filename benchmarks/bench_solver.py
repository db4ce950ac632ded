"""Setup, per-update time and peak memory of the split and joint solves.

Meshes (``--mesh``):

``cube``
    Kuhn-split cube grids with jittered vertices (``--sizes 12,26,55``: about
    10k, 100k and 1M tets; a cube is the worst case for nested-dissection
    fill), fixed bottom 10% and a handle on the top 10%, moved by a
    translation + 20 deg rotation.
``bracket``
    The CAD part of ``tests/data/make_bracket.py`` (a bar with a bolt hole)
    meshed by gmsh with MeshSizeMax ``--sizes 2.1,0.95,0.44`` (about 10k,
    100k and 1M tets); FIXED end fixed, LOAD end translated + rotated 20 deg.

Each case runs in its own process so that peak RSS is the case's own (the
bracket deck is meshed beforehand, in another process).

    python benchmarks/bench_solver.py [--mesh cube|bracket] [--sizes ...] [--modes split,joint]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def bracket_deck(size: float) -> Path:
    """The bracket deck meshed at ``size`` (cached in the temp directory)."""
    path = Path(tempfile.gettempdir()) / f"tetmorph-bracket-{size:g}.inp"
    if not path.exists():
        subprocess.run([sys.executable, str(ROOT / "tests" / "data" / "make_bracket.py"),
                        f"{size:g}", str(path)], check=True)
    return path


def case(mesh_kind: str, size: str, mode: str, updates: int) -> dict:
    from solver import mesh_from_arrays, precompute, read_mesh
    from solver.testing import cube_mesh

    if mesh_kind == "bracket":
        mesh = read_mesh(bracket_deck(float(size)))
        V, T = mesh.V, mesh.T
        spec = {"selections": {"bottom": {"set": "FIXED"}, "top": {"set": "LOAD"}},
                "fixed": ["bottom"], "handles": {"top": "top"}, "solve": mode}
        span = 100.0
    else:
        n = int(size)
        V, T = cube_mesh(n)
        rng = np.random.default_rng(0)
        V = V + rng.uniform(-0.15 / n, 0.15 / n, V.shape)
        mesh = mesh_from_arrays(V, T)
        spec = {"selections": {"bottom": {"box": {"min": [-1, -1, -1], "max": [2, 2, 0.1]}},
                               "top": {"box": {"min": [-1, -1, 0.9], "max": [2, 2, 2]}}},
                "fixed": ["bottom"], "handles": {"top": "top"}, "solve": mode}
        span = 1.0
    t0 = time.perf_counter()
    d = precompute(mesh, spec)
    setup = time.perf_counter() - t0
    solve, total = [], []
    for k in range(updates):
        a = 20.0 * (k + 1) / updates
        r = d.solve({"handles": {"top": {"translation": [0.1 * span * a / 20, 0, 0],
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
    p.add_argument("--mesh", choices=["cube", "bracket"], default="cube")
    p.add_argument("--sizes", help="cube cells per side, or bracket gmsh mesh sizes")
    p.add_argument("--modes", default="split,joint")
    p.add_argument("--updates", type=int, default=10)
    p.add_argument("--case", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.case:
        kind, size, mode = a.case.split(":")
        print(json.dumps(case(kind, size, mode, a.updates)))
        return
    sizes = a.sizes or ("12,26,55" if a.mesh == "cube" else "2.1,0.95,0.44")
    print(f"mesh: {a.mesh}")
    print("| tets | vertices | solve | setup s (assembly + factor) | update ms: solve | update ms: solve+check | "
          "peak RSS GB | inverted (last update) |")
    print("|---:|---:|---|---:|---:|---:|---:|---:|")
    for size in sizes.split(","):
        if a.mesh == "bracket":
            bracket_deck(float(size))
        for mode in a.modes.split(","):
            out = subprocess.run([sys.executable, __file__, "--case", f"{a.mesh}:{size}:{mode}",
                                  "--updates", str(a.updates)], capture_output=True, text=True)
            if out.returncode != 0:
                print(f"| {a.mesh} {size} | | {mode} | failed: "
                      f"{out.stderr.strip().splitlines()[-1]} | | | | |")
                continue
            r = json.loads(out.stdout.strip().splitlines()[-1])
            print(f"| {r['tets']:,} | {r['vertices']:,} | {mode} | {r['setup_s']:.2f} "
                  f"({r['assembly_s']:.2f} + {r['factor_s']:.2f}) | {r['update_solve_ms']:.1f} | "
                  f"{r['update_total_ms']:.1f} | {r['peak_rss_gb']:.2f} | {r['inverted']} |", flush=True)


if __name__ == "__main__":
    main()
