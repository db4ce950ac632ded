"""Inverted tets with and without the thin-wall rows, per weight, on real meshes.

Meshes: kiefer_fea_bracket.vtu (tetra10, taken on its corner nodes), Armadillo13K.msh,
screw.msh (from ../shared/data/tet). Fixed: the lowest 10% along the longest axis; handle:
the highest 10%, moved sideways by a fraction of the diagonal and turned about the third
axis. Prints a markdown table::

    python benchmarks/compare/thin_walls.py
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

WEIGHTS = (0.0, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0)
#: (angle in degrees, sideways fraction of the diagonal, orientation): orientation 0 moves
#: along the axis after the longest and turns about the one after that; 1 swaps the two.
MOVES = ((20, 0.1, 0), (30, 0.15, 0), (30, 0.2, 0), (45, 0.1, 0),
         (20, 0.1, 1), (30, 0.15, 1), (30, 0.2, 1), (45, 0.1, 1))


def load(name: str):
    import meshio

    from solver import mesh_from_arrays, read_mesh

    if name.endswith(".vtu"):
        m0 = meshio.read(SHARED / name)
        T10 = np.concatenate([c.data for c in m0.cells if c.type == "tetra10"])
        return mesh_from_arrays(np.asarray(m0.points, float), T10[:, :4])
    return read_mesh(SHARED / name)


def spec_and_moves(mesh):
    spec, ax, diag = slab_spec(mesh)
    moves = []
    for a, f, o in MOVES:
        side, axis = np.eye(3)[(ax + 1 + o) % 3], np.eye(3)[(ax + 2 - o) % 3]
        moves.append({"handles": {"h": {"translation": (f * diag * side).tolist(),
                                        "rotation": {"axis": axis.tolist(), "angle_deg": a}}}})
    return spec, moves


def main() -> None:
    from solver import precompute

    print("| mesh | all-boundary tets | weight | " + " | ".join(f"{a}° + {f:.0%} ({'ab'[o]})" for a, f, o in MOVES)
          + " | total |")
    print("|---|---:|---:|" + "---:|" * (len(MOVES) + 1))
    totals: dict[float, int] = {}
    for name in ("kiefer_fea_bracket.vtu", "Armadillo13K.msh", "screw.msh"):
        mesh = load(name)
        spec, moves = spec_and_moves(mesh)
        allb = int(mesh.boundary[mesh.T].all(axis=1).sum())
        for w in WEIGHTS:
            d = precompute(mesh, {**spec, "thin_walls": {"weight": w}})
            counts = [d.solve(mv).report["inverted_elements"] for mv in moves]
            totals[w] = totals.get(w, 0) + sum(counts)
            print(f"| {name} | {allb:,} of {len(mesh.T):,} | {w:g} | " + " | ".join(map(str, counts))
                  + f" | {sum(counts)} |", flush=True)
    print("\ninverted tets over all meshes and moves, per weight: "
          + ", ".join(f"{w:g}: {t}" for w, t in totals.items()))


if __name__ == "__main__":
    main()
