"""The named choices of the documents that the library also needs before pydantic is loaded.

:mod:`solver.options` reads them at ``import solver``; the SPEC's model (:mod:`solver.documents.spec`)
states them in its schema. This module imports nothing.
"""

from __future__ import annotations

__all__ = ["BACKENDS", "PRECISIONS"]

#: Symmetric positive definite backends; ``auto`` picks CHOLMOD, then PARDISO, then SciPy, whichever
#: is installed first.
BACKENDS = ("auto", "cholmod", "pardiso", "scipy")
#: The interior solve's precision: ``mixed`` factors the mean-value system in single precision and
#: checks (and refines) in double; ``exact`` keeps a double-precision factor.
PRECISIONS = ("mixed", "exact")
