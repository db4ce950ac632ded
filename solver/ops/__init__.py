"""Operators: pure functions of the rest mesh that build the method's matrices."""

import numba

from ..environment import START

# Solves run concurrently in threads (one precompute serves several requests), and numba's
# "workqueue" layer aborts on concurrent parallel launches: require a thread-safe layer
# (TBB or OpenMP, both installed with MKL) unless the user chose one.
if START.numba_threading_layer is None:
    numba.config.THREADING_LAYER = "threadsafe"  # type: ignore[attr-defined]

from .boundary_facets import boundary_facets, simplex_edges
from .cotmatrix import cotmatrix, uniform_matrix, voronoi_areas
from .mvc_matrix import mvc_matrix
from .rotation import log_to_matrix, rotate_by_log

__all__ = ["boundary_facets", "simplex_edges", "cotmatrix", "uniform_matrix", "voronoi_areas", "mvc_matrix",
           "log_to_matrix", "rotate_by_log"]
