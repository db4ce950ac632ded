"""PARDISO's factor gives the same bits on one thread and on two (its reproducible mode), and so
does its ordering alone.

Each count runs in a fresh interpreter, since MKL reads its thread count from the
environment. The systems are large enough (8,000 unknowns) for MKL to factor them
on two threads: with the settings before the reproducible mode, the LU solution
differed between the two counts.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp

from solver.linalg.pardiso import PardisoFactor, mkl_runtime

pytestmark = pytest.mark.skipif(mkl_runtime() is None, reason="MKL is an optional library")

SCRIPT = """
import hashlib, sys
import numpy as np
from tests.solver.linalg.test_pardiso import grid_system
from solver.linalg import pardiso
for mtype in (11, 2):
    A, b = grid_system(20, symmetric=mtype == 2)
    x = pardiso.PardisoFactor(A, "grid", mtype=mtype).solve(b)
    print(mtype, hashlib.sha256(np.ascontiguousarray(x).tobytes()).hexdigest())
A, _ = grid_system(20, symmetric=False)
for ordering in (pardiso.ORDERING_ONLY, pardiso.ORDERING):
    pardiso.ORDERING_ONLY = ordering
    print("perm", hashlib.sha256(pardiso.nested_dissection(A).tobytes()).hexdigest())
"""


def grid_system(n: int, symmetric: bool) -> tuple[sp.csr_matrix, np.ndarray]:
    """The 7-point Laplacian of an n^3 grid plus a random positive diagonal (made non-symmetric
    unless ``symmetric``), and 3 right-hand sides; the same on every call."""
    rng = np.random.default_rng(1)
    eye = sp.identity(n)
    line = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    A = sp.kron(sp.kron(line, eye), eye) + sp.kron(sp.kron(eye, line), eye) + sp.kron(sp.kron(eye, eye), line)
    A = A + sp.diags(rng.uniform(0.0, 0.1, n**3))
    if not symmetric:
        A = A + 0.01 * sp.triu(A, 1)
    return sp.csr_matrix(A), rng.standard_normal((n**3, 3))


def _solutions(threads: int) -> list[str]:
    env = {**os.environ, "MKL_NUM_THREADS": str(threads), "OMP_NUM_THREADS": str(threads)}
    out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=120,
                         check=True)
    return out.stdout.split()


def test_one_thread_and_two_give_the_same_bits():
    one, two = _solutions(1), _solutions(2)
    assert len(one) == 8  # LU and Cholesky, each with its hash; the two orderings' permutations
    assert one == two
    # the ordering alone (the multifrontal LU's), OpenMP's: the one-thread ordering's permutation
    assert one[5] == one[7]


def test_the_grid_systems_are_solved():
    for mtype in (11, 2):
        A, b = grid_system(20, symmetric=mtype == 2)
        x = PardisoFactor(A, "grid", mtype=mtype).solve(b)
        assert np.abs(A @ x - b).max() <= 1e-10 * np.abs(b).max()
