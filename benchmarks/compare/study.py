"""Side-by-side study: tetmorph against libigl (harmonic, biharmonic, ARAP) and RBF morphing.

Same meshes, same fixed and handle vertices, same handle targets for every method:

* meshes: Armadillo13K.msh, kiefer_fea_bracket.vtu (tetra10 on its corner nodes),
  wheelset.vtk, cube_big_tetra.mesh (../shared/data/tet), and two gmsh CAD parts,
  tests/data/bracket.inp and tests/data/plate.inp;
* selections: the lowest 10% along the longest axis fixed, the highest 10% the
  handle (wheelset: also its middle 10% fixed, so every body is held);
* moves of the handle about its centroid: a bend (turn about the second axis), a
  twist (turn about the longest axis) and a sideways translation, three magnitudes each;
* methods: tetmorph null_space (default: thin-wall rows on), tetmorph as in the paper
  (``thin_walls: false``), tetmorph kkt and penalty; libigl harmonic (k=1) and
  biharmonic (k=2) deformation of the displacement field through
  ``igl.min_quad_with_fixed_precompute/solve``; libigl ARAP on tets
  (``igl.ARAPData``, ``arap_precomputation``, ``arap_solve``, 10 iterations, started
  from the biharmonic result); RBF morphing with ``scipy.interpolate.RBFInterpolator``
  (thin-plate spline) driven by the constrained vertices' displacements.

Per run: set-up time, per-update time (no quality check; RBF's update includes its fit, as
scipy's RBFInterpolator has no separate factorization), inverted elements, min and
1st-percentile scaled Jacobian, hard-constraint error (largest distance of a fixed or
handle vertex from its target). Writes ``benchmarks/results/compare.md`` and PNG plots
(inverted count against move magnitude per mesh; scaled-Jacobian histograms) and prints
the table::

    python benchmarks/compare/study.py [--meshes NAME,...] [--methods NAME,...]

Needs the ``compare`` extra (``pip install -e .[compare]``: libigl, matplotlib).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
SHARED = ROOT.parent / "shared" / "data" / "tet"
RESULTS = ROOT / "benchmarks" / "results"

MESHES = ("Armadillo13K.msh", "kiefer_fea_bracket.vtu", "wheelset.vtk", "cube_big_tetra.mesh",
          "bracket.inp", "plate.inp")
MOVES = [("bend", 15), ("bend", 30), ("bend", 45), ("twist", 30), ("twist", 60), ("twist", 90),
         ("translate", 0.1), ("translate", 0.2), ("translate", 0.4)]
METHODS = ("tetmorph", "tetmorph-paper", "tetmorph-kkt", "tetmorph-penalty", "igl-harmonic",
           "igl-biharmonic", "igl-arap", "rbf-tps")


def load(name: str):
    """The mesh as linear tets with every vertex used (libigl needs no unreferenced vertices)."""
    import meshio

    from solver import mesh_from_arrays, read_mesh

    if name.endswith(".vtu"):
        m0 = meshio.read(SHARED / name)
        V = np.asarray(m0.points, float)
        T = np.concatenate([c.data for c in m0.cells if c.type == "tetra10"])[:, :4]
    else:
        path = ROOT / "tests" / "data" / name if (ROOT / "tests" / "data" / name).exists() else SHARED / name
        m = read_mesh(path)
        V, T = m.V, m.T
    used = np.unique(T)
    remap = np.full(V.shape[0], -1, np.int64)
    remap[used] = np.arange(used.size)
    return mesh_from_arrays(V[used], remap[T])


def setup_case(mesh, name: str):
    V = mesh.V
    lo, hi = V.min(0), V.max(0)
    ax = int(np.argmax(hi - lo))
    L = hi[ax] - lo[ax]
    diag = float(np.linalg.norm(hi - lo))
    t = (V[:, ax] - lo[ax]) / L
    fixed = np.flatnonzero(t <= 0.1 + 1e-9)
    if name == "wheelset.vtk":
        fixed = np.union1d(fixed, np.flatnonzero(np.abs(t - 0.5) <= 0.05 + 1e-9))
    handle = np.flatnonzero(t >= 0.9 - 1e-9)
    return ax, diag, fixed, handle


def targets(mesh, ax: int, diag: float, handle: np.ndarray, kind: str, mag: float) -> np.ndarray:
    from solver.constraints.move import axis_angle_matrix

    P = mesh.V[handle]
    c = P.mean(0)
    if kind == "translate":
        return P + mag * diag * np.eye(3)[(ax + 2) % 3]
    axis = np.eye(3)[ax] if kind == "twist" else np.eye(3)[(ax + 1) % 3]
    R = axis_angle_matrix(axis, np.radians(mag))
    return c + (P - c) @ R.T


def quality(V: np.ndarray, T: np.ndarray) -> tuple[int, float, float, np.ndarray]:
    from solver.validity.quality import DEGENERATE_TOL, tet_quality

    vol6, sj = tet_quality(V, T)
    bad = int(np.count_nonzero((vol6 <= 0) | (np.abs(sj) <= DEGENERATE_TOL)))
    k = sj.size // 100
    return bad, float(sj.min()), float(np.partition(sj, k)[k]), sj


class Tetmorph:
    def __init__(self, mesh, fixed, handle, method: str = "null_space", thin_walls: bool = True):
        from solver import precompute

        spec = {"selections": {"fix": {"ids": fixed.tolist()}, "hand": {"ids": handle.tolist()}},
                "fixed": ["fix"], "handles": {"h": "hand"}, "constraints": {"method": method},
                "thin_walls": thin_walls}
        self.d = precompute(mesh, spec)
        self.mesh = mesh
        self.handle = handle

    def solve(self, U: np.ndarray, kind: str, mag: float, ax: int, diag: float) -> np.ndarray:
        # the same targets as a MOVE: a turn about the handle centroid, or a translation
        if kind == "translate":
            mv = {"handles": {"h": {"translation": (mag * diag * np.eye(3)[(ax + 2) % 3]).tolist()}}}
        else:
            axis = np.eye(3)[ax] if kind == "twist" else np.eye(3)[(ax + 1) % 3]
            mv = {"handles": {"h": {"rotation": {"axis": axis.tolist(), "angle_deg": mag}}}}
        r = self.d.solve(mv)
        t = r.report["timings"]["update"]
        # the solve itself, as for the other methods: not the quality check, nor the
        # safe-fraction bisection that an inverting MOVE triggers
        self.last_update_ms = t["rhs_ms"] + t["solve_ms"]
        return r.V


class IglQuadratic:
    """k-harmonic deformation of the displacement field (k = 1 harmonic, 2 biharmonic)."""

    def __init__(self, mesh, fixed, handle, k: int):
        import igl

        V, T = mesh.V, mesh.T
        L = igl.cotmatrix(V, T)
        if k == 1:
            Q = -L
        else:
            M = igl.massmatrix(V, T, igl.MassMatrixType.MASSMATRIX_TYPE_BARYCENTRIC)
            Minv = sp.diags(1.0 / M.diagonal())
            Q = L @ Minv @ L
        self.b = np.concatenate([fixed, handle]).astype(np.int64)
        self.data = igl.min_quad_with_fixed_data()
        igl.min_quad_with_fixed_precompute(sp.csc_matrix(Q), self.b, sp.csc_matrix((0, V.shape[0])), True,
                                           self.data)
        self.V = V
        self.nfix = fixed.size

    def solve(self, U: np.ndarray, *_a) -> np.ndarray:
        import igl

        bc = np.vstack([np.zeros((self.nfix, 3)), U - self.V[self.b[self.nfix:]]])
        D = igl.min_quad_with_fixed_solve(self.data, np.zeros((self.V.shape[0], 3)), bc, np.zeros((0, 3)))
        return self.V + D


class IglArap:
    def __init__(self, mesh, fixed, handle):
        import igl

        self.V, self.T = mesh.V, mesh.T
        self.b = np.concatenate([fixed, handle]).astype(np.int32)
        self.data = igl.ARAPData()
        self.data.max_iter = 10
        igl.arap_precomputation(self.V, self.T, 3, self.b, self.data)
        self.init = IglQuadratic(mesh, fixed, handle, 2)
        self.nfix = fixed.size

    def solve(self, U: np.ndarray, *_a) -> np.ndarray:
        import igl

        bc = np.vstack([self.V[self.b[: self.nfix]], U])
        return igl.arap_solve(bc, self.data, self.init.solve(U))


class Rbf:
    """Thin-plate-spline RBF of the constrained vertices' displacements (degree-1 polynomial)."""

    def __init__(self, mesh, fixed, handle):
        self.V = mesh.V
        self.b = np.concatenate([fixed, handle])
        self.nfix = fixed.size

    def solve(self, U: np.ndarray, *_a) -> np.ndarray:
        from scipy.interpolate import RBFInterpolator

        D = np.vstack([np.zeros((self.nfix, 3)), U - self.V[self.b[self.nfix:]]])
        f = RBFInterpolator(self.V[self.b], D, kernel="thin_plate_spline")
        return self.V + f(self.V)


