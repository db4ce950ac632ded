"""Load every numba kernel of tetmorph ahead of use (compiling and caching it on disk the first time).

numba compiles a kernel on its first call and keeps the machine code in
``__pycache__`` next to the module (``cache=True``). Later processes load it
from there, but a process's first kernel also starts numba's own runtime
(its typing and lowering registries), a fixed cost per process. The
document models (pydantic, :mod:`solver.documents`) are built on first use
too. :func:`load_kernels` pays all of it ahead of the first set-up:

- ``make install`` and the Docker image run ``python -m solver.kernels`` once,
  so no process compiles;
- the service calls it at start, before ``/ready`` answers ready, so no
  client's first session waits for it;
- a pipeline that sets up one mesh per process may call it while it reads
  its deck.

``benchmarks/bench_update.py`` reports its cost per process next to the
peer's ``import igl``.

    python -m solver.kernels        # prints the seconds it took
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from collections.abc import Iterator
from typing import TextIO

import numpy as np

__all__ = ["load_kernels", "announced"]


@contextlib.contextmanager
def announced(what: str, after_s: float = 1.0, stream: TextIO | None = None) -> Iterator[None]:
    """Say on standard error what is being done, once it has taken ``after_s`` seconds, and when it ends.

    Short work says nothing; a first use that compiles the kernels (minutes)
    or a cold load (a second or two) is never silent.

    Parameters
    ----------
    what : str
        ``"loading the solver's kernels"``.
    after_s : float
    stream : file, optional
        Default: ``sys.stderr``.
    """
    out = stream if stream is not None else sys.stderr
    done = threading.Event()
    said = threading.Event()
    t0 = time.perf_counter()

    def watch() -> None:
        if not done.wait(after_s):
            print(f"tetmorph: {what}...", file=out, flush=True)
            said.set()

    watcher = threading.Thread(target=watch, name="tm-announce", daemon=True)
    watcher.start()
    try:
        yield
    finally:
        done.set()
        watcher.join()
        if said.is_set():
            print(f"tetmorph: {what}: done in {time.perf_counter() - t0:.1f} s", file=out, flush=True)


def load_kernels() -> float:
    """Run every kernel once on a tiny mesh; returns the seconds taken.

    Cheap once a process has run it (the kernels stay loaded).
    """
    import scipy.sparse as sp

    from .linalg.layout import c_copy, fortran_copy
    from .linalg.residual import block_residual, corrected, coupled_residual_norms
    from .ops.displacement import max_displacement
    from .ops.elements import corner_jacobians, oriented
    from .ops.mean_value_coordinates import mvc_triangle_weights
    from .ops.mvc_matrix import mvc_matrix
    from .ops.rotation import rotate_by_log
    from .testing import cube_mesh
    from .validity.check import _gather_between, tet_check
    from .validity.quality import tet_quality

    t0 = time.perf_counter()
    V, T = cube_mesh(3)
    interior = np.zeros(len(V), bool)
    interior[np.flatnonzero((V > 0).all(axis=1) & (V < 1).all(axis=1))] = True
    mvc_matrix(V, T, interior)
    tet_quality(V, T)
    for ints in (np.int32, np.int64):
        tet_check(V, T.astype(ints), rest_flat=np.zeros(len(T), bool))
    _gather_between(np.ones(4), 0.0, 2.0, np.zeros(1, np.int64), np.empty(4))  # large meshes' selection
    rotate_by_log(V, 0.1 * V)
    max_displacement(V, V)
    for dt in (np.float32, np.float64):
        c_copy(fortran_copy(V, dt), dt)
    mvc_triangle_weights(V[:3], V[T[:3, :3]])
    H = np.array([[0, 1, 2, 3, 4, 5, 6, 7]])
    X = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]])
    corner_jacobians(X, oriented(X, H, "hexahedron"), "hexahedron")
    block_residual(sp.identity(4, format="csr"), np.ones((4, 6)), np.ones((4, 6)), 3)
    block_residual(sp.identity(4, format="csr"), np.ones((4, 3)), np.ones((4, 3)), 3)
    corrected(np.zeros((4, 3)), np.arange(4), np.ones((4, 6)), 3)
    for X in (np.ones((4, 3), np.float32), np.ones((4, 6), np.float32)):  # single-precision solutions
        block_residual(sp.identity(4, format="csr"), np.ones(X.shape), X, 3, store=False)
        corrected(np.zeros((4, 3)), np.arange(4), X, 0)
        coupled_residual_norms(sp.identity(4, format="csr"), sp.identity(4, format="csr"), np.ones((4, 3)),
                               np.ones(X.shape), X, 3)
    _supernodal_kernels()
    _document_models()
    return time.perf_counter() - t0


def _document_models() -> None:
    """The SPEC and MOVE models (pydantic and the models' validators are built on first use)."""
    from .constraints.move import parse_move
    from .constraints.spec import parse_spec

    spec = parse_spec({"selections": {"a": {"ids": [0]}, "b": {"ids": [1]}}, "fixed": ["a"], "handles": {"h": "b"}})
    parse_move({"handles": {"h": {"translation": [0, 0, 0]}}}, list(spec.handles), spec.names)


def _supernodal_kernels() -> None:
    """The supernodal sweeps (both precisions, three and many columns) and the fused products."""
    import scipy.sparse as sp

    from .errors import FactorizationError
    from .linalg.multifrontal import lu_multifrontal
    from .linalg.products import combination, gradient, offset_product, product, shifted_product, stacked_differences
    from .linalg.supernodal import SupernodalFactor

    n = 40
    A = sp.csc_matrix(sp.diags([-1.0, 4.0, -1.0], [-1, 0, 1], shape=(n, n)))
    for single in (False, True):
        try:
            f = lu_multifrontal(A, single)
        except FactorizationError:  # no MKL for the ordering: the LU path is not used either
            break
        f.solve(np.ones((n, 3)))
        f.solve(np.ones((n, 12)))
    L = sp.csc_matrix(sp.tril(A))
    SupernodalFactor(L, None, np.arange(n)).solve(np.ones((n, 3)))
    Acsr = sp.csr_matrix(A)
    gradient(Acsr, Acsr, np.ones((n, 3)), np.ones((n, 3)))
    gradient(Acsr, Acsr, np.ones((2, n, 3)), np.ones((n, 6)))
    shifted_product(Acsr, np.arange(n), np.ones((n, 3)), np.ones((n, 3)), np.ones((n, 3)))
    offset_product(Acsr, np.ones((n, 6)), np.ones((n, 3)))
    stacked_differences([np.ones((n, 3))] * 2, np.arange(n), np.ones((n, 3)))
    stacked_differences([np.ones((n, 3))] * 2, np.arange(n), np.ones((n, 3)), order="F")
    product(Acsr, np.ones((n, 4)))
    combination(np.ones((n, 4), np.float32), np.ones((4, 6)), np.float32)
    combination(np.ones((n, 4)), np.ones((4, 6)))


if __name__ == "__main__":
    with announced("compiling the solver's kernels (once per install location; a few minutes)", after_s=2.0):
        took = load_kernels()
    print(f"tetmorph kernels ready ({took:.1f} s)")
