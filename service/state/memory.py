"""Hand memory freed by deleted sessions back to the system."""

from __future__ import annotations

import ctypes
import ctypes.util
import gc

from solver.linalg.pardiso import loaded_mkl

__all__ = ["release_memory"]


def release_memory() -> None:
    """Collect garbage, empty MKL's buffer pool, and return freed heap pages to the system (glibc).

    Without it a process's resident size stays at its peak after sessions are
    deleted: glibc keeps freed arenas and MKL keeps its buffers for reuse.
    """
    gc.collect()
    mkl = loaded_mkl()  # only an MKL this process uses has buffers to free
    if mkl is not None:
        try:
            mkl.mkl_free_buffers()
        except AttributeError:  # pragma: no cover - every MKL has it
            pass
    name = ctypes.util.find_library("c")
    if name:
        try:
            ctypes.CDLL(name).malloc_trim(0)
        except (OSError, AttributeError):  # not glibc
            pass
