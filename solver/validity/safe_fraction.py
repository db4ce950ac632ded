"""The largest valid fraction of a move, by bisection."""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["safe_fraction", "SAFE_TOL"]

#: Bracket width of the safe-fraction bisection (10 halvings).
SAFE_TOL = 1.0 / 1024


def safe_fraction(valid_at: Callable[[float], bool], tol: float = SAFE_TOL,
                  whole_valid: bool | None = None) -> tuple[float, int]:
    """Largest ``f`` in [0, 1] with ``valid_at(f)``, by bisection from a valid ``f = 0``.

    Parameters
    ----------
    valid_at : callable
        ``valid_at(f) -> bool``: whether the move scaled by ``f`` inverts no
        element (one back-substitution and one check per call).
    tol : float
        Width of the final bracket.
    whole_valid : bool, optional
        Whether ``f = 1`` is known to be valid (saves one call).

    Returns
    -------
    f : float
        1.0 when the whole move is valid; else the valid end of the final
        bracket (``[f, f + tol]`` contains the first invalid fraction that
        bisection meets).
    steps : int
        Calls of ``valid_at``.

    Examples
    --------
    >>> safe_fraction(lambda f: f <= 0.3)
    (0.2998046875, 11)
    """
    steps = 0
    if whole_valid is None:
        steps = 1
        whole_valid = valid_at(1.0)
    if whole_valid:
        return 1.0, steps
    lo, hi = 0.0, 1.0
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        steps += 1
        if valid_at(mid):
            lo = mid
        else:
            hi = mid
    return lo, steps
