"""CHOLMOD's factor orders a system the same way whatever other threads of the process do.

CHOLMOD's METIS ordering draws from the C library's ``rand()``, which every
thread of a process shares. Here a native thread calls ``rand()`` without pause
(as a Ray worker's or a server's threads may) while the same matrix is factored
again and again: with CHOLMOD's METIS, the permutation and the solution's bits
changed from one factorization to the next.
"""

from __future__ import annotations

import ctypes
import hashlib
import shutil
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from solver.linalg import ordering
from solver.linalg.factorization import backend, cholesky
from solver.linalg.ordering import symmetric_ordering
from solver.linalg.pardiso import mkl_runtime

from .test_pardiso import grid_system

pytestmark = pytest.mark.skipif(backend() != "cholmod", reason="the CHOLMOD backend is not installed")

RAND_THREAD = r"""
#include <pthread.h>
#include <stdlib.h>
static volatile int running;
static pthread_t thread;
static void *draw(void *unused) { (void)unused; while (running) rand(); return NULL; }
void start(void) { running = 1; pthread_create(&thread, NULL, draw, NULL); }
void stop(void) { running = 0; pthread_join(thread, NULL); }
"""


@contextmanager
def drawing_random_numbers(folder: Path) -> Iterator[None]:
    """A native thread that calls the C library's ``rand()`` until the block ends."""
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc, "a C compiler is installed with the project's build tools"
    (folder / "draw.c").write_text(RAND_THREAD)
    subprocess.run([cc, "-O1", "-shared", "-fPIC", "-o", str(folder / "draw.so"), str(folder / "draw.c"),
                    "-lpthread"], check=True, timeout=60)
    lib = ctypes.CDLL(str(folder / "draw.so"))
    lib.start()
    try:
        yield
    finally:
        lib.stop()


def _digest(f, b: np.ndarray) -> str:
    return hashlib.sha256(f._f.P().tobytes() + np.ascontiguousarray(f.solve(b)).tobytes()).hexdigest()


@pytest.mark.parametrize("amd_below", [10**9, 0], ids=["amd", "nested-dissection"])
def test_the_factor_is_the_same_while_another_thread_draws_random_numbers(tmp_path, monkeypatch, amd_below):
    if amd_below == 0 and mkl_runtime() is None:
        pytest.skip("MKL is an optional library")
    monkeypatch.setattr(ordering, "AMD_BELOW", amd_below)
    A, b = grid_system(14, symmetric=True)
    quiet = _digest(cholesky(A, "grid"), b)
    with drawing_random_numbers(tmp_path):
        busy = {_digest(cholesky(A, "grid"), b) for _ in range(12)}
    assert busy == {quiet}


@pytest.mark.parametrize("amd_below", [10**9, 0], ids=["amd", "nested-dissection"])
def test_the_ordered_factor_solves_the_system_as_given(monkeypatch, amd_below):
    if amd_below == 0 and mkl_runtime() is None:
        pytest.skip("MKL is an optional library")
    monkeypatch.setattr(ordering, "AMD_BELOW", amd_below)
    A, b = grid_system(10, symmetric=True)
    f = cholesky(A, "grid")
    x = f.solve(b)
    assert np.abs(A @ x - b).max() <= 1e-10 * np.abs(b).max()
    x1 = f.solve(b[:, 0])
    assert x1.shape == (A.shape[0],) and np.allclose(x1, x[:, 0], rtol=0, atol=1e-12)
    P = f._f.P()
    assert np.array_equal(np.sort(P), np.arange(A.shape[0]))
    L = f._f.L()  # L L^T is the matrix permuted by P
    assert abs(L @ L.T - A[P][:, P]).max() <= 1e-12 * abs(A).max()


@pytest.mark.skipif(mkl_runtime() is None, reason="MKL is an optional library")
def test_the_ordering_is_a_permutation_that_reduces_fill(monkeypatch):
    A, _ = grid_system(12, symmetric=True)
    assert A.shape[0] < ordering.AMD_BELOW and symmetric_ordering(A) is None  # a small system: AMD
    monkeypatch.setattr(ordering, "AMD_BELOW", 0)
    p = symmetric_ordering(A)
    assert p is not None and np.array_equal(np.sort(p), np.arange(A.shape[0]))
    from sksparse.cholmod import cholesky as chol

    natural = chol(A.tocsc(), mode="supernodal", ordering_method="natural").L().nnz
    ordered = chol(A[p][:, p].tocsc(), mode="supernodal", ordering_method="natural").L().nnz
    assert ordered < natural / 2
