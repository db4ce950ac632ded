"""The measurements behind tetmorph's design choices (quoted in the README and the code).

Sections (all by default, or pick with --only):

``orderings``  CHOLMOD ordering methods on the split solve's boundary system (plate with 16 holes,
               bracket at gmsh size 0.95 and 0.44): factor and solve time, fill; ``pardiso-nd`` is
               tetmorph's (PARDISO's nested dissection given to CHOLMOD; the ordering included).
``small-lu``   PARDISO vs SuperLU on interior mean-value systems of several sizes.
``penalty``    the penalty weight beta: constraint residual and distance to the exact solution
               (plate.inp, a rigid and a keep_direction hole, a 25° bend).
``refine``     the set-up probe of the refinement step on the test meshes.
``midside``    tetra10 mid-side placement: the polar rotation and edge stretch vs the averaged
               deformation gradient, folded elements on kiefer_fea_bracket.vtu; how much the
               offsets change in each edge's frame; the tractor wheel's elements folded at
               rest and after the tests' bend, without and with mid-side relaxation.
``constraints`` rigid holes of plate.inp per exact method, and null_space vs kkt on the plate
               and on 3,000 random problems.
``pardiso``    the interior mean-value system of the bracket (gmsh sizes 0.95 and 0.44: 107k and
               1M tets) factored by PARDISO with its default iparm (iparm(1) = 0) and with
               tetmorph's (no iterative refinement): solve time for 3 right-hand sides, residual;
               and CHOLMOD on the same pattern symmetrised, as a floor for a direct solve.
``nd-threads`` PARDISO's factor of the bracket's interior system (107k and 1M tets) with the
               settings before its reproducible mode (OpenMP ordering, iparm(2) = 3) and with
               tetmorph's (iparm(2) = 2, iparm(34) = 4): whether a process on one MKL thread
               and one on two solve to the same bits, and the factor time.
``kernels``    the compiled per-update and assembly kernels against the same formulas as numpy
               array expressions (bracket 0.95): quality check, rotation of the normals,
               mean-value weights.
``interior``   the interior back-substitution of the 107k bracket's single update (3 right-hand
               sides): PARDISO in single and double precision on one and two threads, with
               solve-phase settings changed one at a time (iparm 24, 25, no scaling and
               matching, orderings), and SuperLU in single precision; and, on the 1M bracket,
               PARDISO's orderings for a 48-column (DOE block) solve: factor entries and time.
``supernodal`` the supernodal sweeps (``solver/linalg/supernodal.py``, ``sweeps.py``) against PARDISO's and
               CHOLMOD's own solves: the interior mean-value system of the bracket at gmsh sizes
               0.95 and 0.7 (107k tets, and a mid size; the table gives counts), single and double, two threads
               and one, with each factorization's set-up time; the boundary position system of
               the 107k and 1M brackets for 3, 6, 12 and 48 right-hand sides.
``layout``     building stacked right-hand sides: numpy's asfortranarray against the tiled
               copy of ``solver/linalg/layout.py`` (160k x 48, to float32) and back; hstack
               against tile for the boundary system's repeated rest block (40k x 16).
``check``      the per-update element check on the 1M-tet bracket (gmsh size 0.44) at perturbed
               positions: ``ElementCheck.check`` (inverted count, degenerate count, minimum, exact
               1st percentile, ids) against ``tet_quality`` alone (the volume and scaled Jacobian
               of every tet, nothing else), median and range of 15 calls each, alternated.

``interior-1m`` the options for the 1M bracket's interior mean-value system (gmsh size 0.44), 3
               right-hand sides: tetmorph's multifrontal LU with the supernodal sweeps, PARDISO,
               and SuperLU, each in single and double precision, and CHOLMOD on the pattern
               symmetrised as the floor of a direct solve: factor time, factor entries, solve
               time, residual.
``library``    each home-made piece against the library that could do its job, in the same run, on the
               bracket's interior mean-value system at 107k and 1M tets: the multifrontal LU with the
               supernodal sweeps and the compiled PARDISO binding (single and double) against pypardiso's
               factorize and solve (double; it refuses float32); and OpenBLAS's thread count set for a
               block by ``solver.linalg.threads`` against threadpoolctl: cost, and whether a block on a
               second thread takes effect once a first thread has set OpenBLAS.
``distinct``   sorted distinct ids of the bracket's edges (107k and 1M tets): numpy's ``np.unique``
               (a hash table since numpy 2.3) against one sort (``solver/ops/unique.py``).

    python benchmarks/measure_choices.py [--only orderings,small-lu,...]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import tetmorph_core

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
SHARED = ROOT.parent / "shared" / "data" / "tet"
DATA = ROOT / "tests" / "data"


def deck(kind: str, size: float) -> Path:
    path = Path(tempfile.gettempdir()) / f"tetmorph-{kind}-{size:g}.inp"
    if not path.exists():
        if kind == "plate16":
            args = [str(DATA / "make_plate.py"), str(path), "--holes", "4", "--size", f"{size:g}"]
        else:
            args = [str(DATA / "make_bracket.py"), f"{size:g}", str(path)]
        subprocess.run([sys.executable, *args], check=True)
    return path


def end_spec(mesh) -> dict:
    return {"selections": {"fix": {"set": "FIXED"}, "load": {"set": "LOAD"}}, "fixed": ["fix"],
            "handles": {"tip": "load"}}


def orderings() -> None:
    from sksparse.cholmod import cholesky

    from solver import precompute, read_mesh
    from solver.linalg import pardiso as pm
    from solver.linalg.multifrontal import postordered
    from solver.linalg.ordering import AMD_BELOW

    def factor(M, om: str):
        if om.startswith("pardiso-nd"):  # tetmorph's (solver/linalg/ordering.py): the same in every process
            keep = pm.ORDERING_ONLY
            pm.ORDERING_ONLY = 2 if om.endswith("1t") else keep
            try:
                p = postordered(M, pm.nested_dissection(M))
            finally:
                pm.ORDERING_ONLY = keep
            return cholesky(M[p][:, p].tocsc(), mode="supernodal", ordering_method="natural")
        return cholesky(M, mode="supernodal", ordering_method=om)

    methods = ("amd", "metis", "nesdis", "default", "best", "pardiso-nd", "pardiso-nd-1t")
    print("``pardiso-nd``: PARDISO's OpenMP nested dissection (iparm(2) = 3), as tetmorph orders from "
          f"{AMD_BELOW:,} unknowns up (AMD below); ``-1t``: its one-thread METIS (iparm(2) = 2). "
          "Factor time includes the ordering. "
          "Three rounds, the methods alternated; median [range].\n")
    print("| mesh | unknowns | ordering | factor ms | solve ms (3 rhs) | nnz(L) |")
    print("|---|---:|---|---:|---:|---:|")
    for kind, size in (("plate16", 1.7), ("bracket", 0.95), ("bracket", 0.44)):
        mesh = read_mesh(deck(kind, size))
        d = precompute(mesh, end_spec(mesh))
        A = d.data.positions.system.A @ d.data.positions.system.ra.Z
        M = (A.T @ A).tocsc()
        del d
        b = np.random.default_rng(0).random((M.shape[0], 3))
        tf: dict[str, list[float]] = {m: [] for m in methods}
        ts: dict[str, list[float]] = {m: [] for m in methods}
        fill: dict[str, int] = {}
        factor(M, "pardiso-nd")  # MKL loaded before anything is timed
        for _ in range(3):
            for om in methods:
                t = time.perf_counter()
                f = factor(M, om)
                tf[om].append(time.perf_counter() - t)
                f(b)
                t = time.perf_counter()
                for _ in range(10):
                    f(b)
                ts[om].append((time.perf_counter() - t) / 10)
                fill[om] = f.L().nnz
        for om in methods:
            x, y = 1e3 * np.array(tf[om]), 1e3 * np.array(ts[om])
            print(f"| {kind} {size:g} | {M.shape[0]:,} | {om} | {np.median(x):.0f} [{x.min():.0f}-{x.max():.0f}] "
                  f"| {np.median(y):.2f} [{y.min():.2f}-{y.max():.2f}] | {fill[om]:,} |", flush=True)


def small_lu() -> None:
    from solver import precompute, read_mesh
    from solver.linalg import factorization as fz

    print("| mesh | interior unknowns | backend | factor ms | solve ms (3 rhs) |")
    print("|---|---:|---|---:|---:|")
    cases = [("bracket.inp", DATA / "bracket.inp"), ("bracket 2.1", deck("bracket", 2.1)),
             ("plate16 1.7", deck("plate16", 1.7)), ("bracket 0.95", deck("bracket", 0.95))]
    for name, path in cases:
        mesh = read_mesh(path)
        d = precompute(mesh, end_spec(mesh))
        M = d.data.positions.Mfi[:, d.data.positions.free_interior].tocsc()
        b = np.random.default_rng(0).random((M.shape[0], 3))
        for label, make in (("PARDISO", lambda M=M: fz._PardisoFactor(M, "x", symmetric=False)),
                            ("SuperLU", lambda M=M: fz._SuperLUFactor(M, "x", symmetric=False))):
            t = time.perf_counter()
            f = make()
            tf = time.perf_counter() - t
            f.solve(b)
            t = time.perf_counter()
            for _ in range(20):
                f.solve(b)
            print(f"| {name} | {M.shape[0]:,} | {label} | {1e3 * tf:.1f} | {5e1 * (time.perf_counter() - t):.2f} |",
                  flush=True)


def penalty() -> None:
    from solver import precompute, read_mesh

    plate = read_mesh(DATA / "plate.inp")
    sels = {"fix": {"set": "FIXED"}, "load": {"set": "LOAD"}, "h1": {"set": "HOLE1"}, "h4": {"set": "HOLE4"}}
    spec = {"selections": sels, "fixed": ["fix"], "handles": {"tip": "load"}, "solve": "joint",
            "features": [{"selection": "h1", "mode": "rigid", "name": "H1"},
                         {"selection": "h4", "mode": "keep_direction", "name": "H4"}]}
    mv = {"handles": {"tip": {"translation": [0, 0, 20], "rotation": {"axis": [0, 1, 0], "angle_deg": -25}}},
          "features": {"H1": {"scale": 0.9}}}
    exact = precompute(plate, spec).solve(mv).V
    print("| beta | constraint residual mm | distance to the exact solution mm |")
    print("|---:|---:|---:|")
    for beta in (1e2, 1e3, 1e4, 1e5, 1e6):
        r = precompute(plate, {**spec, "constraints": {"method": "penalty", "penalty_weight": beta}}).solve(mv)
        print(f"| {beta:g} | {r.report['constraint_residual_max']:.2g} | {np.abs(r.V - exact).max():.2g} |",
              flush=True)


def refine() -> None:
    from solver import precompute
    from tests.conftest import bend_spec, load

    print("| mesh | refinement probe / diagonal | refine_steps |")
    print("|---|---:|---:|")
    for name in ("screw.msh", "Armadillo13K.msh", "beam.node", "plate.inp", "bracket.inp"):
        m = load(name)
        d = precompute(m, bend_spec(m))
        pos = d.data.positions
        print(f"| {name} | {pos.refine_probe / d.data.constraints.diag:.2g} | {pos.refine_steps} |", flush=True)


def midside() -> None:
    from solver import precompute, read_mesh
    from solver.validity.midside import node_jacobians
    from tests.conftest import bend_move, bend_spec

    print("| mesh | bend | folded: rotation x stretch | folded: averaged gradient G |")
    print("|---|---|---:|---:|")
    m = read_mesh(SHARED / "kiefer_fea_bracket.vtu")
    d = precompute(m, bend_spec(m))
    mid = d.data.midside
    for ang, fr in ((10, 0.03), (15, 0.05), (20, 0.1)):
        P = mid.place(d.solve_positions(d.parse_move(bend_move(m, ang, fr))).P).P  # the rule alone, no relaxation
        R = mid.rotations(P)
        s = np.linalg.norm(P[mid.a] - P[mid.b], axis=1) / np.linalg.norm(m.V[mid.a] - m.V[mid.b], axis=1)
        Rs = P.copy()
        Rs[mid.ids] = 0.5 * (P[mid.a] + P[mid.b]) + s[:, None] * np.einsum("kab,kb->ka", R, mid.rest_offsets)
        folded = [int((node_jacobians(X, m.T10).min(axis=1) <= 0).sum()) for X in (Rs, P)]
        print(f"| kiefer_fea_bracket.vtu | {ang}° + {fr:.0%} | {folded[0]} | {folded[1]} |", flush=True)
    print("\n| mesh | offset change in the edge's rotated, stretched frame / edge length: p99 | max | "
          "midside_relaxed at 15° | at 20° |")
    print("|---|---:|---:|---|---|")
    for name in ("kiefer_fea_bracket.vtu", "segmenttet.inp"):
        q = read_mesh(SHARED / name)
        dq = precompute(q, bend_spec(q))
        P = dq.solve(bend_move(q, 15, 0.05)).V
        mq = dq._mid
        L0 = np.linalg.norm(q.V[mq.a] - q.V[mq.b], axis=1)
        s = np.linalg.norm(P[mq.a] - P[mq.b], axis=1) / L0
        back = np.einsum("kba,kb->ka", mq.rotations(P), P[mq.ids] - 0.5 * (P[mq.a] + P[mq.b])) / s[:, None]
        dev = np.linalg.norm(back - mq.rest_offsets, axis=1) / L0
        relaxed = [dq.solve(bend_move(q, a, 0.05)).report["midside_relaxed"] for a in (15, 20)]
        print(f"| {name} | {np.percentile(dev, 99):.2%} | {dev.max():.2%} | {relaxed[0]} | {relaxed[1]} |",
              flush=True)
    t = read_mesh(SHARED / "tractor_wheel_coarse.INP")
    dt = precompute(t, bend_spec(t))
    r = dt.solve(bend_move(t, 15, 0.05))
    dj0 = node_jacobians(t.V, t.T10)
    ratio0 = dj0.min(axis=1) / np.abs(dj0).max(axis=1)
    dj = node_jacobians(dt.data.midside.place(r.V).P, t.T10)  # the placement rule alone, no relaxation
    new = np.flatnonzero((dj.min(axis=1) <= 0) & (dj0.min(axis=1) > 0))
    bad0 = set(t.T10[dj0.min(axis=1) <= 0].ravel())
    print(f"\ntractor_wheel_coarse.INP: {int((dj0.min(axis=1) <= 0).sum())} elements folded at rest; without "
          f"mid-side relaxation the 15° + 5% bend folds {new.size} more, with rest Jacobian ratios "
          f"{np.round(ratio0[new], 4).tolist()} (0.1th percentile of the valid elements: "
          f"{np.percentile(ratio0[ratio0 > 0], 0.1):.4f}); "
          f"{sum(bool(set(t.T10[e]) & bad0) for e in new)} of them share a node with an element folded at rest")
    for angle in (15, 20):
        rep = dt.solve(bend_move(t, angle, 0.05)).report
        print(f"with relaxation, {angle}° + 5%: {rep['inverted_elements']} folded, midside_relaxed = "
              f"{rep['midside_relaxed']} of {dt.data.midside.ids.size} mid-side nodes")


def constraints() -> None:
    import scipy.sparse as sp

    from solver import precompute, read_mesh
    from solver.linalg.constrained import constrained_solver

    plate = read_mesh(DATA / "plate.inp")
    diag = float(np.linalg.norm(plate.V.max(0) - plate.V.min(0)))
    sels = {"fix": {"set": "FIXED"}, "load": {"set": "LOAD"}, **{f"h{k}": {"set": f"HOLE{k}"} for k in range(1, 5)}}
    mv = {"handles": {"tip": {"translation": [0, 0, 20], "rotation": {"axis": [0, 1, 0], "angle_deg": -25}}},
          "features": {"H4": {"scale": 1.25}}}
    print("| method | solve | largest rigid-hole residual mm (Procrustes, radius 6) | vs null_space split / diagonal |")
    print("|---|---|---:|---:|")
    ref = None
    for method, solve in (("null_space", "auto"), ("null_space", "joint"), ("kkt", "auto"), ("kkt", "joint")):
        spec = {"selections": sels, "fixed": ["fix"], "handles": {"tip": "load"}, "solve": solve,
                "constraints": {"method": method},
                "features": [{"selection": f"h{k}", "mode": "rigid", "name": f"H{k}"} for k in (1, 2, 4)]}
        d = precompute(plate, spec)
        P = d.solve(mv).V
        ref = P if ref is None else ref
        worst = 0.0
        for k in (1, 2, 4):
            ids = plate.sets[f"HOLE{k}"]
            a, b = plate.V[ids] - plate.V[ids].mean(0), P[ids] - P[ids].mean(0)
            U, S, Vt = np.linalg.svd(a.T @ b)
            sc = S.sum() / (a ** 2).sum()
            worst = max(worst, float(np.abs(b - sc * a @ (U @ Vt)).max()))
        print(f"| {method} | {d.solve_mode} | {worst:.1e} | {np.abs(P - ref).max() / diag:.1e} |", flush=True)
    worst = 0.0
    for seed in range(3000):  # the property test's random problems, many more of them
        rng = np.random.default_rng(seed)
        N = int(rng.integers(2, 13))
        m = int(rng.integers(1, N + 1))
        C = rng.standard_normal((m, N)) * (rng.random((m, N)) < 0.4)
        C[np.arange(m), rng.integers(0, N, m)] += 1.0
        extra = [C[i] * rng.uniform(0.5, 2) for i in rng.integers(0, m, rng.integers(0, 4))]
        if m >= 2 and rng.random() < 0.5:
            extra.append(C[0] - 2 * C[1])
        C = np.vstack([C, *extra]) if extra else C
        A = sp.csr_matrix(np.vstack([np.eye(N), rng.standard_normal((N, N))]))
        c, d = rng.standard_normal((2 * N, 2)), C @ rng.standard_normal((N, 2))
        x = [constrained_solver(sp.csr_matrix(C), A=A, method=meth).solve(np.zeros((N, 2)), d, c)
             for meth in ("null_space", "kkt")]
        worst = max(worst, float(np.abs(x[0] - x[1]).max() / max(1.0, np.abs(x[1]).max())))
    print(f"\nnull_space vs kkt over 3,000 random problems: largest relative difference {worst:.1e}")


def pardiso() -> None:
    import pypardiso
    import scipy.sparse as sp

    from solver import precompute, read_mesh
    from solver.linalg.pardiso import PardisoFactor, mkl_runtime

    os.environ.setdefault("PYPARDISO_MKL_RT", mkl_runtime() or "")
    print("| mesh | interior unknowns | iparm | factor ms | solve ms (3 rhs) | relative residual |")
    print("|---|---:|---|---:|---:|---:|")
    for size in (0.95, 0.44):
        mesh = read_mesh(deck("bracket", size))
        d = precompute(mesh, end_spec(mesh))
        A = d.data.positions.Mfi[:, d.data.positions.free_interior].tocsr()
        b = np.asfortranarray(np.random.default_rng(0).standard_normal((A.shape[0], 3)))
        del d
        # a floor for any direct solve with this sparsity: CHOLMOD on the symmetrised pattern
        # (|A| + |A^T| plus a diagonal shift, SPD; solves a different system of the same fill)
        from sksparse.cholmod import cholesky
        from threadpoolctl import threadpool_limits

        S = abs(A) + abs(A.T)
        S = (S + sp.identity(A.shape[0]) * float(S.sum(axis=1).max())).tocsc()
        with threadpool_limits(os.cpu_count(), user_api="blas"):  # tetmorph runs CHOLMOD's BLAS on one
            t = time.perf_counter()
            f = cholesky(S, ordering_method="metis")
            tf = 1e3 * (time.perf_counter() - t)
            f(np.ascontiguousarray(b))
            t = time.perf_counter()
            for _ in range(10):
                f(np.ascontiguousarray(b))
        print(f"| bracket {size:g} | {A.shape[0]:,} | CHOLMOD, same pattern symmetrised (nnz(L) "
              f"{f.L().nnz:,}) | {tf:.0f} | {1e2 * (time.perf_counter() - t):.1f} | - |", flush=True)
        for label in ("PARDISO defaults", "tetmorph"):
            if label == "tetmorph":
                t = time.perf_counter()
                f = PardisoFactor(A, "x", mtype=11)
                tf = 1e3 * (time.perf_counter() - t)
                solve = f.solve
            else:
                ps = pypardiso.PyPardisoSolver(mtype=11)
                ps.set_statistical_info_off()
                t = time.perf_counter()
                ps.factorize(A)
                tf = 1e3 * (time.perf_counter() - t)
                solve = lambda b, ps=ps, A=A: ps.solve(A, b)  # noqa: E731
            x = solve(b)
            t = time.perf_counter()
            for _ in range(10):
                solve(b)
            res = np.abs(A @ x - b).max() / np.abs(b).max()
            print(f"| bracket {size:g} | {A.shape[0]:,} | {label} | {tf:.0f} | "
                  f"{1e2 * (time.perf_counter() - t):.1f} | {res:.1e} |", flush=True)


def _median_ms(f, n: int = 15) -> str:
    f()
    ts = []
    for _ in range(n):
        t = time.perf_counter()
        f()
        ts.append(1e3 * (time.perf_counter() - t))
    return f"{np.median(ts):.2f} [{min(ts):.2f}-{max(ts):.2f}]"


def _pardiso_with(M, single: bool, iparm: dict[int, int]):
    """A PARDISO factor of ``M`` whose ``iparm`` (1-based numbers) is changed before the factorization."""
    from solver.linalg import pardiso as pm

    orig = pm.PardisoFactor._call

    def call(self, phase, b, x):
        if phase == 12:
            for k, v in iparm.items():
                self._iparm[k - 1] = v
        return orig(self, phase, b, x)

    pm.PardisoFactor._call = call
    try:
        return pm.PardisoFactor(M, "interior", mtype=11, single=single)
    finally:
        pm.PardisoFactor._call = orig


def interior() -> None:
    import scipy.sparse.linalg as spla

    from solver import precompute, read_mesh
    from solver.linalg import pardiso as pm

    mesh = read_mesh(deck("bracket", 0.95))
    d = precompute(mesh, end_spec(mesh))
    M = d.data.positions.Mff.tocsr()
    del d
    B = np.random.default_rng(0).standard_normal((M.shape[0], 3))
    print(f"bracket 0.95: {M.shape[0]:,} interior unknowns, {M.nnz:,} nonzeros; 3 right-hand sides, "
          "median [min-max] of 15 solves")
    print("| factor | iparm changed | factor entries | threads | solve ms | relative residual |")
    print("|---|---|---:|---:|---:|---:|")
    keep = pm.solve_threads
    cases = [(True, {}), (False, {}), (True, {24: 1}), (True, {24: 10}), (True, {25: 1}), (True, {25: 2}),
             (True, {11: 0, 13: 0}), (True, {2: 0}), (True, {2: 2})]
    try:
        for single, iparm in cases:
            F = _pardiso_with(M, single, iparm)
            res = float(np.abs(M @ F.solve(B) - B).max() / np.abs(B).max())
            for threads in (1, 2):
                pm.solve_threads = lambda columns, stacked, n=threads: n
                label = ", ".join(f"{k} = {v}" for k, v in iparm.items()) or "tetmorph's"
                print(f"| PARDISO {'single' if single else 'double'} | {label} | {F.nnz:,} | {threads} | "
                      f"{_median_ms(lambda F=F: F.solve(B))} | {res:.1e} |", flush=True)
            F.release()
    finally:
        pm.solve_threads = keep
    lu = spla.splu(M.tocsc().astype(np.float32), permc_spec="COLAMD")
    B32 = B.astype(np.float32)
    res = float(np.abs(M @ lu.solve(B32) - B).max() / np.abs(B).max())
    print(f"| SuperLU single | COLAMD | {lu.L.nnz + lu.U.nnz:,} | 1 | {_median_ms(lambda: lu.solve(B32))} | "
          f"{res:.1e} |")
    mesh = read_mesh(deck("bracket", 0.44))
    d = precompute(mesh, end_spec(mesh))
    M = d.data.positions.Mff.tocsr()
    del d
    B = np.random.default_rng(0).standard_normal((M.shape[0], 48))
    print(f"\nbracket 0.44: {M.shape[0]:,} interior unknowns; 48 right-hand sides, median [min-max] of 3 solves")
    print("| iparm(2) | factor s | factor entries | solve ms |")
    print("|---:|---:|---:|---:|")
    for order in (3, 2, 13, 23):
        t = time.perf_counter()
        F = _pardiso_with(M, True, {2: order})
        tf = time.perf_counter() - t
        print(f"| {order} | {tf:.1f} | {F.nnz:,} | {_median_ms(lambda F=F: F.solve(B), 3)} |", flush=True)
        F.release()


def supernodal() -> None:
    import copy

    from solver import SolveOptions, precompute, read_mesh
    from solver.linalg import factorization as fz
    from solver.linalg import pardiso as pm
    from solver.linalg.supernodal import cholmod_supernodal, lu_supernodal

    def one_thread(f):
        g = copy.copy(f)
        g._split = np.zeros(2, np.int64)  # no cut: one thread sweeps every supernode
        return g

    print("Interior mean-value systems (3 right-hand sides), median [min-max] of 15 solves; set-up is one "
          "factorization (ordering included)")
    print("| mesh | unknowns | backend | precision | threads | set-up s | solve ms | relative residual |")
    print("|---|---:|---|---|---:|---:|---:|---:|")
    for size in (0.95, 0.7):
        mesh = read_mesh(deck("bracket", size))
        # the precompute only builds the matrix; PARDISO is quicker
        M = precompute(mesh, end_spec(mesh), options=SolveOptions(sweeps=False)).data.positions.Mff.tocsc()
        B = np.random.default_rng(0).standard_normal((M.shape[0], 3))
        label = f"bracket {size} ({len(mesh.T):,} tets)"
        for single in (True, False):
            prec = "single" if single else "double"
            t = time.perf_counter()
            P = pm.PardisoFactor(M, "interior", mtype=11, single=single)
            tp = time.perf_counter() - t
            res = float(np.abs(M @ P.solve(B) - B).max() / np.abs(B).max())
            ms = _median_ms(lambda P=P, B=B: P.solve(B))
            print(f"| {label} | {M.shape[0]:,} | PARDISO | {prec} | 2 | {tp:.3f} | {ms} | {res:.1e} |", flush=True)
            P.release()
            t = time.perf_counter()
            S = lu_supernodal(M, single)
            ts = time.perf_counter() - t
            res = float(np.abs(M @ S.solve(B) - B).max() / np.abs(B).max())
            for f, n in ((S, S.threads), (one_thread(S), 1)):
                print(f"| {label} | {M.shape[0]:,} | supernodal | {prec} | {n} | {ts:.3f} | "
                      f"{_median_ms(lambda f=f, B=B: f.solve(B))} | {res:.1e} |", flush=True)
    print("\nBoundary position systems (null-space reduced, CHOLMOD's factor exported), median [min-max] of 9 solves")
    print("| mesh | unknowns | columns | CHOLMOD ms | supernodal ms | max difference / max |")
    print("|---|---:|---:|---:|---:|---:|")
    for size in (0.95, 0.44):
        mesh = read_mesh(deck("bracket", size))
        d = precompute(mesh, end_spec(mesh), options=SolveOptions(sweeps=False))
        chol = d.data.positions.system._f  # CHOLMOD's own factor of the reduced system
        Lm = chol._f.L()
        Hr = (Lm @ Lm.T).tocsc()
        inv = np.argsort(chol._f.P())
        S = cholmod_supernodal(chol._f, Hr[inv][:, inv])
        del d, Lm, Hr
        for k in (3, 6, 12, 48):
            B = np.random.default_rng(k).standard_normal((S.shape[0], k))
            ref = chol.solve(B)
            diff = float(np.abs(S.solve(B) - ref).max() / np.abs(ref).max())
            print(f"| bracket {size} | {S.shape[0]:,} | {k} | {_median_ms(lambda B=B, c=chol: c.solve(B), 9)} | "
                  f"{_median_ms(lambda B=B, f=S: f.solve(B), 9)} | {diff:.1e} |", flush=True)
    print(f"\n(tetmorph uses the supernodal sweeps from {fz.LU_SMALL:,} to {fz.SUPERNODAL_MAX:,} unknowns)")


def layout() -> None:
    from solver.linalg.layout import c_copy, fortran_copy

    b = np.random.default_rng(0).standard_normal((160_000, 48))
    x = np.asfortranarray(b, dtype=np.float32)
    col = np.random.default_rng(1).standard_normal((40_000, 1))
    print("| step | ms, median [min-max] of 15 |")
    print("|---|---:|")
    for name, f in (("numpy asfortranarray, 160k x 48 float64 -> float32", lambda: np.asfortranarray(b, np.float32)),
                    ("fortran_copy (tiles), same", lambda: fortran_copy(b, np.float32)),
                    ("numpy ascontiguousarray, 160k x 48 Fortran float32", lambda: np.ascontiguousarray(x)),
                    ("c_copy (tiles), same", lambda: c_copy(x, np.float32)),
                    ("numpy hstack of 16 copies of a 40k x 1 block", lambda: np.hstack([col] * 16)),
                    ("numpy tile, same", lambda: np.tile(col, (1, 16)))):
        print(f"| {name} | {_median_ms(f)} |", flush=True)


def _numpy_tet_quality(V, T):
    from solver.validity.quality import _edges2

    jac, e2 = _edges2(V, T)
    corner = np.stack([e2[:, 0] * e2[:, 2] * e2[:, 3], e2[:, 0] * e2[:, 1] * e2[:, 4],
                       e2[:, 1] * e2[:, 2] * e2[:, 5], e2[:, 3] * e2[:, 4] * e2[:, 5]]).max(axis=0)
    return jac, np.clip(np.sqrt(2.0) * jac / np.sqrt(corner), -1, 1)


def _numpy_rotate(v, r):
    half = np.linalg.norm(r, axis=1)
    a = np.divide(r, half[:, None], out=np.zeros_like(r), where=half[:, None] > 0)
    c, s = np.cos(2 * half)[:, None], np.sin(2 * half)[:, None]
    return v * c + np.cross(a, v) * s + a * np.einsum("ij,ij->i", a, v)[:, None] * (1 - c)


def kernels() -> None:
    from solver import precompute, read_mesh
    from solver.ops.mvc_matrix import mvc_matrix
    from solver.ops.rotation import rotate_by_log
    from solver.validity.quality import tet_quality

    mesh = read_mesh(deck("bracket", 0.95))
    V, T = mesh.V, np.ascontiguousarray(mesh.T)
    d = precompute(mesh, end_spec(mesh))
    delta = d.data.delta[d.data.constraints.bidx]
    r = np.random.default_rng(0).normal(0, 0.2, delta.shape)

    def best(f, k=20):
        f()
        ts = []
        for _ in range(k):
            t = time.perf_counter()
            f()
            ts.append(time.perf_counter() - t)
        return 1e3 * min(ts)

    print("| kernel | size | compiled ms | numpy ms | largest difference |")
    print("|---|---:|---:|---:|---:|")
    a, b = tet_quality(V, T), _numpy_tet_quality(V, T)
    print(f"| quality check (vol6, scaled Jacobian) | {len(T):,} tets | {best(lambda: tet_quality(V, T)):.2f} | "
          f"{best(lambda: _numpy_tet_quality(V, T)):.2f} | {np.abs(a[1] - b[1]).max():.1e} |")
    print(f"| rotated normals (Rodrigues) | {len(delta):,} vertices | {best(lambda: rotate_by_log(delta, r)):.2f} | "
          f"{best(lambda: _numpy_rotate(delta, r)):.2f} | "
          f"{np.abs(rotate_by_log(delta, r) - _numpy_rotate(delta, r)).max():.1e} |")
    interior = mesh.interior & mesh.referenced
    t = time.perf_counter()
    mvc_matrix(V, T, interior)
    print(f"| mean-value matrix (assembly) | {len(T):,} tets | {1e3 * (time.perf_counter() - t):.0f} | "
          "- | - |")


def check() -> None:
    from solver import read_mesh
    from solver.validity.check import ElementCheck
    from solver.validity.quality import tet_quality

    mesh = read_mesh(deck("bracket", 0.44))
    ec = ElementCheck(mesh.V, mesh.T, {})
    P = mesh.V + 1e-3 * np.random.default_rng(0).standard_normal(mesh.V.shape)
    T = np.ascontiguousarray(mesh.T, dtype=np.int32)
    ec.check(P), tet_quality(P, T)  # warm
    full, bare = [], []
    for _ in range(15):
        for f, out in ((lambda: ec.check(P), full), (lambda: tet_quality(P, T), bare)):
            t = time.perf_counter()
            f()
            out.append(1e3 * (time.perf_counter() - t))
    print(f"{len(T):,} tets, {tetmorph_core.get_num_threads()} threads")
    print("| step | ms, median [min-max] |")
    print("|---|---:|")
    for name, v in (("ElementCheck.check (the REPORT's check)", full), ("tet_quality (volumes and scaled Jacobians)",
                                                                         bare)):
        print(f"| {name} | {np.median(v):.1f} [{min(v):.1f}-{max(v):.1f}] |")


def interior_1m() -> None:
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from solver.linalg import pardiso as pm
    from solver.linalg.factorization import cholesky
    from solver.linalg.multifrontal import lu_multifrontal

    M, B, _ = _interior_system(0.44)
    print(f"bracket 0.44: {M.shape[0]:,} interior unknowns, {M.nnz:,} nonzeros; 3 right-hand sides, "
          "solve median [min-max] of 9")
    print("| factor | precision | factor s | factor entries | solve ms | relative residual |")
    print("|---|---|---:|---:|---:|---:|")

    def row(name, single, build, entries, solve, release=None):
        print(f"| {name} | {'single' if single else 'double'} | "
              f"{_factor_cells(M, B, build, solve, release, entries)} |", flush=True)

    for single in (True, False):
        row("multifrontal + sweeps (tetmorph)", single, lambda s=single: lu_multifrontal(M, s),
            lambda F: int(F.nnz), lambda F: F.solve(B))
    for single in (True, False):
        row("PARDISO", single, lambda s=single: pm.PardisoFactor(M, "interior", mtype=11, single=s),
            lambda F: int(F.nnz), lambda F: F.solve(B), lambda F: F.release())
    for single in (True, False):
        dt = np.float32 if single else np.float64
        row("SuperLU (MMD on A^T+A)", single,
            lambda dt=dt: spla.splu(M.astype(dt), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                    options={"SymmetricMode": True}),
            lambda F: int(F.L.nnz + F.U.nnz), lambda F, dt=dt: F.solve(B.astype(dt)))
    S = ((M + M.T) * 0.5).tocsc()
    S = S + sp.diags(np.abs(S).sum(axis=1).A1)  # positive definite on the same pattern: a floor, not a solve of M
    t = time.perf_counter()
    C = cholesky(S, "symmetrised")
    tf = time.perf_counter() - t
    print(f"| CHOLMOD on the symmetrised pattern (floor) | double | {tf:.2f} | {int(C.nbytes // 12):,} | "
          f"{_median_ms(lambda: C.solve(B), 9)} | (another matrix) |")


def _factor_cells(M, B, build, solve, release=None, entries=None) -> str:
    """Table cells of one factorization of ``M``: factor s, [entries,] solve ms (median of 9), relative residual."""
    t = time.perf_counter()
    F = build()
    tf = time.perf_counter() - t
    res = float(np.abs(M @ np.asarray(solve(F), np.float64) - B).max() / np.abs(B).max())
    cells = [f"{tf:.2f}", *([f"{entries(F):,}"] if entries is not None else []), _median_ms(lambda: solve(F), 9),
             f"{res:.1e}"]
    if release is not None:
        release(F)
    return " | ".join(cells)


def _interior_system(size: float):
    """The interior mean-value system of the bracket at gmsh ``size`` (CSC) and 3 right-hand sides."""
    from solver import precompute, read_mesh

    mesh = read_mesh(deck("bracket", size))
    d = precompute(mesh, end_spec(mesh))
    M = d.data.positions.Mff.tocsc()
    return M, np.random.default_rng(0).standard_normal((M.shape[0], 3)), len(mesh.T)


def _library_rows(size: float) -> None:
    """:func:`library`'s solver rows at one bracket size."""
    import pypardiso

    from solver.linalg import pardiso as pm
    from solver.linalg.multifrontal import lu_multifrontal

    M, B, tets = _interior_system(size)
    Mr = M.tocsr()
    name = f"{tets:,} tets"

    def row(path, single, build, solve, release=None):
        print(f"| {name} | {path} | {'single' if single else 'double'} | "
              f"{_factor_cells(M, B, build, solve, release)} |", flush=True)

    for single in (True, False):
        row("multifrontal LU + supernodal sweeps (tetmorph)", single,
            lambda s=single: lu_multifrontal(M, s), lambda F: F.solve(B))
    for single in (True, False):
        row("PARDISO through solver/linalg/pardiso.py (compiled core)", single,
            lambda s=single: pm.PardisoFactor(M, "interior", mtype=11, single=s),
            lambda F: F.solve(B), lambda F: F.release())

    def pypardiso_factor():
        ps = pypardiso.PyPardisoSolver()
        ps.factorize(Mr)
        return ps

    row("pypardiso (factorize, solve)", False, pypardiso_factor, lambda ps: ps.solve(Mr, B),
        lambda ps: ps.free_memory(everything=True))
    try:
        pypardiso.PyPardisoSolver().factorize(Mr.astype(np.float32))
        print(f"| {name} | pypardiso | single | took float32 | | |")
    except (TypeError, ValueError) as e:
        print(f"| {name} | pypardiso | single | refused: {str(e)[:70]} | | |")


