"""The per-update element check: inverted, degenerate and (quadratic) folded elements.

:class:`ElementCheck` is built once from the rest mesh and is immutable;
:meth:`ElementCheck.check` is a pure function of the positions. For meshes of
linear tetrahedra the check is three compiled, multi-threaded passes
(src/core/validity.cpp):

1. ``validity_sj`` (:func:`_sj_kernel`), the scaled Jacobian of every tet (its
   sign is the sign of the volume), a loop without branches over the corners
   stored as four rows, which the compiler vectorizes with gathers from the
   positions;
2. ``validity_tally``, per chunk of tets, the counts of bad and
   degenerate tets, the first bad ids, and how many
   values fall below and inside a bracket of the 1st percentile taken from a
   strided sample (:func:`_bracket`);
3. ``validity_gather_between`` (:func:`_gather_between`), the values inside the
   bracket, from which the 1st percentile is selected exactly (:func:`_select`).

Three light passes beat one fused pass that keeps a histogram, because the
histogram's scattered increments serialize (``python
benchmarks/measure_choices.py --only check``). Mixed
and quadratic meshes take the general path (corner and node Jacobians).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import tetmorph_core

from ..errors import MAX_IDS as REPORT_IDS
from .midside import Placement, node_jacobians
from .quality import DEGENERATE_TOL, element_jacobians, first_percentile

__all__ = ["ElementCheck", "SurfaceCheck", "CheckResult", "tet_check", "triangle_quality"]

#: Below this many elements the 1st percentile is selected by a plain partition.
_SELECT_DIRECT = 65536
#: Elements sampled (at a fixed stride) to bracket the 1st percentile of a larger mesh.
_SAMPLE = 16384


@dataclass(frozen=True, eq=False)
class CheckResult:
    """What the check found at one set of positions.

    Attributes
    ----------
    count : int
        Bad elements: inverted (Jacobian <= 0), degenerate (``|scaled Jacobian| <=
        DEGENERATE_TOL``), or, for quadratic elements valid at rest, folded at a node.
    ids : (k,) int array
        The first ``REPORT_IDS`` bad element ids, ascending.
    degenerate : int
        Degenerate elements.
    min_sj, p01_sj : float or None
        Smallest and 1st-percentile (order statistic ``m // 100``) scaled Jacobian.
    sj_ordered : (M,) float array
        Scaled Jacobian of every element, in the order the check ran them (``order``).
    node_jacobians : (m, 10) float array or None
        Quadratic meshes only.
    order : (M,) int array or None
        Element of each entry of ``sj_ordered`` (None: element order).
    """

    count: int
    ids: np.ndarray
    degenerate: int
    min_sj: float | None
    p01_sj: float | None
    sj_ordered: np.ndarray
    node_jacobians: np.ndarray | None = None
    order: np.ndarray | None = None

    @property
    def sj(self) -> np.ndarray:
        """(M,) scaled Jacobian of every element in element order (corner tets for quadratic meshes)."""
        if self.order is None:
            return self.sj_ordered
        out = np.empty_like(self.sj_ordered)
        out[self.order] = self.sj_ordered
        return out


def _sj_kernel(F: np.ndarray, TC: np.ndarray, sj: np.ndarray) -> None:
    """Scaled Jacobian of every tet into ``sj``, (m,) float64: the compiled kernel ``validity_sj``.

    ``F`` is the (3 n,) float64 flat coordinates, ``TC`` the (4, m) int32 or int64 corner rows.
    """
    tetmorph_core.validity_sj(F, TC, sj)


def _gather_between(sj: np.ndarray, lo_v: float, hi_v: float, start: np.ndarray, out: np.ndarray) -> None:
    """The values of ``sj`` in ``[lo_v, hi_v]`` into ``out``: the compiled kernel ``validity_gather_between``.

    ``sj`` is cut into ``start.size`` equal chunks; chunk ``c``'s values go to ``out[start[c]:]``.
    """
    tetmorph_core.validity_gather_between(sj, lo_v, hi_v, start, out)


def _bracket(sj: np.ndarray, k: int) -> tuple[float, float]:
    """Values that bracket the order statistic ``k`` of ``sj`` with high probability, from a strided sample.

    The sample's order statistic at the same rank, widened by four binomial standard deviations and
    eight places each way; a miss costs a full partition, never a wrong answer.
    """
    if sj.size < _SELECT_DIRECT:
        return np.inf, -np.inf  # an empty bracket: select directly
    sample = np.sort(sj[:: sj.size // _SAMPLE])
    j = k * sample.size // sj.size
    w = int(4.0 * np.sqrt(j)) + 8
    lo = float(sample[j - w]) if j - w >= 0 else -np.inf
    hi = float(sample[j + w]) if j + w < sample.size else np.inf
    return lo, hi


def _select(sj: np.ndarray, k: int, lo: float, hi: float, counts: np.ndarray) -> float:
    """The order statistic ``k`` of ``sj`` (exact; NaN last), given the per-chunk counts below and in ``[lo, hi]``."""
    below, inside = int(counts[:, 2].sum()), int(counts[:, 3].sum())
    if not below <= k < below + inside:
        return float(np.partition(sj, k)[k])
    start = np.concatenate([[0], np.cumsum(counts[:-1, 3])]).astype(np.int64)
    out = np.empty(inside)
    _gather_between(sj, lo, hi, start, out)
    return float(np.partition(out, k - below)[k - below])


def tet_check(V: np.ndarray, T: np.ndarray, tol: float = DEGENERATE_TOL,
              rest_flat: np.ndarray | None = None, order: np.ndarray | None = None) -> CheckResult:
    """The check of linear tetrahedra in compiled, multi-threaded passes (see the module docstring).

    Parameters
    ----------
    V : (n, 3) float array
    T : (m, 4) int32 or int64 array
        The tets, in the order to visit them (``order[k]`` is the element id of ``T[k]``).
    tol : float
        Degeneracy threshold of ``|scaled Jacobian|``.
    rest_flat : (m,) bool array, optional
        Tets flat (degenerate) at rest (in ``T``'s order): counted only when inverted beyond ``tol``.
    order : (m,) int array, optional
        Element ids of the tets of ``T`` (a permutation; None: the identity). Visiting tets
        sorted by their smallest vertex keeps the vertex reads local.

    Returns
    -------
    CheckResult

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> r = tet_check(V, np.array([[0, 1, 2, 3], [0, 2, 1, 3]]))
    >>> r.count, r.ids.tolist(), round(r.min_sj, 6)
    (1, [1], -0.707107)
    """
    return _check_columns(V, np.ascontiguousarray(np.asarray(T).T), tol, rest_flat, order)


def _check_columns(V: np.ndarray, TC: np.ndarray, tol: float, rest_flat: np.ndarray | None,
                   order: np.ndarray | None) -> CheckResult:
    """:func:`tet_check` of the tets whose corners are the rows of ``TC``, (4, m) contiguous."""
    m = TC.shape[1]
    sj = np.empty(m)
    if not m:
        return CheckResult(0, np.zeros(0, np.int64), 0, None, None, sj)
    if TC.dtype not in (np.int32, np.int64):
        TC = TC.astype(np.int64)
    _sj_kernel(np.ascontiguousarray(V, dtype=np.float64).reshape(-1), TC, sj)
    k = m // 100
    lo, hi = _bracket(sj, k)
    nch = max(1, min(tetmorph_core.get_num_threads() * 4, m // 1024 or 1))
    counts = np.zeros((nch, 4), np.int64)
    first = np.empty((nch, REPORT_IDS), np.int64)
    flat = np.zeros(m, np.uint8) if rest_flat is None else rest_flat.view(np.uint8)
    # bad: sj <= tol (inverted or degenerate), or, flat at rest, sj < -tol; NaN is never bad
    tetmorph_core.validity_tally(sj, tol, flat, lo, hi, counts, first)
    count = int(counts[:, 0].sum())
    if order is None:
        ids = np.concatenate([first[c, :min(int(counts[c, 0]), REPORT_IDS)] for c in range(nch)])[:REPORT_IDS]
    elif count <= REPORT_IDS:  # every bad tet was collected: their element ids, ascending
        ids = np.sort(order[np.concatenate([first[c, :int(counts[c, 0])] for c in range(nch)])])
    else:  # the smallest element ids among many: from the scaled Jacobians
        bad = sj <= tol if rest_flat is None else np.where(rest_flat, sj < -tol, sj <= tol)
        ids = np.sort(order[np.flatnonzero(bad)])[:REPORT_IDS]
    min_sj = float(np.min(sj))  # numpy's SIMD reduction; NaN when any position was not finite
    if min_sj != min_sj:
        with np.errstate(invalid="ignore"):
            min_sj = float(np.nanmin(sj)) if not np.isnan(sj).all() else float("nan")
    return CheckResult(count, ids, int(counts[:, 1].sum()), min_sj, _select(sj, k, lo, hi, counts), sj, order=order)


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
    flat : (k,) int array, optional
        Elements the mesh's validation found flat at rest (``Mesh.degenerate_at_rest``),
        besides those whose rest scaled Jacobian is within ``DEGENERATE_TOL`` of 0.
    """

    def __init__(self, V0: np.ndarray, T: np.ndarray, cells: dict[str, np.ndarray],
                 T10: np.ndarray | None = None, flat: np.ndarray | None = None) -> None:
        small = V0.shape[0] < 2**31 - 1
        self.T = np.ascontiguousarray(T, dtype=np.int32 if small else np.int64)
        #: Tets sorted by their smallest vertex (local vertex reads), and the element id of each.
        self.order = np.argsort(self.T.min(axis=1), kind="stable") if len(self.T) else np.zeros(0, np.int64)
        #: The sorted tets' corners as four rows, (4, m): the layout the check kernel reads.
        self.T_sorted = np.ascontiguousarray(self.T[self.order].T)
        self._flat_sorted: np.ndarray | None = None
        self.cells = cells
        self.T10 = T10
        self.valid_rest = node_jacobians(V0, T10).min(axis=1) > 0 if T10 is not None else None
        self.rest_flat: np.ndarray | None = None
        rest = self.check(V0)
        is_flat = np.abs(rest.sj) <= DEGENERATE_TOL
        if flat is not None and len(flat):
            is_flat[np.asarray(flat, np.int64)] = True
        self.rest_flat = is_flat if is_flat.any() else None
        if not self.cells and self.T10 is None:  # kept: no per-check flag array (all False when none is flat)
            flat_rest = self.rest_flat if self.rest_flat is not None else np.zeros(len(self.T), bool)
            self._flat_sorted = np.ascontiguousarray(flat_rest[self.order])
        #: Elements flat at rest (zero volume), reported apart from what a morph inverts.
        self.degenerate_at_rest = np.flatnonzero(is_flat)
        self.sj_before = (rest.min_sj, rest.p01_sj)

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
        if not self.cells and self.T10 is None:
            return _check_columns(P, self.T_sorted, DEGENERATE_TOL, self._flat_sorted, self.order)
        vol6, sj = element_jacobians(P, self.T, self.cells)
        degenerate = np.abs(sj) <= DEGENERATE_TOL
        bad = (vol6 <= 0) | degenerate
        if self.rest_flat is not None:
            bad[self.rest_flat] = sj[self.rest_flat] < -DEGENERATE_TOL
        dj = None
        if self.T10 is not None:
            if placement is not None and placement.jacobians is not None and placement.P is P:
                dj = placement.jacobians
            else:
                dj = node_jacobians(P, self.T10)
            assert self.valid_rest is not None
            bad |= (dj.min(axis=1) <= 0) & self.valid_rest
        ids = np.flatnonzero(bad)
        return CheckResult(int(ids.size), ids[:REPORT_IDS], int(degenerate.sum()),
                           float(sj.min()) if sj.size else None, first_percentile(sj) if sj.size else None, sj, dj)


def triangle_quality(V: np.ndarray, F: np.ndarray, N0: np.ndarray) -> np.ndarray:
    """Signed shape quality of triangles against their rest normals: 1 equilateral, <= 0 flipped.

    ``q = 4 sqrt(3) A / (l1^2 + l2^2 + l3^2)`` with ``A`` the area signed by the
    side of the rest normal ``N0`` the current normal lies on: the triangle
    analogue of the scaled Jacobian.

    Parameters
    ----------
    V : (n, 3) float array
    F : (k, 3) int array
    N0 : (k, 3) float array
        Unit rest normals.

    Returns
    -------
    (k,) float array in [-1, 1]

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0.5, np.sqrt(3) / 2, 0]])
    >>> F = np.array([[0, 1, 2]])
    >>> up, down = np.array([[0., 0, 1]]), np.array([[0., 0, -1]])
    >>> [round(float(triangle_quality(V, F, n)[0]), 12) for n in (up, down)]
    [1.0, -1.0]
    """
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    n = np.cross(b - a, c - a)
    area2 = np.einsum("ij,ij->i", n, N0)  # twice the area, signed against the rest normal
    e2 = ((b - a) ** 2).sum(1) + ((c - b) ** 2).sum(1) + ((a - c) ** 2).sum(1)
    with np.errstate(invalid="ignore", divide="ignore"):
        q = 2.0 * np.sqrt(3.0) * area2 / e2
    return np.clip(np.nan_to_num(q, nan=0.0), -1.0, 1.0)


def enclosed_volumes(V: np.ndarray, F: np.ndarray, shell: np.ndarray, nshells: int) -> np.ndarray:
    """Signed volume enclosed by each shell of a triangle surface (divergence theorem), (nshells,)."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    v = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    return np.bincount(shell, weights=v, minlength=nshells)


class SurfaceCheck:
    """The check of a triangle surface: triangles flipped against their rest normals, or degenerate.

    A closed shell can turn inside out with every normal keeping its
    direction (a mirror image); so the enclosed volume of each closed shell is
    checked too, and all triangles of a shell whose volume changed sign
    count as inverted (:attr:`CheckResult.count`).

    Parameters
    ----------
    V0 : (n, 3) float array
    F : (k, 3) int array
    shell : (k,) int array, optional
        Component of each triangle; with ``closed``, enables the volume test.
    closed : (s,) bool array, optional
        Which shells have no open edge.
    """

    valid_rest = None

    def __init__(self, V0: np.ndarray, F: np.ndarray, shell: np.ndarray | None = None,
                 closed: np.ndarray | None = None) -> None:
        self.F = np.ascontiguousarray(F)
        a, b, c = V0[F[:, 0]], V0[F[:, 1]], V0[F[:, 2]]
        n = np.cross(b - a, c - a)
        self.N0 = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        self.shell = shell if shell is not None else np.zeros(len(F), np.int64)
        self.closed = closed if closed is not None else np.zeros(int(self.shell.max(initial=-1)) + 1, bool)
        self.vol0 = enclosed_volumes(V0, self.F, self.shell, self.closed.size)
        self.rest_flat: np.ndarray | None = None
        rest = self.check(V0)
        flat = np.abs(rest.sj) <= DEGENERATE_TOL
        self.rest_flat = flat if flat.any() else None
        #: Triangles of zero area at rest, reported apart from what a morph flips.
        self.degenerate_at_rest = np.flatnonzero(flat)
        self.sj_before = (rest.min_sj, rest.p01_sj)

    def volume_ratios(self, P: np.ndarray) -> np.ndarray:
        """Enclosed volume over rest volume of each closed shell (negative: inside out)."""
        v = enclosed_volumes(P, self.F, self.shell, self.closed.size)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.closed, v / self.vol0, np.nan)

    def check(self, P: np.ndarray, placement: Placement | None = None) -> CheckResult:
        """Check every triangle at positions ``P``."""
        q = triangle_quality(P, self.F, self.N0)
        degenerate = np.abs(q) <= DEGENERATE_TOL
        bad = (q <= 0) | degenerate
        if self.rest_flat is not None:
            bad[self.rest_flat] = q[self.rest_flat] < -DEGENERATE_TOL
        if self.closed.any():
            ratio = self.volume_ratios(P)
            inside_out = np.flatnonzero(self.closed & ~(ratio > 0))
            if inside_out.size:
                bad |= np.isin(self.shell, inside_out)
        ids = np.flatnonzero(bad)
        return CheckResult(int(ids.size), ids[:REPORT_IDS], int(degenerate.sum()),
                           float(q.min()) if q.size else None, first_percentile(q) if q.size else None, q)
