"""DOE cost per variant against single morph updates, side by side in one process.

The bracket of ``tests/data/make_bracket.py`` meshed at gmsh MeshSizeMax
``--sizes`` (0.95: about 107k tets, 0.44: about 1.03M), FIXED end fixed, LOAD
end the handle, four shapes (lift, pull, twist, bend) and a plan of
``--rows`` random rows in [-1, 1]. Per repeat, in this order:

``single``
    ``Deformer.solve`` of each of the first ``--singles`` rows' MOVEs, one at a
    time: the update ``tetmorph morph`` makes per MOVE (parse, right-hand
    sides, back-substitutions, element check, REPORT), without file writing.
``doe, block b``
    ``run_doe`` of the whole plan with ``block=b`` rows per stacked solve:
    its wall time over the rows (combining the shapes, parsing, stacked
    back-substitutions, checks, REPORTs; no output callback, so no writing).

Each DOE run follows its own ``single`` measurement, block sizes in a
shuffled order per repeat, so each ratio compares neighbours in time. The
table gives per-variant wall milliseconds as median [min-max] over the
repeats, the wall-time ratio to the neighbouring ``single`` (median [min-max]
of the ratios), and the same ratio of this process's CPU time (user + system,
all threads), which counts work rather than waiting for a busy machine. The
machine is a shared VM: compare columns of one run.

With ``--fresh`` each block size of more than 2 rows also runs on a second
precompute of the same mesh that makes nothing but stacked solves, as a
``tetmorph doe`` process or a Ray actor does (PARDISO keeps a factor's
earlier thread count, ``solver/linalg/threads.py``: the main precompute's
single updates run on one thread, and so do its stacked solves after them).

The process sets the allocator up as ``tetmorph doe`` does
(``solver/workflows/batch_memory.py``; ``TETMORPH_BATCH_MALLOC=0`` keeps
glibc's defaults, which is how a service session's batch runs).

With ``--oneshot N`` each block size of more than 2 rows also runs N times in
a fresh process of its own that sets the allocator up, reads the mesh, makes
one precompute and one ``run_doe`` of the plan, as one ``tetmorph doe``
invocation does (its first block pays for its allocations and PARDISO's work
space); the ratio is to the median single update of the main process.

With ``--direct`` the one-shot processes also run with the interior's
stacked solve made directly on every column (``TETMORPH_COLUMN_BASIS=0``)
beside the default, which back-substitutes only the directions the block's
columns span (``solver/deform/positions.py``).

With ``--components B`` it also prints where one variant's time goes in a
stacked solve of ``B`` rows against a single update (median of 3, per
variant): the right-hand sides, the interior back-substitution (3 columns
against 3 B), the interior right-hand side ``M_f P`` over every column
against ``M_fb dP_b`` over the boundary columns only, the element check, the
stacked positions and the stacked updates; then a profile of one stacked
``solve_many`` by each function's own time.

    python benchmarks/bench_doe.py [--sizes 0.95,0.44] [--blocks 1,4,16,64] [--rows 64] [--repeats 3]
                                   [--components 16] [--fresh] [--oneshot 3 [--direct]]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import resource
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_solver import bracket_deck  # noqa: E402

from solver.linalg.threads import WIDE_COLUMNS  # noqa: E402

SHAPES = {"shapes": {
    "lift": {"handles": {"top": {"translation": [0, 0, 2.0]}}},
    "pull": {"handles": {"top": {"translation": [1.0, 0, 0]}}},
    "twist": {"handles": {"top": {"rotation": {"axis": [1, 0, 0], "angle_deg": 5}}}},
    "bend": {"handles": {"top": {"rotation": {"axis": [0, 1, 0], "angle_deg": 5}}}},
}}


def spread(v: list[float], fmt: str = ".1f") -> str:
    return f"{np.median(v):{fmt}} [{min(v):{fmt}}-{max(v):{fmt}}]"


def oneshot_case(size: float, block: int, rows: int) -> dict:
    """One `tetmorph doe`-like process: allocator set, mesh read, one precompute, one `run_doe` of the plan."""
    from solver import precompute, read_mesh
    from solver.workflows import parse_plan, parse_shapes, run_doe
    from solver.workflows.batch_memory import keep_freed_memory

    keep_freed_memory()
    mesh = read_mesh(bracket_deck(size))
    d = precompute(mesh, {"selections": {"bottom": {"set": "FIXED"}, "top": {"set": "LOAD"}},
                          "fixed": ["bottom"], "handles": {"top": "top"}})
    shapes = parse_shapes(SHAPES, d)
    values = np.random.default_rng(0).uniform(-1, 1, (rows, shapes.count))  # the plan of run()
    plan = parse_plan([dict(zip(shapes.names, r, strict=True)) for r in values.tolist()])
    t = time.perf_counter()
    res = run_doe(d, shapes, plan, block=block)
    wall = 1e3 * (time.perf_counter() - t) - res.timings["output_ms"]
    # VmHWM: this process's own peak (ru_maxrss would carry the parent's across fork and exec)
    hwm = next(int(line.split()[1]) for line in Path("/proc/self/status").read_text().splitlines()
               if line.startswith("VmHWM:"))
    return {"per_variant_ms": wall / rows, "peak_rss_gb": hwm / 2**20}


def oneshot(size: float, blocks: list[int], rows: int, repeats: int, single_ms: list[float],
            direct: bool = False) -> None:
    """Each block size in fresh processes (the first block's allocations and work space included)."""
    import json
    import os
    import subprocess

    s = float(np.median(single_ms))
    print(f"\none-shot processes ({repeats} per case, alternating), against the single update's median "
          f"{s:.1f} ms above")
    print("| case | wall ms per variant, median [min-max] | wall / single update | peak RSS GB |")
    print("|---|---:|---:|---:|")
    cases = [(b, basis) for b in blocks for basis in ((True, False) if direct else (True,))]
    got: dict[tuple[int, bool], list[dict]] = {c: [] for c in cases}
    for _ in range(repeats):
        for b, basis in cases:
            env = {**os.environ, "TETMORPH_COLUMN_BASIS": "1" if basis else "0"}
            out = subprocess.run([sys.executable, __file__, "--oneshot-case", f"{size:g}:{b}:{rows}"],
                                 capture_output=True, text=True, check=True, env=env)
            got[(b, basis)].append(json.loads(out.stdout.strip().splitlines()[-1]))
    for b, basis in cases:
        per = [r["per_variant_ms"] for r in got[(b, basis)]]
        label = f"doe, block {b}, one-shot process" + ("" if basis else ", direct stacked solve")
        print(f"| {label} | {spread(per)} | {spread([p / s for p in per], '.2f')} | "
              f"{max(r['peak_rss_gb'] for r in got[(b, basis)]):.2f} |")


def run(size: float, blocks: list[int], rows: int, singles: int, repeats: int,
        fresh: bool = False) -> list[float]:
    from solver import precompute, read_mesh
    from solver.workflows import parse_plan, parse_shapes, run_doe, variant_move

    mesh = read_mesh(bracket_deck(size))
    spec = {"selections": {"bottom": {"set": "FIXED"}, "top": {"set": "LOAD"}},
            "fixed": ["bottom"], "handles": {"top": "top"}}
    t0 = time.perf_counter()
    d = precompute(mesh, spec)
    setup = time.perf_counter() - t0
    shapes = parse_shapes(SHAPES, d)
    rng = np.random.default_rng(0)
    values = rng.uniform(-1, 1, (rows, shapes.count))
    plan = parse_plan([dict(zip(shapes.names, r, strict=True)) for r in values.tolist()])
    moves = [variant_move(d, shapes, values[i]) for i in range(singles)]
    # a second precompute that only ever makes stacked solves, as in a `tetmorph doe` process (its
    # first back-substitution is stacked, so it keeps both threads: solver/linalg/threads.py)
    fd = precompute(mesh, spec) if fresh else None
    f_shapes = parse_shapes(SHAPES, fd) if fd is not None else None
    f_blocks = [b for b in blocks if 3 * b > WIDE_COLUMNS]
    d.solve(moves[0])  # warm: kernels, factor work space
    run_doe(d, shapes, parse_plan([plan_row(plan, 0)]), block=1)
    single: list[float] = []
    per: dict[int, list[float]] = {b: [] for b in blocks}
    ratio: dict[int, list[float]] = {b: [] for b in blocks}
    cpu_ratio: dict[int, list[float]] = {b: [] for b in blocks}
    check: dict[int, list[float]] = {b: [] for b in blocks}
    f_per: dict[int, list[float]] = {b: [] for b in f_blocks}
    f_ratio: dict[int, list[float]] = {b: [] for b in f_blocks}
    first = 0.0
    order = np.random.default_rng(1)
    for _ in range(repeats):
        for b in order.permutation(blocks).tolist():
            # the single updates right before each DOE run: the ratio compares neighbours in time
            ts, cs, V1 = [], [], []
            for mv in moves:
                t, c = time.perf_counter(), time.process_time()
                r = d.solve(mv)
                ts.append(1e3 * (time.perf_counter() - t))
                cs.append(1e3 * (time.process_time() - c))
                V1.append(r.V)
            s, s_cpu = float(np.median(ts)), float(np.median(cs))
            single.append(s)
            got: list[np.ndarray] = []
            reps: list[dict] = []

            def keep(row: int, res, got=got, reps=reps) -> None:
                if row <= singles:
                    got.append(res.V)
                reps.append(res.report)

            t, c = time.perf_counter(), time.process_time()
            res = run_doe(d, shapes, plan, block=b, output=keep)
            wall = 1e3 * (time.perf_counter() - t) - res.timings["output_ms"]
            cpu = 1e3 * (time.process_time() - c)
            per[b].append(wall / rows)
            ratio[b].append(wall / rows / s)
            cpu_ratio[b].append(cpu / rows / s_cpu)
            check[b].append(float(np.median([r["timings"]["update"]["check_ms"] for r in reps])))
            first = max(first, max(float(np.abs(a - v).max()) for a, v in zip(got, V1, strict=True)))
            if fd is not None and b in f_blocks:
                t = time.perf_counter()
                res = run_doe(fd, f_shapes, plan, block=b)
                wall = 1e3 * (time.perf_counter() - t)
                f_per[b].append(wall / rows)
                f_ratio[b].append(wall / rows / s)
    n_tets = mesh.T.shape[0]
    print(f"\n### bracket {size:g}: {n_tets:,} tets, {mesh.n:,} vertices; setup {setup:.2f} s; "
          f"{rows} plan rows, {shapes.count} shapes, {repeats} repeats; "
          f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB")
    print(f"largest distance, DOE row vs single solve of its MOVE: {first:.2e} "
          f"({first / d.data.constraints.diag:.1e} of the diagonal)\n")
    print("| case | wall ms per variant, median [min-max] | wall / single update | CPU time / single update "
          "| check ms per variant |")
    print("|---|---:|---:|---:|---:|")
    print(f"| single `solve` (morph update) | {spread(single)} | 1 | 1 | |")
    for b in blocks:
        print(f"| doe, block {b} | {spread(per[b])} | {spread(ratio[b], '.2f')} | {spread(cpu_ratio[b], '.2f')} "
              f"| {np.median(check[b]):.1f} |")
    for b in f_blocks if fd is not None else []:
        print(f"| doe, block {b}, own factor (as `tetmorph doe`) | {spread(f_per[b])} | {spread(f_ratio[b], '.2f')} "
              "| | |")
    return single


def timed(f, n: int = 3) -> tuple[float, float]:
    """Median wall and CPU milliseconds of ``n`` calls."""
    w, c = [], []
    for _ in range(n):
        t, p = time.perf_counter(), time.process_time()
        f()
        w.append(1e3 * (time.perf_counter() - t))
        c.append(1e3 * (time.process_time() - p))
    return float(np.median(w)), float(np.median(c))


def components(size: float, block: int) -> None:
    from solver import precompute, read_mesh
    from solver.deform.solve import check_positions, solve_positions, solve_positions_many
    from solver.workflows import parse_shapes, variant_move

    mesh = read_mesh(bracket_deck(size))
    d = precompute(mesh, {"selections": {"bottom": {"set": "FIXED"}, "top": {"set": "LOAD"}},
                          "fixed": ["bottom"], "handles": {"top": "top"}})
    shapes = parse_shapes(SHAPES, d)
    rng = np.random.default_rng(0)
    mvs = [variant_move(d, shapes, rng.uniform(-1, 1, shapes.count)) for _ in range(block)]
    pos = d.data.positions
    fi, Mfi = pos.free_interior, pos.Mfi
    rest = np.setdiff1d(np.flatnonzero(mesh.referenced), fi)
    Mfb = Mfi[:, rest].tocsr()
    P = np.hstack([solve_positions(d.data, mv).P for mv in mvs])
    dPb = np.ascontiguousarray(P[rest] - np.hstack([mesh.V[rest]] * block))
    B3, Bk = rng.normal(size=(fi.size, 3)), rng.normal(size=(fi.size, 3 * block))
    d.solve(mvs[0])
    s = solve_positions(d.data, mvs[0])
    rows = [("single `solve` (morph update)", timed(lambda: d.solve(mvs[1]), 5), 1),
            ("right-hand sides of one MOVE", timed(lambda: d.data.rhs(mvs[1]), 5), 1),
            ("interior back-substitution, 3 columns", timed(lambda: pos.interior.solve(B3)), 1),
            (f"interior back-substitution, {3 * block} columns", timed(lambda: pos.interior.solve(Bk)), block),
            (f"interior rhs M_f P, {3 * block} columns (nnz {Mfi.nnz:,})", timed(lambda: Mfi @ P), block),
            (f"interior rhs M_fb dP_b, {3 * block} columns (nnz {Mfb.nnz:,})", timed(lambda: Mfb @ dPb), block),
            ("element check", timed(lambda: check_positions(d.data, s), 5), 1),
            (f"solve_positions_many, {block} MOVEs", timed(lambda: solve_positions_many(d.data, mvs)), block),
            (f"solve_many (updates with REPORTs), {block} MOVEs", timed(lambda: d.solve_many(mvs)), block)]
    print(f"\n### where a variant's time goes: bracket {size:g}, {mesh.T.shape[0]:,} tets, block {block}\n")
    print("| step | wall ms per variant | CPU ms per variant |")
    print("|---|---:|---:|")
    for label, (w, c), k in rows:
        print(f"| {label} | {w / k:.1f} | {c / k:.1f} |")
    prof = cProfile.Profile()
    prof.runcall(d.solve_many, mvs)
    st = pstats.Stats(prof)
    top = sorted(st.stats.items(), key=lambda kv: -kv[1][2])[:12]  # type: ignore[attr-defined]
    print(f"\nsolve_many of {block} MOVEs under cProfile, by own time (ms per variant):\n")
    print("| function | calls | own ms per variant |")
    print("|---|---:|---:|")
    for (file, line, name), (_, calls, own, _, _) in top:
        where = f"{Path(file).parent.name}/{Path(file).name}:{line}" if line else "builtin"
        print(f"| `{name}` ({where}) | {calls} | {1e3 * own / block:.1f} |")


def plan_row(plan, i: int) -> dict:
    return {c: float(plan.values[i, j]) for j, c in enumerate(plan.columns)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="0.95,0.44")
    ap.add_argument("--blocks", default="1,4,16,64")
    ap.add_argument("--rows", type=int, default=64)
    ap.add_argument("--singles", type=int, default=8, help="rows also solved one at a time per repeat")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--components", type=int, default=0, help="also print the cost breakdown for this block size")
    ap.add_argument("--fresh", action="store_true", help="also run each block size (> 2 rows) on a second "
                    "precompute that makes only stacked solves, as a `tetmorph doe` process does")
    ap.add_argument("--oneshot", type=int, default=0, metavar="N",
                    help="also run each block size N times in a fresh process of its own (one precompute, one DOE)")
    ap.add_argument("--direct", action="store_true", help="with --oneshot, also run each block size with the "
                    "direct stacked interior solve (TETMORPH_COLUMN_BASIS=0) beside the column basis")
    ap.add_argument("--oneshot-case", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.oneshot_case:
        import json

        size_s, block_s, rows_s = a.oneshot_case.split(":")
        print(json.dumps(oneshot_case(float(size_s), int(block_s), int(rows_s))))
        return
    from solver.workflows.batch_memory import keep_freed_memory

    # as `tetmorph doe` and a Ray actor do (TETMORPH_BATCH_MALLOC=0: glibc's defaults)
    print("allocator:", "keeps freed memory (batch process)" if keep_freed_memory() else "glibc defaults")
    for size in (float(s) for s in a.sizes.split(",")):
        blocks = [int(b) for b in a.blocks.split(",")]
        single = run(size, blocks, a.rows, a.singles, a.repeats, a.fresh)
        if a.oneshot:
            oneshot(size, [b for b in blocks if b > 2], a.rows, a.oneshot, single, a.direct)
        if a.components:
            components(size, a.components)


if __name__ == "__main__":
    main()
