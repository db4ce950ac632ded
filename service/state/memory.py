"""Hand memory freed by deleted sessions back to the system."""

from __future__ import annotations

import ctypes
import ctypes.util
import gc

from solver.linalg.pardiso import mkl_runtime

__all__ = ["release_memory"]


def release_memory() -> None:
    """Collect garbage, empty MKL's buffer pool, and return freed heap pages to the system (glibc).

    Without it a process's resident size stays at its peak after sessions are
    deleted: glibc keeps freed arenas and MKL keeps its buffers for reuse.
    """
    gc.collect()
    mkl = mkl_runtime()
    if mkl:
        try:
            ctypes.CDLL(mkl).mkl_free_buffers()
        except (OSError, AttributeError):
            pass
    name = ctypes.util.find_library("c")
    if name:
        try:
            ctypes.CDLL(name).malloc_trim(0)
        except (OSError, AttributeError):  # not glibc
            pass
