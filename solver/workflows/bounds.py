"""Safe bounds of each shape parameter: the largest values whose variants invert no element.

For every shape ``k`` and each sign, :func:`shape_bounds` searches the
parameter ``theta_k`` (the others held at ``base``, default 0 = rest) for the
largest magnitude whose variant has 0 inverted elements:

1. bracket: with a range, probe its end; without one, probe 1, 2, 4, ... up
   to :data:`MAX_VALUE`. A valid end of the range ends the search there
   (``limit: "range"``).
2. bisect between the largest valid and the smallest invalid value until they
   are ``tol`` apart.

A probe is one back-substitution and one element check (no REPORT, no policy,
no repair). All searches advance together: each round stacks one probe per
unfinished search into one multi-column back-substitution
(:func:`~solver.deform.solve.solve_positions_many`, ``block`` columns at a
time). A value whose variant is no valid MOVE (a handle turned by 360 degrees
or more, a scale out of the MOVE range) counts as invalid
(``limit: "move"``). Bisection finds one transition: it assumes the valid
set is an interval around ``base``, as it is for moderate shapes; the reported
value is always one that was solved and found valid.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..deform.deformer import Deformer
from ..deform.solve import check_positions, solve_positions_many
from ..errors import SpecError
from ..limits import BOUNDS_TOL_MAX, SHAPE_VALUE_MAX
from ..linalg.threads import solving
from ..options import using
from .plan import check_block
from .shapes import Shapes, variant_move

__all__ = ["Side", "ShapeBounds", "BoundsResult", "shape_bounds", "MAX_VALUE", "TOL"]

#: Without a range, the search probes 1, 2, 4, ... up to this value.
MAX_VALUE = 1024.0
#: Default width of the final bracket, in parameter units (1 = the basis shape).
TOL = 1e-3
#: Probes per stacked solve by default.
BLOCK = 32
#: Rounds of probes a search may take (bracketing plus bisection need far fewer).
MAX_ROUNDS = 200


@dataclass(frozen=True)
class Side:
    """The bound on one side (positive or negative values) of one shape.

    Attributes
    ----------
    value : float
        The largest-magnitude parameter found valid (0 inverted elements), signed.
    beyond : float or None
        The nearest value past it that was found invalid (None when the end
        of the range is valid).
    inverted_beyond : int or None
        Inverted elements at ``beyond`` (None when that variant is no valid MOVE).
    limit : {"inversion", "range", "move"}
        What stopped the search: elements inverted beyond ``value``; the end
        of the range is valid; the MOVE is invalid beyond ``value``.
    """

    value: float
    beyond: float | None
    inverted_beyond: int | None
    limit: str

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"value": self.value, "beyond": self.beyond, "inverted_beyond": self.inverted_beyond,
                "limit": self.limit}


@dataclass(frozen=True)
class ShapeBounds:
    """Both bounds of one shape.

    Attributes
    ----------
    shape : str
    positive, negative : Side
    probes : int
        Variants solved for this shape's two searches.
    """

    shape: str
    positive: Side
    negative: Side
    probes: int

    def to_dict(self) -> dict[str, Any]:
        """JSON form: ``{"positive": {...}, "negative": {...}, "probes": n}``."""
        return {"positive": self.positive.to_dict(), "negative": self.negative.to_dict(), "probes": self.probes}


@dataclass(frozen=True)
class BoundsResult:
    """Bounds of every shape.

    Attributes
    ----------
    shapes : list of ShapeBounds
        In ``Shapes.names`` order (only the finished ones when cancelled).
    range : (float or None, float or None)
    tol : float
    cancelled : bool
    timings : dict
        ``total_ms``, ``solves`` (stacked solves), ``probes``.
    """

    shapes: list[ShapeBounds]
    range: tuple[float | None, float | None]
    tol: float
    cancelled: bool
    timings: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON form: ``{"bounds": {SHAPE: {...}}, "range", "tol", "cancelled", "timings"}``."""
        return {"bounds": {b.shape: b.to_dict() for b in self.shapes}, "range": list(self.range),
                "tol": self.tol, "cancelled": self.cancelled, "timings": self.timings}


class _Search:
    """One side of one shape: the largest valid and the smallest invalid magnitude so far."""

    def __init__(self, k: int, sign: float, end: float | None) -> None:
        self.k, self.sign, self.end = k, sign, end
        self.ok, self.bad = 0.0, math.inf
        self.bad_count: int | None = None
        self.next_expand = 1.0
        self.done = end == 0.0
        self.limit = "range" if self.done else ""
        self.probes = 0

    def probe(self, tol: float) -> float | None:
        """The next magnitude to try, or None when finished."""
        if self.done:
            return None
        if math.isinf(self.bad):
            return self.end if self.end is not None else self.next_expand
        mid = 0.5 * (self.ok + self.bad)
        if self.bad - self.ok <= tol or not self.ok < mid < self.bad:  # (the second: floating-point resolution)
            self.done = True
            self.limit = "inversion" if self.bad_count is not None else "move"
            return None
        return mid

    def record(self, x: float, count: int | None) -> None:
        """The outcome of magnitude ``x``: inverted count, or None for an invalid MOVE."""
        self.probes += 1
        if count == 0:
            self.ok = max(self.ok, x)
            if math.isinf(self.bad):
                at_end = x == self.end or (self.end is None and x >= MAX_VALUE)
                if at_end:
                    self.done, self.limit = True, "range"
                else:
                    self.next_expand = 2.0 * x
        elif x < self.bad:
            self.bad, self.bad_count = x, count

    def side(self) -> Side:
        if self.limit == "range":
            return Side(self.sign * self.ok, None, None, "range")
        return Side(self.sign * self.ok, self.sign * self.bad, self.bad_count, self.limit)


