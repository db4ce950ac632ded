"""Safe fraction, clamp and local repair on Armadillo13K (the paper's method, no thin-wall rows).

Fixed: lowest 10% along the longest axis; handle: highest 10%, translated sideways by a
fraction of the diagonal and turned about the second axis. Prints a markdown table::

    python benchmarks/compare/validity.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from cases import slab_spec  # noqa: E402

SHARED = ROOT.parent / "shared" / "data" / "tet"
MOVES = ((10, 0.05), (20, 0.1), (25, 0.15), (30, 0.2), (45, 0.1), (60, 0.3))


def main() -> None:
    from solver import precompute, read_mesh

    mesh = read_mesh(ROOT / "tests" / "data" / "Armadillo13K.msh")
    spec, ax, diag = slab_spec(mesh)
    d = precompute(mesh, {**spec, "thin_walls": False})
    axis = np.eye(3)[(ax + 1) % 3]
    print("| move | inverted | safe fraction | bisection solves | bisection ms | inverted after clamp | "
          "repair: inverted after | moved vertices | repair ms | repair note |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for ang, f in MOVES:
        mv = {"handles": {"h": {"translation": (f * diag * np.eye(3)[(ax + 2) % 3]).tolist(),
                                "rotation": {"axis": axis.tolist(), "angle_deg": ang}}}}
        r = d.solve(mv).report
        c = d.solve(mv, inversion="clamp").report
        rp = d.solve(mv, repair=True).report.get("repair", {})
        print(f"| {ang}° + {f:.0%} | {r['inverted_elements']} | {r['safe_fraction']:.4f} | "
              f"{r.get('safe_fraction_solves', 0)} | {r['timings']['update']['safe_fraction_ms']:.0f} | "
              f"{c['inverted_elements']} | {rp.get('inverted_after', '-')} | {rp.get('moved_vertices', '-')} | "
              f"{rp.get('ms', 0):.0f} | {rp.get('reason', 'ok' if rp else '-')} |", flush=True)


if __name__ == "__main__":
    main()
