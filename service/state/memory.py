"""Hand memory freed by deleted sessions back to the system."""

from __future__ import annotations

import gc

import tetmorph_core

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
        mkl.free_buffers()
    tetmorph_core.trim_heap()
