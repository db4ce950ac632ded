"""The run-time libraries behind the compiled core: MKL's runtime, OpenBLAS's thread count, loaded objects."""

import os

import numpy as np
import pytest
import scipy.sparse as sp
import tetmorph_core

from solver.linalg import threads
from solver.linalg.pardiso import PardisoFactor, _library, mkl_runtime

needs_mkl = pytest.mark.skipif(mkl_runtime() is None, reason="MKL is an optional library")


def test_a_missing_library_is_an_os_error_naming_it(tmp_path):
    path = str(tmp_path / "libnothing.so")
    with pytest.raises(OSError, match="libnothing.so: cannot be loaded"):
        tetmorph_core.Mkl(path)
    with pytest.raises(OSError, match="libnothing.so: not loaded in this process"):
        tetmorph_core.OpenBLASThreads(path)


def test_a_library_without_openblas_functions_is_refused():
    libm = next(p for p in tetmorph_core.loaded_objects()[2] if os.path.basename(p).startswith("libm."))
    with pytest.raises(OSError, match="no openblas_get_num_threads"):
        tetmorph_core.OpenBLASThreads(libm)


def test_numpys_openblas_is_found_and_set_from_its_own_functions():
    own = threads.openblas(own=True)
    assert own, "numpy's wheel brings an OpenBLAS"
    before = [c.get_num_threads() for c in own]
    try:
        for c in own:
            c.set_num_threads(1)
        assert [c.get_num_threads() for c in own] == [1] * len(own)
    finally:
        for c, n in zip(own, before, strict=True):
            c.set_num_threads(n)
    assert [c.get_num_threads() for c in own] == before


def test_loaded_objects_count_a_new_load(tmp_path):
    import _ctypes
    import ctypes
    import shutil

    if not getattr(_ctypes, "__file__", None):
        pytest.skip("_ctypes is built into this Python")
    adds, subs, paths = tetmorph_core.loaded_objects()
    assert len(paths) > 0 and all(isinstance(p, str) for p in paths)
    copy = tmp_path / "copy.so"
    shutil.copy(_ctypes.__file__, copy)
    ctypes.CDLL(str(copy))
    adds2, subs2, paths2 = tetmorph_core.loaded_objects()
    assert adds2 == adds + 1 and subs2 == subs
    assert str(copy) in paths2
    assert tetmorph_core.load_counts() == (adds2, subs2)


@needs_mkl
def test_pardiso_refuses_arrays_of_the_wrong_item_size_or_length():
    A = sp.random(30, 30, density=0.2, random_state=1, format="csr") + sp.eye(30) * 4
    f = PardisoFactor(A, "test")
    try:
        lib = _library()
        b = np.ones((30, 1), order="F")
        with pytest.raises(ValueError, match="b: items of 4 bytes, expected 8"):
            lib.pardiso(f._pt, f.mtype, 33, 30, f._a, f._ia, f._ja, f._perm, 1, f._iparm, b.astype(np.float32), b)
        with pytest.raises(ValueError, match="x: 10 items, expected at least 30"):
            lib.pardiso(f._pt, f.mtype, 33, 30, f._a, f._ia, f._ja, f._perm, 1, f._iparm, b, np.ones((10, 1)))
        with pytest.raises(ValueError, match="iparm: 3 items, expected at least 64"):
            lib.pardiso(f._pt, f.mtype, 33, 30, f._a, f._ia, f._ja, f._perm, 1, np.zeros(3, np.int32), b, b.copy())
        x = f.solve(np.arange(30.0))
        assert np.abs(A @ x - np.arange(30.0)).max() < 1e-10 * 30
    finally:
        f.release()


@needs_mkl
def test_mkl_threads_are_set_per_calling_thread_and_restored():
    lib = _library()
    prev = lib.set_local_threads(1)
    try:
        assert lib.set_local_threads(1) == 1
    finally:
        lib.set_local_threads(prev)
    assert lib.set_local_threads(prev) == prev