def library() -> None:
    """Each home-made piece against the library that could do its job, 107k and 1M, in this run."""
    from threadpoolctl import threadpool_limits

    from solver.linalg import threads

    print("interior mean-value system, 3 right-hand sides: factor s, solve ms median [min-max] of 9")
    print("| bracket | path | precision | factor s | solve ms | relative residual |")
    print("|---|---|---|---:|---:|---:|")
    for size in (0.95, 0.44):
        _library_rows(size)
    print()
    print("OpenBLAS on one thread for a block: enter + exit, median [min-max] of 200 (microseconds), and whether")
    print("a block on a second thread takes effect once a first, still living thread has set OpenBLAS")
    print("| path | enter + exit us | effective from a second thread |")
    print("|---|---:|---|")
    import threading

    def cost(block) -> str:
        ts = []
        for _ in range(200):
            t = time.perf_counter()
            with block():
                pass
            ts.append(1e6 * (time.perf_counter() - t))
        return f"{np.median(ts):.1f} [{min(ts):.1f}-{max(ts):.1f}]"

    def effective(block) -> bool:
        from threadpoolctl import ThreadpoolController

        set_first, leave, seen = threading.Event(), threading.Event(), []

        def first():  # a long-lived thread (a service's pool) that set OpenBLAS through threadpoolctl first
            for c in ThreadpoolController().lib_controllers:
                if c.internal_api == "openblas":
                    c.set_num_threads(c.get_num_threads())
            set_first.set()
            leave.wait(30)

        def second():
            with block():
                seen.append([c.get_num_threads() for c in threads._own_openblas()])

        t1 = threading.Thread(target=first)
        t1.start()
        set_first.wait(30)
        t2 = threading.Thread(target=second)
        t2.start()
        t2.join()
        leave.set()
        t1.join()
        return bool(seen) and all(n == 1 for n in seen[0])

    for label, block in (("threads.one_blas_thread (OpenBLAS's own functions)", threads.one_blas_thread),
                         ("threadpoolctl.threadpool_limits(1, 'blas')",
                          lambda: threadpool_limits(1, user_api="blas"))):
        print(f"| {label} | {cost(block)} | {'yes' if effective(block) else 'no'} |", flush=True)


