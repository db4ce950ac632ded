"""Thread-count helpers: OpenBLAS on one thread while any block needs it, restored after the last."""

from __future__ import annotations

from solver.linalg import threads


def _counts() -> list[int]:
    return [c.get_num_threads() for c in threads._own_openblas()]


def test_overlapping_blocks_restore_openblas_after_the_last_exit():
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
