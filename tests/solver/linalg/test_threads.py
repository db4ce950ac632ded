"""Thread-count helpers: OpenBLAS on one thread while any block needs it, restored after the last."""

from __future__ import annotations

from solver.linalg import threads


def _counts() -> list[int]:
    """NumPy's and SciPy's own OpenBLAS thread counts, the libraries read afresh."""
    return [c.get_num_threads() for c in threads._own_openblas()]


def _wait_for_blocks_to_end() -> None:
    """A solve left running by an earlier test of this process may still be inside a block: let it end."""
    import time

    deadline = time.monotonic() + 10
    while threads._BLAS_USERS and time.monotonic() < deadline:
        time.sleep(0.01)
    assert threads._BLAS_USERS == 0, "a block was entered and never left"


def test_overlapping_blocks_restore_openblas_after_the_last_exit():
    _wait_for_blocks_to_end()
    before = _counts()
    assert before  # numpy's own OpenBLAS is there to set
    a, b = threads.one_blas_thread(), threads.one_blas_thread()
    a.__enter__()
    assert _counts() == [1] * len(before)
    b.__enter__()
    a.__exit__(None, None, None)  # the first one out, as when two service threads overlap
    assert _counts() == [1] * len(before)
    b.__exit__(None, None, None)
    assert _counts() == before


def test_a_block_sets_openblas_whatever_thread_set_it_first():
    """threadpoolctl (3.8) lets only the first thread that set a pthreads OpenBLAS set it while that thread
    lives. A service's build thread quieting CHOLMOD's OpenBLAS took that role, and every block of another
    thread (the solve pool's, the main thread's) then left OpenBLAS on all its threads."""
    import threading

    from threadpoolctl import OpenBLASController, ThreadpoolController

    clear = getattr(OpenBLASController, "clear_controlling_thread", None)  # threadpoolctl >= 3.8
    if clear is not None:
        clear(force=True)
    _wait_for_blocks_to_end()
    before = _counts()
    set_first, leave = threading.Event(), threading.Event()

    def build_thread():  # sets every OpenBLAS through threadpoolctl first, then lives on, like a pool's worker
        for c in ThreadpoolController().lib_controllers:
            if c.internal_api == "openblas":
                c.set_num_threads(c.get_num_threads())
        set_first.set()
        leave.wait(30)

    t = threading.Thread(target=build_thread)
    t.start()
    try:
        assert set_first.wait(30)
        with threads.one_blas_thread():
            assert _counts() == [1] * len(before)
        assert _counts() == before
    finally:
        leave.set()
        t.join()
        if clear is not None:
            clear(force=True)


def test_the_libraries_are_looked_up_again_after_a_load(monkeypatch, tmp_path):
    import _ctypes
    import ctypes
    import shutil

    import pytest

    if not getattr(_ctypes, "__file__", None) or threads._loads() is None:
        pytest.skip("_ctypes built in, or no dl_iterate_phdr")
    looked = []
    own = threads._own_openblas
    monkeypatch.setattr(threads, "_own_openblas", lambda: looked.append(1) or own())
    _wait_for_blocks_to_end()
    with threads.one_blas_thread():
        pass
    n = len(looked)
    with threads.one_blas_thread():
        pass
    assert len(looked) == n  # nothing loaded since: the list found before
    copy = tmp_path / "copy.so"
    shutil.copy(_ctypes.__file__, copy)
    ctypes.CDLL(str(copy))  # a new shared object in the process (its Python init never runs)
    with threads.one_blas_thread():
        pass
    assert len(looked) == n + 1


def test_free_threads_share_the_free_cores(monkeypatch):
    n = threads.cores()
    monkeypatch.setattr(threads, "_running_tasks", lambda: 1)  # only the caller runs
    assert threads.free_threads(1) == n
    assert threads.free_threads(2) == max(1, n // 2)
    monkeypatch.setattr(threads, "_running_tasks", lambda: n + 1)  # every core taken by another task
    assert threads.free_threads(1) == 1
    monkeypatch.setattr(threads, "_running_tasks", lambda: None)  # no /proc: the cores of the mask
    assert threads.free_threads(1) == n


def test_busy_processes_leave_one_thread():
    import subprocess
    import sys
    import time

    spin = "import time\nend = time.monotonic() + 20\nwhile time.monotonic() < end:\n    pass\n"
    procs = [subprocess.Popen([sys.executable, "-c", spin]) for _ in range(threads.cores())]
    try:
        time.sleep(0.5)
        seen = [threads.free_threads(1) for _ in range(20)]
    finally:
        for p in procs:
            p.kill()
            p.wait()
    assert max(seen) == 1 or threads.cores() == 1, seen


def test_solving_counts_solves_and_sets_the_kernels_threads_for_the_caller_only(monkeypatch):
    import threading

    import tetmorph_core

    monkeypatch.setattr(threads, "_running_tasks", lambda: threads.in_flight())
    before = tetmorph_core.get_num_threads()
    threads.in_flight_reset()
    seen = {}
    inside = threading.Event()
    leave = threading.Event()

    def other():
        with threads.solving() as k:
            seen["other"] = (k, tetmorph_core.get_num_threads())
            inside.set()
            leave.wait(10)

    t = threading.Thread(target=other)
    t.start()
    inside.wait(10)
    try:
        with threads.solving() as k:
            seen["main"] = (k, tetmorph_core.get_num_threads(), threads.in_flight())
            with threads.solving() as k2:  # nested: the outer count
                assert k2 == k and threads.in_flight() == 2
    finally:
        leave.set()
        t.join()
    assert seen["other"][0] == seen["other"][1] == min(threads.cores(), tetmorph_core.max_threads())
    assert seen["main"][:2] == (max(1, threads.cores() // 2),) * 2 and seen["main"][2] == 2
    assert threads.in_flight() == 0 and threads.in_flight_peak() == 2
    assert tetmorph_core.get_num_threads() == before


def test_configure_caps_every_solve():
    import pytest

    try:
        threads.configure(max_threads=1)
        with threads.solving() as k:
            assert k == 1
        assert threads.solve_threads(48) == 1
    finally:
        threads.configure(None)
    with pytest.raises(ValueError, match="max_threads"):
        threads.configure(max_threads=-1)


def test_spin_settings_are_set_before_the_runtimes_load_and_yield_to_the_user():
    import os
    import subprocess
    import sys

    code = "import os, solver; print(os.environ.get('GOMP_SPINCOUNT'), os.environ.get('OPENBLAS_THREAD_TIMEOUT'))"
    env = {k: v for k, v in os.environ.items() if k not in ("GOMP_SPINCOUNT", "OPENBLAS_THREAD_TIMEOUT",
                                                           "OMP_WAIT_POLICY")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["10000", "16"]
    out = subprocess.run([sys.executable, "-c", code], env={**env, "GOMP_SPINCOUNT": "7"}, capture_output=True,
                         text=True, check=True)
    assert out.stdout.split() == ["7", "16"]