def build(method: str, mesh, fixed, handle):
    if method == "tetmorph":
        return Tetmorph(mesh, fixed, handle)
    if method == "tetmorph-paper":
        return Tetmorph(mesh, fixed, handle, thin_walls=False)
    if method == "tetmorph-kkt":
        return Tetmorph(mesh, fixed, handle, method="kkt")
    if method == "tetmorph-penalty":
        return Tetmorph(mesh, fixed, handle, method="penalty")
    if method == "igl-harmonic":
        return IglQuadratic(mesh, fixed, handle, 1)
    if method == "igl-biharmonic":
        return IglQuadratic(mesh, fixed, handle, 2)
    if method == "igl-arap":
        return IglArap(mesh, fixed, handle)
    return Rbf(mesh, fixed, handle)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", default=",".join(MESHES))
    ap.add_argument("--methods", default=",".join(METHODS))
    a = ap.parse_args()
    RESULTS.mkdir(parents=True, exist_ok=True)
    # warm every method up on a small cube: first calls into CHOLMOD, PARDISO, libigl and
    # numexpr pay one-time costs that a long-running process pays once
    from solver import mesh_from_arrays
    from solver.testing import cube_mesh

    cube = mesh_from_arrays(*cube_mesh(4))
    cax, cdiag, cfix, chand = setup_case(cube, "cube")
    for method in a.methods.split(","):
        build(method, cube, cfix, chand).solve(targets(cube, cax, cdiag, chand, "bend", 10), "bend", 10,
                                               cax, cdiag)
    rows = []
    hist: dict[str, dict[str, np.ndarray]] = {}
    for name in a.meshes.split(","):
        mesh = load(name)
        ax, diag, fixed, handle = setup_case(mesh, name)
        for method in a.methods.split(","):
            t0 = time.perf_counter()
            try:
                solver = build(method, mesh, fixed, handle)
            except Exception as e:  # a method that cannot handle the mesh is reported, not hidden
                rows.append({"mesh": name, "method": method, "error": f"{type(e).__name__}: {e}"[:200]})
                print(json.dumps(rows[-1]), flush=True)
                continue
            setup = time.perf_counter() - t0
            for kind, mag in MOVES:
                U = targets(mesh, ax, diag, handle, kind, mag)
                t1 = time.perf_counter()
                try:
                    P = solver.solve(U, kind, mag, ax, diag)
                except Exception as e:
                    rows.append({"mesh": name, "method": method, "move": f"{kind} {mag}",
                                 "error": f"{type(e).__name__}: {e}"[:200]})
                    continue
                upd = time.perf_counter() - t1
                upd = getattr(solver, "last_update_ms", 1e3 * upd) / 1e3
                finite = bool(np.isfinite(P).all())
                bad, sjmin, sjp01, sj = quality(P, mesh.T) if finite else (-1, float("nan"), float("nan"), None)
                err = float(max(np.abs(P[fixed] - mesh.V[fixed]).max(), np.abs(P[handle] - U).max())) \
                    if finite else float("nan")
                rows.append({"mesh": name, "tets": int(mesh.T.shape[0]), "method": method, "move": kind,
                             "magnitude": mag, "setup_s": setup, "update_ms": 1e3 * upd, "inverted": bad,
                             "min_sj": sjmin, "p01_sj": sjp01, "constraint_error": err / diag})
                print(json.dumps(rows[-1]), flush=True)
                if (kind, mag) == ("bend", 30) and sj is not None:
                    hist.setdefault(name, {})[method] = sj
    (RESULTS / "compare.json").write_text(json.dumps(rows, indent=1))
    write_markdown(rows)
    plot(rows, hist)


