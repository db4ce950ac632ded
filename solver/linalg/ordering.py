"""The fill-reducing ordering of a symmetric system factored by CHOLMOD.

CHOLMOD's own METIS ordering draws its random numbers from the C library's
``rand()``, whose state the whole process shares. METIS seeds it at the start
of every ordering, but any other thread that calls ``rand()`` meanwhile (a Ray
worker's and a web server's threads do) moves the sequence: the same matrix
is then ordered differently from run to run, and the factor rounds
differently. A deck morphed on a Ray actor differed from the single-process
deck in the last bit of most coordinates this way.

The ordering here is PARDISO's nested dissection (its own METIS, phase 11
only, :func:`~solver.linalg.pardiso.nested_dissection`): the same permutation
whatever other threads do, no more fill than CHOLMOD's METIS on the boundary
systems (``benchmarks/measure_choices.py --only orderings``), and the GIL
released while it runs. Where MKL is missing, CHOLMOD's AMD, which draws no
random numbers, orders the system instead.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import FactorizationError
from .pardiso import nested_dissection

__all__ = ["symmetric_ordering"]


def symmetric_ordering(M: sp.spmatrix) -> np.ndarray | None:
    """A nested-dissection permutation of ``M``, the same in every process; None where MKL is missing.

    Parameters
    ----------
    M : (n, n) sparse matrix
        Symmetric (both triangles stored).

    Returns
    -------
    perm : (n,) int64 array or None
        Row ``i`` of the ordered matrix is row ``perm[i]`` of ``M``.
    """
    try:
        return nested_dissection(M)
    except FactorizationError as e:
        if e.code == "unknown_backend":  # MKL not installed: the caller orders with AMD
            return None
        raise