#: PARDISO settings nd-threads compares (MKL's 1-based iparm numbers): the ones before the
#: reproducible mode, and tetmorph's (solver/linalg/pardiso.py)
ND_SETTINGS = {"OpenMP ordering, no reproducible mode": {2: 3, 34: 0},
               "one-thread ordering, reproducible mode": {2: 2, 34: 4}}

_ND_CHILD = """
import hashlib, sys
import numpy as np, scipy.sparse as sp
sys.path.insert(0, sys.argv[1])
import measure_choices as mc
A = sp.load_npz(sys.argv[2]).tocsr()
b = np.asfortranarray(np.random.default_rng(0).standard_normal((A.shape[0], 3)))
for label, iparm in mc.ND_SETTINGS.items():
    f = mc._pardiso_with(A, single=False, iparm=iparm)
    print(hashlib.sha256(np.ascontiguousarray(f.solve(b)).tobytes()).hexdigest())
    f.release()
"""


def nd_threads() -> None:
    """PARDISO's factor on one MKL thread and on two, in separate processes: the same bits or not; factor time."""
    import scipy.sparse as sp

    from solver import precompute, read_mesh

    print("| mesh | interior unknowns | settings | factor s, median [range] | 1 thread = 2 threads |")
    print("|---|---:|---|---:|---|")
    orderings = []
    for size, runs in ((0.95, 7), (0.44, 3)):
        mesh = read_mesh(deck("bracket", size))
        d = precompute(mesh, end_spec(mesh))
        A = d.data.positions.Mfi[:, d.data.positions.free_interior].tocsr()
        del d
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "A.npz")
            sp.save_npz(path, A)
            hashes = []
            for n in (1, 2):
                env = {**os.environ, "MKL_NUM_THREADS": str(n), "OMP_NUM_THREADS": str(n)}
                hashes.append(subprocess.run([sys.executable, "-c", _ND_CHILD, os.path.dirname(__file__), path],
                                             env=env, capture_output=True, text=True, check=True).stdout.split())
        times: dict[str, list[float]] = {k: [] for k in ND_SETTINGS}
        for _ in range(runs):  # alternated, so that a change of load meets both
            for label, iparm in ND_SETTINGS.items():
                t = time.perf_counter()
                f = _pardiso_with(A, single=False, iparm=iparm)
                times[label].append(time.perf_counter() - t)
                f.release()
        for k, (label, ts) in enumerate(times.items()):
            same = "yes" if hashes[0][k] == hashes[1][k] else "no"
            print(f"| bracket {size:g} | {A.shape[0]:,} | {label} | {np.median(ts):.2f} [{min(ts):.2f}-{max(ts):.2f}] "
                  f"| {same} |", flush=True)
        orderings.append((size, A))
    # the ordering alone (the multifrontal LU's): OpenMP's against one thread's, time and permutation
    from solver.linalg import pardiso as pm

    print("\n| mesh | ordering alone, iparm(2) | s, median [range] | the one-thread permutation |")
    print("|---|---|---:|---|")
    for size, A in orderings:
        perms: dict[int, list[bytes]] = {3: [], 2: []}
        took: dict[int, list[float]] = {3: [], 2: []}
        keep = pm.ORDERING_ONLY
        try:
            for _ in range(3):
                for nd in (3, 2):
                    pm.ORDERING_ONLY = nd
                    t = time.perf_counter()
                    perms[nd].append(pm.nested_dissection(A).tobytes())
                    took[nd].append(time.perf_counter() - t)
        finally:
            pm.ORDERING_ONLY = keep
        for nd in (3, 2):
            same = "yes" if set(perms[nd]) == set(perms[2]) and len(set(perms[2])) == 1 else "no"
            ts = took[nd]
            print(f"| bracket {size:g} | {nd} | {np.median(ts):.2f} [{min(ts):.2f}-{max(ts):.2f}] | {same} |",
                  flush=True)