def write_markdown(rows: list[dict]) -> None:
    lines = ["| mesh | tets | method | setup s | update ms (median of 9) | inverted (bend 15/30/45; "
             "twist 30/60/90; translate 10/20/40%) | min scaled Jacobian (worst move) | p01 (worst move) | "
             "max constraint error / diag |", "|---|---:|---|---:|---:|---|---:|---:|---:|"]
    by = {}
    for r in rows:
        by.setdefault((r["mesh"], r["method"]), []).append(r)
    for (mesh, method), rs in by.items():
        ok = [r for r in rs if "error" not in r]
        if not ok:
            lines.append(f"| {mesh} | | {method} | failed: {rs[0]['error']} | | | | | |")
            continue
        inv = " / ".join(str(r["inverted"]) for r in ok)
        lines.append(
            f"| {mesh} | {ok[0]['tets']:,} | {method} | {ok[0]['setup_s']:.2f} | "
            f"{np.median([r['update_ms'] for r in ok]):.1f} | {inv} | {min(r['min_sj'] for r in ok):.3f} | "
            f"{min(r['p01_sj'] for r in ok):.3f} | {max(r['constraint_error'] for r in ok):.1e} |")
    text = "\n".join(lines) + "\n"
    (RESULTS / "compare.md").write_text(text)
    print(text)


