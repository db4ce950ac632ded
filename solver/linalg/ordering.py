"""The fill-reducing ordering of a symmetric system factored by CHOLMOD.

CHOLMOD's own METIS ordering draws its random numbers from the C library's
``rand()``, whose state the whole process shares. METIS seeds it at the start
of every ordering, but any other thread that calls ``rand()`` meanwhile (a Ray
worker's and a web server's threads do) moves the sequence: the same matrix
is then ordered differently from run to run, and the factor rounds
differently. A deck morphed on a Ray actor differed from the single-process
deck in the last bit of most coordinates this way.

Both orderings here draw no random numbers from it:

* below :data:`AMD_BELOW` unknowns, CHOLMOD's AMD: it factors faster than
  METIS there, for a little more fill and the same solve time;
* above, PARDISO's nested dissection (its own METIS, phase 11 only,
  :func:`~solver.linalg.pardiso.nested_dissection`), given to CHOLMOD: no more
  fill than CHOLMOD's METIS, in about its time on large systems, where AMD's
  fill grows. Its fixed cost makes it the slower one on small systems.
  Where MKL is missing, AMD orders every size.

``benchmarks/measure_choices.py --only orderings`` measures all of them.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import FactorizationError
from .pardiso import nested_dissection

__all__ = ["AMD_BELOW", "symmetric_ordering"]

#: Unknowns below which CHOLMOD's AMD orders a system (no PARDISO ordering).
AMD_BELOW = 20_000


def symmetric_ordering(M: sp.spmatrix) -> np.ndarray | None:
    """A nested-dissection permutation of ``M``, the same in every process; None: order with AMD.

    Parameters
    ----------
    M : (n, n) sparse matrix
        Symmetric (both triangles stored).

    Returns
    -------
    perm : (n,) int64 array or None
        Row ``i`` of the ordered matrix is row ``perm[i]`` of ``M``; None below
        :data:`AMD_BELOW` unknowns or where MKL is missing.
    """
    if M.shape[0] < AMD_BELOW:
        return None
    try:
        return nested_dissection(M)
    except FactorizationError as e:
        if e.code == "unknown_backend":  # MKL not installed: the caller orders with AMD
            return None
        raise