def distinct() -> None:
    from solver import read_mesh
    from solver.ops.unique import unique

    print("| mesh | edges (with repeats) | distinct | np.unique ms | one sort ms |")
    print("|---|---:|---:|---:|---:|")
    for size in (0.95, 0.44):
        T = read_mesh(deck("bracket", size)).T
        E = np.sort(np.concatenate([T[:, [a, b]] for a in range(4) for b in range(a + 1, 4)]), axis=1)
        key = E[:, 0] * (int(E.max()) + 1) + E[:, 1]
        assert np.array_equal(np.unique(key), unique(key))
        print(f"| bracket {len(T):,} tets | {key.size:,} | {unique(key).size:,} | "
              f"{_median_ms(lambda k=key: np.unique(k), 5)} | {_median_ms(lambda k=key: unique(k), 5)} |", flush=True)


SECTIONS = {"orderings": orderings, "small-lu": small_lu, "penalty": penalty, "refine": refine, "midside": midside,
            "constraints": constraints, "pardiso": pardiso, "interior": interior, "layout": layout, "kernels": kernels,
            "check": check, "supernodal": supernodal,
            "interior-1m": interior_1m, "distinct": distinct, "nd-threads": nd_threads, "library": library}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default=",".join(SECTIONS))
    for name in ap.parse_args().only.split(","):
        print(f"\n## {name}\n", flush=True)
        SECTIONS[name]()


if __name__ == "__main__":
    main()