def plot(rows: list[dict], hist: dict[str, dict[str, np.ndarray]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    kinds = ("bend", "twist", "translate")
    fig, axes = plt.subplots(len(meshes), 3, figsize=(13, 3.0 * len(meshes)), squeeze=False)
    for i, mesh in enumerate(meshes):
        for j, kind in enumerate(kinds):
            ax = axes[i][j]
            for method in methods:
                rs = [r for r in rows if r["mesh"] == mesh and r["method"] == method and r.get("move") == kind
                      and "error" not in r]
                if rs:
                    ax.plot([r["magnitude"] for r in rs], [max(r["inverted"], 0) + 0.5 for r in rs], "o-",
                            label=method)
            ax.set_yscale("log")
            ax.set_title(f"{mesh}: {kind}", fontsize=9)
            ax.set_ylabel("inverted tets + 0.5")
    _save(plt, fig, axes, "inverted_vs_magnitude.png")
    ncol = min(3, len(hist))
    nrow = -(-len(hist) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 3.4 * nrow), squeeze=False)
    for k, (mesh, per) in enumerate(hist.items()):
        ax = axes[k // ncol][k % ncol]
        for method, sj in per.items():
            ax.hist(sj, bins=np.linspace(-1, 1, 81), histtype="step", label=method)
        ax.set_yscale("log")
        ax.set_title(f"{mesh}: bend 30°", fontsize=9)
        ax.set_xlabel("scaled Jacobian")
    _save(plt, fig, axes, "scaled_jacobian_histograms.png")


def _save(plt, fig, axes, name: str) -> None:
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(RESULTS / name, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
