"""Compile (and cache on disk) every numba kernel of tetmorph once, ahead of use.

numba compiles a kernel on its first call and keeps the machine code in
``__pycache__`` next to the module (``cache=True``); later processes load it
in milliseconds. The first compilation of all kernels takes about 10 s on the
reference machine (two cores), so ``make install`` and the Docker image run
``python -m solver.ops.kernels`` once instead of leaving it to the first request.

    python -m solver.ops.kernels        # prints the seconds it took
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ["compile_all"]


def compile_all() -> float:
    """Run every kernel on a tiny mesh; returns the seconds taken."""
    import scipy.sparse as sp

    from ..linalg.layout import c_copy, fortran_copy
    from ..linalg.residual import block_residual, corrected, coupled_residual_norms
    from ..testing import cube_mesh
    from ..validity.check import tet_check
    from ..validity.quality import tet_quality
    from .displacement import max_displacement
    from .elements import corner_jacobians, oriented
    from .mean_value_coordinates import mvc_triangle_weights
    from .mvc_matrix import mvc_matrix
    from .rotation import rotate_by_log

    t0 = time.perf_counter()
    V, T = cube_mesh(3)
    interior = np.zeros(len(V), bool)
    interior[np.flatnonzero((V > 0).all(axis=1) & (V < 1).all(axis=1))] = True
    mvc_matrix(V, T, interior)
    tet_quality(V, T)
    for ints in (np.int32, np.int64):
        tet_check(V, T.astype(ints), rest_flat=np.zeros(len(T), bool))
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
    return time.perf_counter() - t0


def _supernodal_kernels() -> None:
    """The supernodal sweeps (both precisions, three and many columns) and the fused products."""
    import scipy.sparse as sp

    from ..errors import FactorizationError
    from ..linalg.multifrontal import lu_multifrontal
    from ..linalg.products import combination, gradient, offset_product, product, shifted_product, stacked_differences
    from ..linalg.supernodal import SupernodalFactor

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
    print(f"tetmorph kernels ready ({compile_all():.1f} s)")
