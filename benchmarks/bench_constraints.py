"""Benchmark of the constraint engine: rigid hole features, each solve method.

Two tables:

1. A sheet-metal-like plate with 16 round holes (``tests/data/make_plate.py
   --holes 4``), one end fixed, the other end a handle; every hole a ``rigid``
   form feature. Setup and update time per method, the hard-constraint count,
   and how rigid the holes stay.
2. The ~1M-tet bracket of ``bench_solver.py`` (gmsh size 0.44), positional
   constraints only vs. with its bolt hole as a rigid feature and the hole's
   centre on a plane: setup ratio.

Each case runs in its own process (peak RSS is per case), warmed up by one
set-up on a small cube first, as a running service is::

    python benchmarks/bench_constraints.py [--plate-size 1.7] [--big-size 0.44] [--skip-big]
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
sys.path.insert(0, str(ROOT))


def deck(kind: str, size: float) -> Path:
    """The plate (16 holes) or bracket deck at gmsh size ``size``, cached in the temp directory."""
    path = Path(tempfile.gettempdir()) / f"tetmorph-{kind}-{size:g}.inp"
    if not path.exists():
        if kind == "plate16":
            args = [str(ROOT / "tests" / "data" / "make_plate.py"), str(path), "--holes", "4",
                    "--size", f"{size:g}"]
        else:
            args = [str(ROOT / "tests" / "data" / "make_bracket.py"), f"{size:g}", str(path)]
        subprocess.run([sys.executable, *args], check=True)
    return path


def _rigidity(P0: np.ndarray, P: np.ndarray) -> float:
    a, b = P0 - P0.mean(0), P - P.mean(0)
    U, _, Vt = np.linalg.svd(a.T @ b)
    return float(np.abs(b - a @ (U @ Vt)).max())


def case(cfg: dict) -> dict:
    from solver import mesh_from_arrays, precompute, read_mesh
    from solver.testing import cube_mesh

    # warm up as a running service is: the first CHOLMOD/PARDISO/SuperLU/numexpr calls of a
    # process pay one-time initialisation (about 0.3 s here) that no later set-up pays
    warm = mesh_from_arrays(*cube_mesh(4))
    precompute(warm, {"selections": {"a": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
                                     "b": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}},
                                     "c": {"box": {"min": [0, 0, 0.5], "max": [1, 0, 0.5]}}},
                      "fixed": ["a"], "handles": {"b": "b"}, "solve": cfg["solve"],
                      "constraints": {"method": cfg["method"]},
                      "features": [{"selection": "c", "mode": "rigid", "name": "c"}]}).solve({})
    mesh = read_mesh(deck(cfg["deck"], cfg["size"]))
    holes = sorted(k for k in mesh.sets if k.startswith("HOLE"))
    sels = {"fix": {"set": "FIXED"}, "load": {"set": "LOAD"}, **{h: {"set": h} for h in holes}}
    spec = {"selections": sels, "fixed": ["fix"], "handles": {"tip": "load"},
            "constraints": {"method": cfg["method"]}, "solve": cfg["solve"]}
    if cfg["deck"] == "bracket":
        sels["wall"] = {"sphere": {"center": [60, 10, 5], "radius": 7.5}, "boundary_only": True}
        spec["selections"] = {k: v for k, v in sels.items() if not k.startswith("HOLE")}
        holes = []
        if cfg["features"]:
            spec["features"] = [{"selection": "wall", "mode": "rigid", "name": "bolt"}]
            spec["motion"] = [{"name": "centre", "selection": "wall", "plane": {"normal": [0, 0, 1]}}]
    elif cfg["features"]:
        spec["features"] = [{"selection": h, "mode": "rigid", "name": h} for h in holes]
    setups = []
    for _ in range(cfg.get("setups", 1)):  # median of several set-ups: this VM's timings vary ~20%
        t0 = time.perf_counter()
        d = precompute(mesh, spec)
        setups.append(time.perf_counter() - t0)
    setup = float(np.median(setups))
    span = float(np.ptp(mesh.V[:, 0]))
    moves = [{"handles": {"tip": {"translation": [0, 0, 0.1 * span * (k + 1) / cfg["updates"]],
                                  "rotation": {"axis": [0, 1, 0], "angle_deg": -20.0 * (k + 1) / cfg["updates"]}}}}
             for k in range(cfg["updates"])]
    solve_ms, total_ms, reps = [], [], []
    for mv in moves:
        r = d.solve(mv)
        solve_ms.append(r.report["timings"]["update"]["solve_ms"])
        total_ms.append(r.report["timings"]["update"]["total_ms"])
        reps.append(r)
    last = reps[-1]
    rig = max((_rigidity(mesh.V[mesh.sets[h]], last.V[mesh.sets[h]]) for h in holes), default=0.0)
    if cfg["deck"] == "bracket" and cfg["features"]:
        ids = d.data.constraints.blocks[[b.kind for b in d.data.constraints.blocks].index("feature")].vertices
        rig = _rigidity(mesh.V[ids], last.V[ids])
    rows = 0 if d.data.constraints.pasm is None else int(d.data.constraints.pasm.C.shape[0])
    rrows = 0 if d.data.constraints.rasm is None else int(d.data.constraints.rasm.C.shape[0])
    feature_rows = sum(b.nrows for b in d.data.constraints.blocks if b.kind in ("feature", "motion"))
    return {
        "tets": int(mesh.T.shape[0]), "vertices": mesh.n, "method": cfg["method"], "mode": d.solve_mode,
        "features": len(spec.get("features", [])), "feature_rows": feature_rows,
        "position_rows": rows, "rotation_rows": rrows,
        "components": 0 if d.data.constraints.pra is None else d.data.constraints.pra.components,
        "largest": [] if d.data.constraints.pra is None else list(d.data.constraints.pra.largest),
        "setup_s": setup, "solve_ms": float(np.median(solve_ms)), "total_ms": float(np.median(total_ms)),
        "residual": last.report["constraint_residual_max"], "rigidity": rig,
        "inverted": last.report["inverted_elements"],
        "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20,
    }


def run(cfg: dict) -> dict:
    out = subprocess.run([sys.executable, __file__, "--case", json.dumps(cfg)], check=True,
                         capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plate-size", type=float, default=1.7)
    ap.add_argument("--big-size", type=float, default=0.44)
    ap.add_argument("--updates", type=int, default=20)
    ap.add_argument("--skip-big", action="store_true")
    ap.add_argument("--case", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.case:
        print(json.dumps(case(json.loads(a.case))))
        return
    print("Plate with 16 rigid hole features "
          f"(make_plate.py --holes 4 --size {a.plate_size:g}; setup: median of 3; update: median of {a.updates})\n")
    print("| method | solve | features | hard rows (positions + rotations) | components (largest: unknowns x rows) "
          "| setup s | update ms: solve | update ms: solve+check | constraint residual | hole rigidity error | "
          "inverted |")
    print("|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|")
    base = None
    for method, solve, feats in [("null_space", "auto", False), ("null_space", "auto", True),
                                 ("null_space", "joint", True), ("kkt", "auto", True), ("kkt", "joint", True),
                                 ("penalty", "joint", True)]:
        r = run({"deck": "plate16", "size": a.plate_size, "method": method, "solve": solve,
                 "features": feats, "updates": a.updates, "setups": 3})
        base = base or r
        print(f"| {method} | {r['mode']} | {r['features']} | {r['position_rows']:,} + {r['rotation_rows']:,} | "
              f"{r['components']:,} ({r['largest'][0]} x {r['largest'][1]}) | {r['setup_s']:.3f} | "
              f"{r['solve_ms']:.1f} | {r['total_ms']:.1f} | {r['residual']:.1e} | {r['rigidity']:.1e} | "
              f"{r['inverted']} |", flush=True)
    print(f"\nmesh: {base['tets']:,} tets, {base['vertices']:,} vertices\n")
    if a.skip_big:
        return
    print(f"Bracket at gmsh size {a.big_size:g}: positional only vs. rigid bolt-hole feature + centre on a "
          f"plane (null space, split; median of {min(a.updates, 5)} updates)\n")
    print("| constraints | tets | feature rows | setup s | update ms: solve+check | hole rigidity error | "
          "peak RSS GB |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    res = {}
    for feats in (False, True):
        r = run({"deck": "bracket", "size": a.big_size, "method": "null_space", "solve": "auto",
                 "features": feats, "updates": min(a.updates, 5)})
        res[feats] = r
        print(f"| {'positional + feature' if feats else 'positional only'} | {r['tets']:,} | "
              f"{r['feature_rows']:,} | {r['setup_s']:.2f} | {r['total_ms']:.1f} | {r['rigidity']:.1e} | "
              f"{r['peak_rss_gb']:.2f} |", flush=True)
    print(f"\nsetup ratio (feature / positional only): {res[True]['setup_s'] / res[False]['setup_s']:.2f}")


if __name__ == "__main__":
    main()
