"""The fill-reducing ordering of a symmetric system factored by CHOLMOD.

CHOLMOD's own METIS ordering draws its random numbers from the C library's
``rand()``, whose state the whole process shares. METIS seeds it at the start
of every ordering, but any other thread that calls ``rand()`` meanwhile (a Ray
worker's and a web server's threads do) moves the sequence: the same matrix
is then ordered differently from run to run, and the factor rounds
differently. A deck morphed on a Ray actor differed from the single-process
deck in the last bit of most coordinates this way.

The ordering here draws no random numbers from it: PARDISO's nested
dissection (its own METIS, phase 11 only,
:func:`~solver.linalg.pardiso.nested_dissection`) with its elimination tree
post-ordered (CHOLMOD keeps a given order as it is, and without the post-order
its supernodes break up), given to CHOLMOD. It factors and solves the boundary
systems of the bracket, from 107k to 1M tets, as fast as CHOLMOD's METIS or
faster, for about the same fill. Below :data:`AMD_BELOW` unknowns, and where
MKL is missing, CHOLMOD's AMD orders instead (no random numbers either); on
such small systems the fill matters little.

``benchmarks/measure_choices.py --only orderings`` measures all of them.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import FactorizationError
from .multifrontal import postordered
from .pardiso import nested_dissection

__all__ = ["AMD_BELOW", "symmetric_ordering"]

#: Unknowns below which CHOLMOD's AMD orders a system (no PARDISO ordering).
AMD_BELOW = 2_000


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
        perm = nested_dissection(M)
    except FactorizationError as e:
        if e.code == "unknown_backend":  # MKL not installed: the caller orders with AMD
            return None
        raise
    # CHOLMOD keeps a natural order as it is, not post-ordered: without it, supernodes break up
    return postordered(M, perm)
