"""Operators: pure functions of the rest mesh that build the method's matrices."""

from .boundary_facets import boundary_facets, simplex_edges
from .cotmatrix import cotmatrix, uniform_matrix, voronoi_areas
from .mvc_matrix import mvc_matrix
from .rotation import log_to_matrix, rotate_by_log

__all__ = ["boundary_facets", "simplex_edges", "cotmatrix", "uniform_matrix", "voronoi_areas", "mvc_matrix",
           "log_to_matrix", "rotate_by_log"]
