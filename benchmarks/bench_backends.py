"""Factor and solve times of the sparse backends on tetmorph's two kinds of system.

Systems, taken from a split-solve Deformer on a jittered cube grid (``--n``
cells per side; 40 gives 384k tets) or on the gmsh bracket (``--bracket SIZE``):

* boundary normal equations ``Af^T Af`` (SPD): CHOLMOD, PARDISO (mtype 2),
  SuperLU;
* interior mean-value system ``M_II`` (square, non-symmetric): PARDISO LU
  (mtype 11), SuperLU, and CHOLMOD on the normal equations ``M^T M``.

Times are for one factorization and the median of 5 solves with 3
right-hand sides (x, y, z).

    python benchmarks/bench_backends.py [--n 40] [--bracket 0.95]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def timed(factor, M, rhs):
    t0 = time.perf_counter()
    f = factor(M)
    tf = time.perf_counter() - t0
    ts = []
    for _ in range(5):
        t0 = time.perf_counter()
        x = f(rhs)
        ts.append(1e3 * (time.perf_counter() - t0))
    res = float(np.abs(M @ x - rhs).max() / np.abs(rhs).max())
    return tf, statistics.median(ts), res


def cholmod(M):
    from sksparse.cholmod import cholesky

    f = cholesky(sp.csc_matrix(M))
    return f.solve_A


def pardiso(mtype):
    def factor(M):
        import pypardiso

        A = sp.triu(M, format="csr") if mtype == 2 else sp.csr_matrix(M)
        A.sort_indices()
        ps = pypardiso.PyPardisoSolver(mtype=mtype)
        ps.set_statistical_info_off()
        ps.factorize(A)
        return lambda b: ps.solve(A, np.asfortranarray(b))
    return factor


def superlu(symmetric):
    def factor(M):
        f = spla.splu(sp.csc_matrix(M), permc_spec="MMD_AT_PLUS_A" if symmetric else "COLAMD",
                      options={"SymmetricMode": symmetric})
        return f.solve
    return factor


def normal_equations(M):
    Mt = sp.csr_matrix(M.T)
    f = cholmod((Mt @ M).tocsc())
    return lambda b: f(Mt @ b)


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--n", type=int, default=40)
    p.add_argument("--bracket", type=float, help="gmsh mesh size of the bracket instead of a cube")
    a = p.parse_args()
    from solver import mesh_from_arrays, precompute, read_mesh
    from solver.testing import cube_mesh

    if a.bracket:
        from bench_solver import bracket_deck

        mesh = read_mesh(bracket_deck(a.bracket))
        spec = {"selections": {"f": {"set": "FIXED"}, "h": {"set": "LOAD"}},
                "fixed": ["f"], "handles": {"h": "h"}, "solve": "split"}
        name = f"bracket {a.bracket:g}"
    else:
        V, T = cube_mesh(a.n)
        V = V + np.random.default_rng(0).uniform(-0.15 / a.n, 0.15 / a.n, V.shape)
        mesh = mesh_from_arrays(V, T)
        spec = {"selections": {"f": {"box": {"min": [-1, -1, -1], "max": [2, 2, 0.1]}},
                               "h": {"box": {"min": [-1, -1, 0.9], "max": [2, 2, 2]}}},
                "fixed": ["f"], "handles": {"h": "h"}, "solve": "split"}
        name = f"cube n={a.n}"
    d = precompute(mesh, spec)
    system = d.data.positions.system
    Af = sp.csr_matrix(system.A @ system.ra.Z)  # boundary rows on the free boundary unknowns
    Mb = (Af.T @ Af).tocsc()
    Mi = sp.csr_matrix(d.data.positions.Mfi[:, d.data.positions.free_interior])
    rng = np.random.default_rng(1)
    print(f"mesh: {name}, {mesh.T.shape[0]:,} tets, {mesh.n:,} vertices\n")
    print("| system | unknowns | nnz | backend | factor s | solve ms (3 rhs) | rel. residual |")
    print("|---|---:|---:|---|---:|---:|---:|")
    cases = [("boundary AᵀA (SPD)", Mb, [("CHOLMOD", cholmod), ("PARDISO mtype 2", pardiso(2)),
                                         ("SuperLU", superlu(True))]),
             ("interior M_II (non-symmetric)", Mi, [("PARDISO LU mtype 11", pardiso(11)),
                                                   ("SuperLU", superlu(False)),
                                                   ("CHOLMOD on MᵀM", normal_equations)])]
    for label, M, backends in cases:
        rhs = rng.standard_normal((M.shape[0], 3))
        for bname, factor in backends:
            try:
                tf, ts, res = timed(factor, M, rhs)
                print(f"| {label} | {M.shape[0]:,} | {M.nnz:,} | {bname} | {tf:.2f} | {ts:.1f} | "
                      f"{res:.1e} |", flush=True)
            except Exception as e:  # noqa: BLE001 - a missing backend is reported, not fatal
                print(f"| {label} | {M.shape[0]:,} | {M.nnz:,} | {bname} | unavailable: "
                      f"{type(e).__name__} | | |", flush=True)


if __name__ == "__main__":
    main()
