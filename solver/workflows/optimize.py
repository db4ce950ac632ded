"""Shape optimization with a solver in the loop: the study's evaluations driven by scipy's optimizers.

::

    tetmorph optimize MESH --spec SPEC --shapes SHAPES --solver 'ccx -i {stem}' --response ccx
      --objective max_mises --constraint 'mass<=0.0157' --output 'opt/{i}/deck.inp' --history history.csv

Each evaluation is one study row (:func:`~solver.workflows.study.run_study`):
the shape parameters ``theta`` morphed (``reject`` policy: an inverting
variant is recorded and not solved), the deck written, the FE solver run and
its responses read. The optimizer sees the parameters scaled to the unit box
of their bounds, ``u = (theta - lo) / (hi - lo)``:

- ``slsqp`` (default): scipy's SLSQP, with the gradients of the objective and
  of every constraint by forward differences of step ``step`` in ``u`` (one
  evaluation per shape per iterate; the responses of one evaluation serve
  the objective and every constraint);
- ``cobyqa``: scipy's derivative-free COBYQA, for responses too noisy to
  difference.

Where the response file also defines ``gradient(deck) -> {name: (n, 3)
array}``, the derivatives of responses with respect to the node
coordinates (in the order of the mesh's points as read: an adjoint
solver's nodal sensitivities, or the user's own), SLSQP takes no
differences: each gradient is chained with tetmorph's exact ``dX/dtheta``
(:func:`~solver.workflows.sensitivities.shape_sensitivities`),
``dR/dtheta_k = sum_i dR/dX_i . dX_i/dtheta_k``, one evaluation per iterate.

The default bounds of each shape are its safe range (:func:`~solver.workflows.bounds.shape_bounds`:
the largest values either way that invert no element, each shape alone),
scaled by ``safety`` because shapes combined can invert where each alone
does not. An evaluation that fails (the morph inverts, the solver fails or
times out, the reader raises, a response is missing) ends the search: it is
recorded, and the best feasible evaluation so far is the result.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..deform.deformer import Deformer
from ..errors import SolverError
from ..mesh import Mesh
from .bounds import shape_bounds
from .doe import write_rows
from .plan import parse_plan
from .sensitivities import shape_sensitivities
from .shapes import Shapes
from .study import DEFAULT_TIMEOUT_S, Response, StudyRow, check_solver, run_study

__all__ = ["Condition", "Evaluation", "OptimizeResult", "parse_condition", "default_bounds", "run_optimize",
           "write_history", "write_plot", "METHODS"]

METHODS = ("slsqp", "cobyqa")
#: Default forward-difference step, in the unit box of the bounds.
STEP = 0.02
#: Default fraction of each shape's safe range used as its bound.
SAFETY = 0.8
#: Relative slack of a constraint counted as met (responses are read from a text file).
FEASIBLE_TOL = 1e-9

_CONDITION = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*(<=|>=)\s*([-+0-9.eE]+)\s*$")


@dataclass(frozen=True)
class Condition:
    """A response constraint ``name <= value`` or ``name >= value``."""

    name: str
    op: str
    value: float

    def slack(self, responses: dict[str, float]) -> float:
        """``>= 0`` when met: ``value - r`` for ``<=``, ``r - value`` for ``>=``."""
        r = responses[self.name]
        return self.value - r if self.op == "<=" else r - self.value

    def __str__(self) -> str:
        return f"{self.name}{self.op}{self.value:g}"


def parse_condition(text: str) -> Condition:
    """``"mass<=0.0157"`` as a :class:`Condition`.

    Raises
    ------
    SolverError
        ``usage`` for text that is not ``NAME<=NUMBER`` or ``NAME>=NUMBER``.
    """
    m = _CONDITION.match(text)
    value = float(m.group(3)) if m and _is_number(m.group(3)) else math.nan
    if m is None or not math.isfinite(value):
        raise SolverError(f"--constraint {text!r}: expected NAME<=NUMBER or NAME>=NUMBER, e.g. 'mass<=0.0157'",
                          code="usage")
    return Condition(m.group(1), m.group(2), value)


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


@dataclass
class Evaluation:
    """One evaluation of the search: a study row and what the optimizer saw.

    Attributes
    ----------
    index : int
        From 1, in the order run (the ``{i}`` of the deck path).
    iteration : int
        The optimizer's iterate it belongs to (0: the start).
    role : {"start", "iterate", "difference"}
        An iterate, or a forward-difference probe around one.
    study : StudyRow
    objective : float or None
    slacks : dict of str to float
        Each constraint's slack (``>= 0`` when met).
    gradients : dict of str to (K,) float array
        ``dR/dtheta`` of the objective and the constrained responses, when the
        response file gives ``gradient(deck)`` (chained with ``dX/dtheta``).
    """

    index: int
    iteration: int
    role: str
    study: StudyRow
    objective: float | None = None
    slacks: dict[str, float] = field(default_factory=dict)
    gradients: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def feasible(self) -> bool:
        """Solved, and every constraint met."""
        return (self.objective is not None
                and all(s >= -FEASIBLE_TOL * max(1.0, abs(s)) for s in self.slacks.values()))


@dataclass
class OptimizeResult:
    """The search.

    Attributes
    ----------
    history : list of Evaluation
    best : Evaluation or None
        The feasible evaluation with the lowest objective (highest with ``maximize``).
    start : Evaluation or None
        The first evaluation (the start point).
    status : str
        ``converged``, ``budget`` (``max_evaluations`` reached),
        ``evaluation_failed`` or ``stopped`` (the optimizer's own stop).
    message : str
    bounds : (K, 2) float array
    """

    history: list[Evaluation]
    best: Evaluation | None
    start: Evaluation | None
    status: str
    message: str
    bounds: np.ndarray


class _Stop(Exception):
    """Ends the search from inside an objective call."""

    def __init__(self, status: str, message: str) -> None:
        super().__init__(message)
        self.status, self.message = status, message


def default_bounds(deformer: Deformer, shapes: Shapes, given: dict[str, tuple[float, float]],
                   safety: float = SAFETY) -> np.ndarray:
    """Bounds ``(K, 2)``: the given ones, else ``safety`` times each shape's safe range.

    Raises
    ------
    SolverError
        ``usage`` for a bound of an unknown shape, or one with ``lo >= hi``.
    """
    unknown = sorted(set(given) - set(shapes.names))
    if unknown:
        raise SolverError(f"--bounds names {unknown}, not shapes of SHAPES (shapes: {list(shapes.names)})",
                          code="usage")
    for name, (lo, hi) in given.items():
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise SolverError(f"--bounds {name}={lo:g}:{hi:g}: needs finite LO < HI", code="usage")
    out = np.zeros((shapes.count, 2))
    todo = [k for k, n in enumerate(shapes.names) if n not in given]
    safe = {b.shape: b for b in shape_bounds(deformer, shapes).shapes} if todo else {}
    for k, name in enumerate(shapes.names):
        if name in given:
            out[k] = given[name]
        else:
            b = safe[name]
            out[k] = (safety * b.negative.value, safety * b.positive.value)
            if not out[k, 0] < out[k, 1]:
                raise SolverError(f"shape {name!r} inverts elements at any non-zero value: no range to search",
                                  code="no_range", shape=name)
    return out


def run_optimize(mesh: Mesh, deformer: Deformer, shapes: Shapes, *, output: str, solver: str, response: Response,
                 objective: str, constraints: Sequence[Condition] = (), maximize: bool = False,
                 bounds: np.ndarray, start: np.ndarray | None = None, method: str = "slsqp",
                 max_evaluations: int = 40, step: float = STEP, timeout: float = DEFAULT_TIMEOUT_S,
                 gradient: Callable[[Any], dict[str, Any]] | None = None,
                 progress: Callable[[Evaluation], None] | None = None, nastran_large: bool = False) -> OptimizeResult:
    """Minimize (or maximize) a response over the shape parameters, subject to response constraints.

    Parameters
    ----------
    mesh, deformer, shapes
        As for :func:`~solver.workflows.study.run_study`.
    output : str
        Deck path per evaluation; ``{i}`` is the evaluation (from 1).
    solver, response, timeout
        As for :func:`~solver.workflows.study.run_study`.
    objective : str
        The response to minimize.
    constraints : sequence of Condition
    maximize : bool
    bounds : (K, 2) float array
        ``lo < hi`` per shape (:func:`default_bounds`).
    start : (K,) float array, optional
        Start parameters (default 0, the rest shape, clipped into the bounds).
    method : {"slsqp", "cobyqa"}
    max_evaluations : int
        Solver runs at most (each iterate and each difference probe is one).
    step : float
        Forward-difference step in the unit box (``slsqp`` without ``gradient``).
    gradient : callable, optional
        ``gradient(deck) -> {name: (n, 3) array}``: derivatives of the objective
        and of each constrained response with respect to the node coordinates
        (``slsqp`` only); chained with ``dX/dtheta`` instead of differences.
    progress : callable, optional
        Called with each evaluation when it is done.
    nastran_large : bool
        As for :func:`~solver.workflows.doe.deck_writer`.

    Returns
    -------
    OptimizeResult

    Raises
    ------
    SolverError
        ``usage`` for a bad method, budget, step, start or bounds; ``solver_not_found``.
    """
    from scipy.optimize import NonlinearConstraint, minimize

    if method not in METHODS:
        raise SolverError(f"--method {method!r}: one of {', '.join(METHODS)}", code="usage")
    if max_evaluations < 1:
        raise SolverError(f"--max-evaluations must be >= 1, got {max_evaluations}", code="usage")
    if not 0 < step < 0.5:
        raise SolverError(f"--step must be in (0, 0.5) of the bounds' range, got {step:g}", code="usage")
    lo, hi = np.asarray(bounds, float).T
    if lo.shape != (shapes.count,) or not (lo < hi).all():
        raise SolverError(f"bounds must be ({shapes.count}, 2) with lo < hi", code="usage")
    x0 = np.zeros(shapes.count) if start is None else np.asarray(start, float)
    if x0.shape != (shapes.count,) or not np.isfinite(x0).all():
        raise SolverError(f"--start needs {shapes.count} finite values (shapes {list(shapes.names)})", code="usage")
    if gradient is not None and method != "slsqp":
        raise SolverError("response gradients are used by --method slsqp only", code="usage")
    check_solver(solver)
    sign = -1.0 if maximize else 1.0
    wanted = (objective, *dict.fromkeys(c.name for c in constraints))
    history: list[Evaluation] = []
    seen: dict[bytes, Evaluation] = {}
    state: dict[str, Any] = {"iteration": 0, "role": "start"}

    def theta(u: np.ndarray) -> np.ndarray:
        return lo + np.clip(u, 0.0, 1.0) * (hi - lo)

    def evaluate(u: np.ndarray) -> Evaluation:
        key = np.round(np.clip(u, 0.0, 1.0), 12).tobytes()
        if key in seen:
            return seen[key]
        if len(history) >= max_evaluations:
            raise _Stop("budget", f"{max_evaluations} evaluations run (--max-evaluations)")
        k = len(history) + 1
        t = theta(u)
        plan = parse_plan([dict(zip(shapes.names, t.tolist(), strict=True))])
        row = run_study(mesh, deformer, shapes, plan, output=output.replace("{i}", str(k)), solver=solver,
                        response=response, timeout=timeout, nastran_large=nastran_large)[0]
        row.row = k
        # an iterate's point belongs to the iteration it starts; probes to the iterate they difference
        ev = Evaluation(k, int(state["iteration"]) + (state["role"] == "iterate"), str(state["role"]), row)
        history.append(ev)
        seen[key] = ev
        if row.status == "ok":
            missing = [n for n in (objective, *(c.name for c in constraints)) if n not in row.responses]
            if missing:
                row.status, row.message = "response_failed", f"no response {missing} (read: {sorted(row.responses)})"
            else:
                ev.objective = row.responses[objective]
                ev.slacks = {str(c): c.slack(row.responses) for c in constraints}
                if gradient is not None:
                    _chain(ev, gradient, deformer, shapes, t, wanted)
        if progress is not None:
            progress(ev)
        if row.status != "ok":
            raise _Stop("evaluation_failed", f"evaluation {k} at {_named(shapes, t)}: {row.status}"
                        + (f" ({row.message})" if row.message else ""))
        return ev

    def f(u: np.ndarray) -> float:
        return sign * float(evaluate(u).objective)  # type: ignore[arg-type]

    def g(u: np.ndarray) -> np.ndarray:
        ev = evaluate(u)
        return np.array([ev.slacks[str(c)] for c in constraints])

    def f_chained(u: np.ndarray) -> np.ndarray:  # d/du = d/dtheta * (hi - lo)
        return sign * evaluate(u).gradients[objective] * (hi - lo)

    def g_chained(u: np.ndarray) -> np.ndarray:
        ev = evaluate(u)
        return np.stack([(1.0 if c.op == ">=" else -1.0) * ev.gradients[c.name] * (hi - lo) for c in constraints])

    def differences(fn: Callable[[np.ndarray], Any], u: np.ndarray) -> np.ndarray:
        base = np.asarray(fn(u), float)
        role, state["role"] = state["role"], "difference"
        cols = []
        try:
            for j in range(len(u)):
                h = step if u[j] + step <= 1.0 else -step  # stay inside the box
                uj = u.copy()
                uj[j] += h
                cols.append((np.asarray(fn(uj), float) - base) / h)
        finally:
            state["role"] = role
        return np.stack(cols, axis=-1)

    def advance(_: Any) -> None:
        state["iteration"] += 1
        state["role"] = "iterate"

    u0 = np.clip((x0 - lo) / (hi - lo), 0.0, 1.0)
    status, message = "converged", ""
    try:
        evaluate(u0)
        state["role"] = "iterate"
        cons = []
        if constraints:
            if method == "slsqp":
                cons = [{"type": "ineq", "fun": g,
                         "jac": g_chained if gradient is not None else (lambda u: differences(g, u))}]
            else:
                cons = [NonlinearConstraint(g, 0.0, np.inf)]
        if method == "slsqp":
            jac = f_chained if gradient is not None else (lambda u: differences(f, u))
            res = minimize(f, u0, jac=jac, bounds=[(0.0, 1.0)] * len(u0),
                           constraints=cons, method="SLSQP", callback=advance,
                           options={"maxiter": max_evaluations, "ftol": 1e-6})
        else:
            res = minimize(f, u0, bounds=[(0.0, 1.0)] * len(u0), constraints=cons, method="COBYQA",
                           callback=advance, options={"maxfev": max_evaluations})
        status = "converged" if res.success else "stopped"
        message = str(res.message)
    except _Stop as e:
        status, message = e.status, e.message
    feasible = [e for e in history if e.feasible]
    best = min(feasible, key=lambda e: sign * float(e.objective)) if feasible else None  # type: ignore[arg-type]
    return OptimizeResult(history, best, history[0] if history else None, status, message, np.c_[lo, hi])


def _chain(ev: Evaluation, gradient: Callable[[Any], dict[str, Any]], deformer: Deformer, shapes: Shapes,
           theta: np.ndarray, wanted: tuple[str, ...]) -> None:
    """``dR/dtheta`` of the wanted responses into ``ev`` from the user's ``dR/dX``, or a failed row."""
    row = ev.study
    n = deformer.data.mesh.n
    try:
        got = dict(gradient(row.deck))
        grads = {}
        for name in wanted:
            if name not in got:
                raise ValueError(f"gradient(deck) gives no {name!r} (gave {sorted(got)})")
            G = np.asarray(got[name], np.float64)
            if G.shape != (n, 3) or not np.isfinite(G).all():
                raise ValueError(f"gradient {name!r} must be a finite ({n}, 3) array, got shape {G.shape}")
            grads[name] = G
    except Exception as e:  # the user's function: whatever it raises is recorded on the row
        row.status, row.message = "response_failed", f"gradient: {type(e).__name__}: {e}"[:300]
        ev.objective, ev.slacks = None, {}
        return
    D = shape_sensitivities(deformer, shapes, theta).derivatives  # (K, n, 3)
    ev.gradients = {name: np.einsum("knj,nj->k", D, G) for name, G in grads.items()}


def _named(shapes: Shapes, t: np.ndarray) -> str:
    return ", ".join(f"{n}={v:.6g}" for n, v in zip(shapes.names, t.tolist(), strict=True))


def write_history(result: OptimizeResult, shapes: tuple[str, ...], objective: str,
                  path: str | os.PathLike[str]) -> None:
    """The history (CSV): evaluation, iteration, role, parameters, status, objective, slacks, responses, deck."""
    slack_names = list(result.history[0].slacks) if result.history and result.history[0].slacks else []
    names = sorted({k for e in result.history for k in e.study.responses} - {objective})
    fields = ["evaluation", "iteration", "role", *shapes, "status", "objective", "feasible",
              *[f"slack[{s}]" for s in slack_names], "inverted", "min_scaled_jacobian", "solver_s", *names, "deck",
              "message"]
    rows = []
    for e in result.history:
        r = e.study
        rows.append({"evaluation": e.index, "iteration": e.iteration, "role": e.role, **r.parameters,
                     "status": r.status, "objective": e.objective, "feasible": e.feasible,
                     **{f"slack[{s}]": e.slacks.get(s) for s in slack_names}, "inverted": r.inverted,
                     "min_scaled_jacobian": r.min_scaled_jacobian, "solver_s": r.solver_s,
                     **{k: v for k, v in r.responses.items() if k != objective}, "deck": r.deck,
                     "message": r.message})
    write_rows(path, fields, rows)


def write_plot(result: OptimizeResult, objective: str, path: str | os.PathLike[str]) -> None:
    """The objective of each iterate against its iteration, as an SVG line chart (difference probes left out)."""
    pts = [(e.iteration, float(e.objective)) for e in result.history
           if e.role != "difference" and e.objective is not None]
    W, H, pad = 480, 300, 48
    lines = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" '
             'font-size="12">', f'<rect width="{W}" height="{H}" fill="white"/>']
    if pts:
        xs, ys = np.array(pts).T
        x0, x1 = 0.0, max(1.0, float(xs.max()))
        y0, y1 = float(ys.min()), float(ys.max())
        y0, y1 = (y0 - 1.0, y1 + 1.0) if y0 == y1 else (y0 - 0.05 * (y1 - y0), y1 + 0.05 * (y1 - y0))
        px = pad + (xs - x0) / (x1 - x0) * (W - 1.5 * pad)
        py = H - pad - (ys - y0) / (y1 - y0) * (H - 1.5 * pad)
        xy = list(zip(px, py, strict=True))
        path_d = " ".join(f"{'M' if k == 0 else 'L'}{a:.1f},{b:.1f}" for k, (a, b) in enumerate(xy))
        lines += [f'<path d="{path_d}" fill="none" stroke="#1f77b4" stroke-width="2"/>']
        lines += [f'<circle cx="{a:.1f}" cy="{b:.1f}" r="3" fill="#1f77b4"/>' for a, b in xy]
        lines += [f'<text x="{pad}" y="{pad * 0.6:.0f}">{objective}: {ys[0]:.4g} at the start, '
                  f'{ys.min():.4g} best</text>',
                  f'<text x="{W / 2:.0f}" y="{H - 10}" text-anchor="middle">iteration</text>',
                  f'<text x="{pad - 6}" y="{H - pad:.0f}" text-anchor="end">{y0:.4g}</text>',
                  f'<text x="{pad - 6}" y="{pad:.0f}" text-anchor="end">{y1:.4g}</text>']
    lines += [f'<line x1="{pad}" y1="{H - pad}" x2="{W - pad / 2}" y2="{H - pad}" stroke="black"/>',
              f'<line x1="{pad}" y1="{pad / 2}" x2="{pad}" y2="{H - pad}" stroke="black"/>', "</svg>"]
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
