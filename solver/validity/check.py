"""The per-update element check: inverted, degenerate and (quadratic) folded elements.

:class:`ElementCheck` is built once from the rest mesh and is immutable;
:meth:`ElementCheck.check` is a pure function of the positions (and of a
mid-side :class:`~solver.validity.midside.Placement` that already holds the
node Jacobians of those positions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .midside import Placement, node_jacobians
from .quality import DEGENERATE_TOL, element_jacobians, first_percentile

__all__ = ["ElementCheck", "CheckResult"]


@dataclass(frozen=True, eq=False)
class CheckResult:
    """What the check found at one set of positions.

    Attributes
    ----------
    bad : (M,) bool array
        Inverted (Jacobian <= 0), degenerate (``|scaled Jacobian| <= DEGENERATE_TOL``),
        or, for quadratic elements valid at rest, folded at a node.
    sj : (M,) float array
        Scaled Jacobian of every element (corner tets for quadratic meshes).
    degenerate : (M,) bool array
    node_jacobians : (m, 10) float array or None
        Quadratic meshes only.
    """

    bad: np.ndarray
    sj: np.ndarray
    degenerate: np.ndarray
    node_jacobians: np.ndarray | None = None

    @property
    def count(self) -> int:
        """Number of bad elements."""
        return int(np.count_nonzero(self.bad))


class ElementCheck:
    """The element check of one mesh, set up once.

    Parameters
    ----------
    V0 : (n, 3) float array
        Rest positions.
    T : (m, 4) int array
        Tetrahedra (corner tets of quadratic elements).
    cells : dict
        Hexahedra, wedges and pyramids.
    T10 : (m, 10) int array, optional
        Quadratic elements; those already folded at rest are reported apart
        (:attr:`valid_rest`), not counted as inverted by a morph.
    """

    def __init__(self, V0: np.ndarray, T: np.ndarray, cells: dict[str, np.ndarray],
                 T10: np.ndarray | None = None) -> None:
        self.T = np.ascontiguousarray(T)
        self.cells = cells
        self.T10 = T10
        self.valid_rest = node_jacobians(V0, T10).min(axis=1) > 0 if T10 is not None else None
        rest = self.check(V0)
        sj = rest.sj
        self.sj_before = (float(sj.min()) if sj.size else None, first_percentile(sj) if sj.size else None)

    def check(self, P: np.ndarray, placement: Placement | None = None) -> CheckResult:
        """Check every element at positions ``P``.

        Parameters
        ----------
        P : (n, 3) float array
        placement : Placement, optional
            The mid-side placement that produced ``P``; its node Jacobians are
            reused when it holds them for exactly these positions.

        Returns
        -------
        CheckResult
        """
        vol6, sj = element_jacobians(P, self.T, self.cells)
        degenerate = np.abs(sj) <= DEGENERATE_TOL
        bad = (vol6 <= 0) | degenerate
        dj = None
        if self.T10 is not None:
            if placement is not None and placement.jacobians is not None and placement.P is P:
                dj = placement.jacobians
            else:
                dj = node_jacobians(P, self.T10)
            assert self.valid_rest is not None
            bad |= (dj.min(axis=1) <= 0) & self.valid_rest
        return CheckResult(bad, sj, degenerate, dj)
