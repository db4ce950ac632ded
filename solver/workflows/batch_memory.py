"""Allocator settings for a process that runs one batch of stacked solves (``tetmorph doe``, a Ray actor).

A DOE block allocates and frees the same large temporaries over and over:
right-hand sides and solutions of 48 columns (tens of MB), 16 position arrays
and 16 scaled-Jacobian arrays per block. glibc's malloc serves blocks above
its mmap threshold (at most 32 MB by default) with fresh ``mmap`` pages and
returns freed heap tops to the system, so every block pays the page faults of
first touching that memory again. A batch process has one job and a stable
working set, so it can keep freed memory for reuse instead: the mmap
threshold and the trim threshold raised to 1 GB and 2 GB. Peak memory is
then the working set's high-water mark, a few percent above the default's
(``benchmarks/bench_doe.py`` prints peak RSS).

NumPy advises the kernel to back every large array with transparent huge
pages (``madvise(MADV_HUGEPAGE)`` on the array's range). When the kernel has
to compact memory to find huge pages, first touches of advised memory become
several times dearer than plain pages (seen on this VM in a throw-away script
timing ``np.empty`` and one write per page; which memory was hit changed
between runs). The first block of a run is made of such touches, so a batch
process also turns NumPy's advice off; later blocks reuse the memory either way.

The service does not call this: it holds many sessions and must give the
memory of a deleted one back.
"""

from __future__ import annotations

import tetmorph_core

from ..environment import START

__all__ = ["keep_freed_memory"]


def keep_freed_memory() -> bool:
    """Raise glibc's mmap and trim thresholds for this process; False where that is not possible.

    ``TETMORPH_BATCH_MALLOC=0`` leaves the allocator as it is.

    Returns
    -------
    bool
        Whether both settings were applied (False on a C library without ``mallopt``).
    """
    if not START.batch_malloc:
        return False
    done = bool(tetmorph_core.keep_freed_memory())  # glibc's mallopt, from the compiled core
    if done:
        _numpy_hugepages(False)
    return done


def _numpy_hugepages(on: bool) -> None:
    """Turn NumPy's huge-page advice for large arrays on or off (where this NumPy has the switch)."""
    import numpy as np

    core = getattr(np, "_core", None) or getattr(np, "core", None)
    switch = getattr(getattr(core, "multiarray", None), "_set_madvise_hugepage", None)
    if switch is not None:
        switch(on)
