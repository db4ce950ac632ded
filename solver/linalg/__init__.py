"""Linear algebra: factorization backends, rank analysis and the constrained-quadratic solvers."""

from .constrained import ConstrainedSolver, RankAnalysis, rank_analysis
from .factorization import backend, cholesky, ldl, lu

__all__ = ["ConstrainedSolver", "RankAnalysis", "rank_analysis", "backend", "cholesky", "ldl", "lu"]