def shape_bounds(deformer: Deformer, shapes: Shapes, *, lo: float | None = None, hi: float | None = None,
                 base: Any = None, tol: float = TOL, block: int = BLOCK,
                 progress: Callable[[int, int], None] | None = None,
                 cancelled: Callable[[], bool] | None = None) -> BoundsResult:
    """The largest positive and negative value of each shape with 0 inverted elements.

    Parameters
    ----------
    deformer : Deformer
    shapes : Shapes
    lo, hi : float, optional
        The search range, ``lo <= 0 <= hi`` (offsets from ``base``); without
        them each side probes up to :data:`MAX_VALUE`.
    base : (K,) array_like, optional
        The other parameters (default 0, the rest shape).
    tol : float
        Width of the final bracket (> 0).
    block : int
        Probes per stacked solve.
    progress : callable, optional
        ``progress(searches_done, searches_total)`` when searches finish (2 searches per shape).
    cancelled : callable, optional
        ``cancelled() -> bool`` before each round.

    Returns
    -------
    BoundsResult

    Raises
    ------
    SpecError
        A range that does not contain 0, a bad tolerance or block, a ``base``
        that is no valid variant or inverts elements itself.
    """
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and 0 < tol <= BOUNDS_TOL_MAX):
        raise SpecError(f"tol must be a number in (0, {BOUNDS_TOL_MAX:g}], got {tol!r}", code="invalid_range",
                        field="tol")
    check_block(block, "invalid_range")
    for name, v in (("lo", lo), ("hi", hi)):
        if v is not None and not (math.isfinite(v) and abs(v) <= SHAPE_VALUE_MAX):
            raise SpecError(f"range {name} must be finite and within +-{SHAPE_VALUE_MAX:g}, got {v!r}",
                            code="invalid_range", field=name)
    if (lo is not None and lo > 0) or (hi is not None and hi < 0):
        raise SpecError(f"the range [{lo}, {hi}] must contain 0 (bounds are searched from the base "
                        "parameters)", code="invalid_range", field="range")
    with using(deformer.data.options), solving():  # the precompute's options and thread cap, as its solves
        return _search(deformer, shapes, lo, hi, base, tol, block, progress, cancelled)


def _search(deformer: Deformer, shapes: Shapes, lo: float | None, hi: float | None, base: Any, tol: float,
            block: int, progress: Callable[[int, int], None] | None,
            cancelled: Callable[[], bool] | None) -> BoundsResult:
    t0 = time.perf_counter()
    K = shapes.count
    th0 = np.zeros(K) if base is None else np.asarray(base, np.float64)
    at_base = variant_move(deformer, shapes, th0, "base parameters")
    data = deformer.data
    c0 = check_positions(data, solve_positions_many(data, [at_base])[0])
    if c0 is not None and c0.count:
        raise SpecError(f"the base parameters {th0.tolist()} invert {c0.count} elements; bounds are searched "
                        "from a valid variant", code="invalid_range", field="base")
    searches = [_Search(k, s, None if end is None else abs(end))
                for k in range(K) for s, end in ((1.0, hi), (-1.0, lo))]
    solves = probes = 0
    stopped = False
    reported = -1

    def report() -> None:
        nonlocal reported
        done = sum(s.done for s in searches)
        if progress is not None and done != reported:
            progress(done, len(searches))
        reported = done

    for _ in range(MAX_ROUNDS):
        todo = [(s, x) for s in searches if (x := s.probe(tol)) is not None]
        if not todo:
            report()
            break
        if cancelled is not None and cancelled():
            stopped = True
            break
        for start in range(0, len(todo), block):
            chunk = todo[start:start + block]
            moves, slots = [], []
            for j, (s, x) in enumerate(chunk):
                th = th0.copy()
                th[s.k] += s.sign * x
                try:
                    moves.append(variant_move(deformer, shapes, th))
                    slots.append(j)
                except SpecError:
                    s.record(x, None)
            if moves:
                solved = solve_positions_many(data, moves)
                solves += 1
                for j, sv in zip(slots, solved, strict=True):
                    s, x = chunk[j]
                    c = check_positions(data, sv)
                    count = c.count if c is not None else 0
                    if not np.isfinite(sv.P).all():
                        count = max(count, 1)
                    s.record(x, count)
            probes += len(chunk)
        report()
    else:  # pragma: no cover - the rounds above are bounded by the bracket widths
        raise RuntimeError("bounds search did not converge")
    out = []
    for k, name in enumerate(shapes.names):
        pos, neg = searches[2 * k], searches[2 * k + 1]
        if stopped and not (pos.done and neg.done):
            continue
        out.append(ShapeBounds(name, pos.side(), neg.side(), pos.probes + neg.probes))
    timings = {"total_ms": 1e3 * (time.perf_counter() - t0), "solves": solves, "probes": probes}
    return BoundsResult(out, (lo, hi), float(tol), stopped, timings)
